"""How often does a setting land a track of the flying default cell that the fine reference flies?

A rare landing (a track whose mean contact force jumps from a fraction of a uN to tens or hundreds) cannot be seen
in the bench's 16 tracks, yet it sets most of a flying cell's mean contact force.  This script runs the bench's
settings (``pipeline.bench.abs.SETTINGS``, and the ``STUDIED`` ones it does not time: the same overrides and step)
on many tracks, then the bench's fine reference (the default at dt / 4) on every track where one of them landed,
and reports per setting the statistics with their 95 % intervals, the landings with a Wilson interval, Fisher's
exact test against the first setting, and the paired differences.  Records go to a JSON-lines file, one per run; a
rerun skips the runs already there.

    python bench/rare_landings.py --setting default --setting "2 dt, secant" --seeds 17-200 -o landings.jsonl
    python bench/rare_landings.py --reference -o landings.jsonl      # the reference where a setting landed
    python bench/rare_landings.py --setting "default dt/4" --seeds 17-200 -o landings.jsonl  # ... or on every track
    python bench/rare_landings.py --report -o landings.jsonl         # the table only
    python bench/rare_landings.py --time 5 --seeds 201 --setting default --setting "2 dt, trapezoid, gap 1 nm"
                                                                     # CPU per run, alternated in one process

The reference's runs where a setting landed tell whether those tracks land at all; only its runs on every track give
its own landing rate, against which a setting's is compared (a chaotic landing moves between tracks with any change
of the numerics).

A default run costs about 11 s of CPU, `2 dt, secant` 7 s and the reference 40 s (2026-11-29).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))  # its sibling, run as a script or loaded by a test
from statistics_grid import ROOT, SCENE, mean_ci, parse_range, read  # noqa: E402

#: A track whose mean contact force exceeds this [N] has landed (the flying cell's tracks stay below 2 uN at dt / 4).
LANDING = 5e-6
MEASURES = (("bouncing_3sigma", 1e9, "nm"), ("mean_contact_force", 1e6, "uN"), ("mean_flying_height", 1e9, "nm"))


def wilson(k: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson's 95 % score interval of a proportion k / n."""
    p, d = k / n, 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / d
    half = z * math.sqrt(p * (1.0 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, centre - half), min(1.0, centre + half)


def settings() -> dict[str, tuple[dict, float]]:
    from pipeline.bench.abs import REFERENCE, SETTINGS, STUDIED

    return {name: (overrides, factor) for name, _, overrides, factor in (*SETTINGS, *STUDIED, REFERENCE)}


def run(names: list[str], seeds: list[int], out: Path) -> None:
    from pipeline.bench.abs import setting_overrides
    from pipeline.config import load_scene
    from pipeline.provenance import git_commit
    from solver.abs.integrate import simulate_abs, summarize
    from solver.abs.steady import fly_start

    known = settings()
    done = {(r["setting"], r["seed"]) for r in read(out)}
    steady = None
    for seed in seeds:
        for name in names:
            if (name, seed) in done:
                continue
            overrides, factor = known[name]
            scene = load_scene(str(SCENE), {**setting_overrides(str(SCENE), {}, overrides, factor), "disk.seed": seed})
            steady = steady or fly_start(scene)
            wall, cpu = time.perf_counter(), time.process_time()
            result = simulate_abs(scene, steady=steady)
            record = {"setting": name, "seed": seed, "status": result.status, "message": result.message,
                      "wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu,
                      "git_commit": git_commit(), **summarize(result, scene),
                      **{f"work_{k}": v for k, v in result.work.items()}}  # fmt: skip
            with out.open("a") as f:
                f.write(json.dumps(record) + "\n")
            print(f"{name} seed {seed}: 3-sigma {record['bouncing_3sigma'] * 1e9:.3f} nm, contact "
                  f"{record['mean_contact_force'] * 1e6:.2f} uN, {record['cpu']:.0f} s", flush=True)  # fmt: skip


def time_runs(names: list[str], seed: int, repeats: int) -> None:
    """CPU time of a 1-ms run of each setting on track ``seed``, the settings alternated ``repeats`` times in this
    process (the kernels loaded and the steady flight solved before): medians, ranges and ratios to the first."""
    from pipeline.bench.abs import setting_overrides
    from pipeline.config import load_scene
    from solver.abs.integrate import simulate_abs
    from solver.abs.steady import fly_start

    known = settings()
    overrides = {n: {**setting_overrides(str(SCENE), {}, *known[n]), "disk.seed": seed} for n in names}
    scenes = {n: load_scene(str(SCENE), o) for n, o in overrides.items()}
    steady = fly_start(scenes[names[0]])
    for n in names:  # load (or compile) the kernels outside the timing
        simulate_abs(load_scene(str(SCENE), overrides[n] | {"numerics.t_end": 4e-6, "numerics.settle_time": 0.0}),
                     steady=steady)  # fmt: skip
    cpu: dict[str, list[float]] = {n: [] for n in names}
    for _ in range(repeats):
        for n in names:
            t0 = time.process_time()
            simulate_abs(scenes[n], steady=steady)
            cpu[n].append(time.process_time() - t0)
            print(f"{n}: {cpu[n][-1]:.2f} s", flush=True)
    base = float(np.median(cpu[names[0]]))
    for n in names:
        num = scenes[n].numerics
        m = float(np.median(cpu[n]))
        print(f"  {n:40s} CPU median {m:.2f} s ({min(cpu[n]):.2f}-{max(cpu[n]):.2f}), "
              f"{m / round(num.t_end / num.dt) * 1e3:.3f} ms a step, {m / (num.t_end / 1e-3):.2f} s per simulated ms, "
              f"ratio {m / base:.3f}")  # fmt: skip


def by_setting(path: Path) -> dict[str, dict[int, dict]]:
    table: dict[str, dict[int, dict]] = {}
    for r in read(path):
        if r["status"] == 0:
            table.setdefault(r["setting"], {})[r["seed"]] = r
    return table


def landed_seeds(table: dict[str, dict[int, dict]], reference: str) -> list[int]:
    return sorted({s for name, runs in table.items() if name != reference for s, r in runs.items()
                   if r["mean_contact_force"] > LANDING})  # fmt: skip


def report(path: Path, reference: str) -> None:
    """The table of the runs in ``path``: per setting its statistics, landings and cost, each paired with the first
    setting and, where the reference ran on every track, with the reference (then a row of its own too)."""
    table = by_setting(path)
    names = [n for n in settings() if n in table and n != reference]  # in the bench's order: the default first
    if not names:
        raise SystemExit(f"{path}: no finished runs of a setting (is it a file this script wrote with -o?)")
    first = names[0]
    common = sorted(set.intersection(*(set(table[n]) for n in names)))
    ref = table.get(reference, {})
    everywhere = all(s in ref for s in common)  # the reference on every track: its landings are a rate too
    print(f"{len(common)} tracks run by every setting ({', '.join(names)}), seeds {common[0]}-{common[-1]}"
          + (f"; the reference ({reference}) on all of them" if everywhere else ""))  # fmt: skip
    for name in names + ([reference] if everywhere else []):
        runs = [table[name][s] for s in common]
        cells = [f"{m:.5g} +- {h:.2g} {unit}" for key, scale, unit in MEASURES
                 for m, h in [mean_ci([r[key] * scale for r in runs])]]  # fmt: skip
        k = sum(r["mean_contact_force"] > LANDING for r in runs)
        lo, hi = wilson(k, len(runs))
        line = f"  {name:20s} " + "  ".join(cells) + f"  landed {k} ({100 * lo:.1f}-{100 * hi:.1f} %)"
        line += f"  CPU median {np.median([r['cpu'] for r in runs]):.1f} s"
        if all("work_reynolds_solves" in r for r in runs):  # the film solves: a cost that the machine's load leaves
            line += f", film solves median {np.median([r['work_reynolds_solves'] for r in runs]):.0f}"
        for other in (first, reference if everywhere else None):
            if other is None or other == name or name == reference:
                continue
            k0 = sum(table[other][s]["mean_contact_force"] > LANDING for s in common)
            p = stats.fisher_exact([[k, len(common) - k], [k0, len(common) - k0]], alternative="greater").pvalue
            paired = []
            for key, scale, unit in MEASURES:
                m, h = mean_ci([(table[name][s][key] - table[other][s][key]) * scale for s in common])
                paired.append(f"{m:+.3g} +- {h:.2g} {unit}")
            line += ("\n  " + " " * 21 + f"paired with {other}: " + "  ".join(paired)
                     + f"  (Fisher, lands more: p = {p:.2g})")  # fmt: skip
        print(line)
    landed = landed_seeds(table, reference)
    if everywhere:  # and the reference's own landings
        landed = sorted(set(landed) | {s for s in common if ref[s]["mean_contact_force"] > LANDING})
    print(f"landings (mean contact force > {LANDING * 1e6:g} uN) and the reference ({reference}) on their tracks:")
    for s in landed:
        row = "  ".join(f"{n} {table[n][s]['mean_contact_force'] * 1e6:.2f}" for n in names if s in table[n])
        there = (
            f"{ref[s]['bouncing_3sigma'] * 1e9:.3f} nm, {ref[s]['mean_contact_force'] * 1e6:.2f} uN"
            if s in ref
            else "not run"
        )
        print(f"  seed {s}: {row} uN; reference: {there}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--setting", action="append", default=[], help="a setting of the bench (repeat the option)")
    parser.add_argument("--seeds", default="17-48", help="tracks: 'LO-HI' or '1,3,5'")
    parser.add_argument("--reference", action="store_true", help="run the reference on every landed track")
    parser.add_argument("--report", action="store_true", help="only print the table of -o's runs")
    parser.add_argument("--time", type=int, default=0, metavar="N",
                        help="only time the settings on the first of --seeds, alternated N times (no -o)")  # fmt: skip
    parser.add_argument("-o", "--output", type=Path, help="JSON-lines file of the runs")
    args = parser.parse_args(argv)
    known = settings()
    reference = list(known)[-1]
    unknown = [n for n in args.setting if n not in known]
    if unknown:
        raise SystemExit(f"--setting {unknown[0]!r} is not allowed: one of {', '.join(map(repr, known))}")
    if args.time:
        if not args.setting:
            raise SystemExit("--time needs at least one --setting")
        time_runs(args.setting, parse_range(args.seeds)[0], args.time)
        return 0
    if args.output is None:
        raise SystemExit("-o/--output is required (the JSON-lines file of the runs), except with --time")
    if args.setting and not args.report:
        run(args.setting, parse_range(args.seeds), args.output)
    if args.reference and not args.report:
        run([reference], landed_seeds(by_setting(args.output), reference), args.output)
    report(args.output, reference)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
