"""Are scene 2's run statistics converged on the grid?  The default run on several grids, track by track.

Each (grid, seed) is one 1-ms run of ``studies/scenes/chen_bogy2007.toml`` from its own steady flight; a seed is
the same track on every grid (box-filtered over each grid's cells), so the runs pair.  Records go to a JSON-lines
file, one per run, and a rerun skips the runs already there (kill it and start again: it resumes).  The report
gives, per grid, the mean and 95 % half-width of the 3-sigma bouncing, mean flying height, mean contact force and
contact fraction, and the paired difference of every grid to the finest.

    python bench/statistics_grid.py --grids 121x101,161x135,181x151,241x201 --seeds 1-4 -o grid.jsonl
    python bench/statistics_grid.py --grids 121x101,241x201 --seeds 5-8 -o grid.jsonl   # more tracks, two grids
    python bench/statistics_grid.py --report -o grid.jsonl                             # the table only

A default run costs about 45 s at 121 x 101 and 170 s at 241 x 201 on one core.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"
MEASURES = (
    ("bouncing_3sigma", 1e9, "nm"),
    ("mean_flying_height", 1e9, "nm"),
    ("mean_contact_force", 1e6, "uN"),
    ("contact_fraction", 100.0, "%"),
)


def parse_range(text: str) -> list[int]:
    """'1-4' or '1,3,5' -> the seeds."""
    if "-" in text:
        lo, hi = (int(v) for v in text.split("-"))
        return list(range(lo, hi + 1))
    return [int(v) for v in text.split(",")]


def run(grids: list[tuple[int, int]], seeds: list[int], out: Path) -> None:
    from solver.abs.integrate import simulate_abs, summarize
    from solver.kinds import scene_from_dict

    done = {(r["nx"], r["ny"], r["seed"]) for r in read(out)}
    for seed in seeds:
        for nx, ny in grids:
            if (nx, ny, seed) in done:
                continue
            data = tomllib.loads(SCENE.read_text())
            data["numerics"].update(nx=nx, ny=ny)
            data["disk"]["seed"] = seed
            scene = scene_from_dict(data, source=str(SCENE))
            wall = time.perf_counter()
            result = simulate_abs(scene)
            record = {"nx": nx, "ny": ny, "seed": seed, "status": result.status, "message": result.message,
                      "wall": time.perf_counter() - wall, **summarize(result, scene)}  # fmt: skip
            with out.open("a") as f:
                f.write(json.dumps(record) + "\n")
            print(f"{nx} x {ny} seed {seed}: 3-sigma {record['bouncing_3sigma'] * 1e9:.3f} nm, "
                  f"{record['wall']:.0f} s", flush=True)  # fmt: skip


def read(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def mean_ci(values: list[float]) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    half = stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size) if v.size > 1 else float("nan")
    return float(v.mean()), float(half)


def report(path: Path) -> None:
    records = [r for r in read(path) if r["status"] == 0]
    by_grid: dict[tuple[int, int], dict[int, dict]] = {}
    for r in records:
        by_grid.setdefault((r["nx"], r["ny"]), {})[r["seed"]] = r
    if not by_grid:
        raise SystemExit(f"{path}: no finished runs")
    finest = max(by_grid)
    for name, scale, unit in MEASURES:
        print(name)
        for grid in sorted(by_grid):
            runs = by_grid[grid]
            m, h = mean_ci([runs[s][name] * scale for s in sorted(runs)])
            line = f"  {grid[0]:3d} x {grid[1]:<3d} n = {len(runs)}: {m:.4g} +- {h:.2g} {unit}"
            common = sorted(set(runs) & set(by_grid[finest]))
            if grid != finest and len(common) > 1:
                dm, dh = mean_ci([(runs[s][name] - by_grid[finest][s][name]) * scale for s in common])
                line += f"   paired with {finest[0]} x {finest[1]} (n = {len(common)}): {dm:+.3g} +- {dh:.2g}"
            print(line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--grids", default="121x101,241x201", help="NXxNY,... (default: 121x101,241x201)")
    parser.add_argument("--seeds", default="1-8", help="track seeds, '1-8' or '1,2,5'")
    parser.add_argument("-o", "--out", type=Path, default=Path("statistics_grid.jsonl"))
    parser.add_argument("--report", action="store_true", help="only print the table of the runs in --out")
    args = parser.parse_args()
    if not args.report:
        grids = [tuple(int(v) for v in g.split("x")) for g in args.grids.split(",")]
        run(grids, parse_range(args.seeds), args.out)
    report(args.out)


if __name__ == "__main__":
    main()
