"""Wall time per time step of scene 1 (rails) and scene 2 (abs), and of each film kernel.

Cases (``--case``, all by default):

* ``rails-101x21``: scene 1 with mu = 0.5, alpha = 0.85 on its default grid (dt 0.4 us, 750 steps);
* ``rails-201x21``: the same on the source's 201 x 21 grid;
* ``abs-121x101``: scene 2 (studies/scenes/chen_bogy2007.toml, 121 x 101, its dt) from steady flight;
* ``abs-stuck``: the same at delta_gamma 0.08 J/m2 (Table I's stuck cell), held on the disk from its start;
* ``abs-mtp``: the micro-pad design (studies/scenes/chen_bogy2007_mtp.toml: asperity adhesion, contact damping).

Scene 1 reports a run's wall and CPU time over its steps (setting up a run
costs a few steps).  Scene 2 sets up a steady film (a sparse Newton solve)
at the start of every run, so it reports the difference of a long and a
short run per extra step (``--abs-steps`` of them, 100 by default: a few tenths
of a second of a flying run, which this shared machine's load has moved by half;
use 500 or more for a verdict).  The median per case is printed at the end; CPU
time is the less sensitive to other processes on a shared machine.

A/B comparison against untouched copies of the package: ``--against DIR
[DIR ...]`` (each DIR holds a ``solver/`` folder) runs this script in fresh
processes, alternating between the DIRs and this tree (A B, then B A, ...),
so that the load of a shared machine hits all alike, and prints the medians
and their ratios to the first DIR.  (The solver imports itself by absolute
name, so two copies cannot share a process.)  Scenes are read here, without
the pipeline, so that any copy of ``solver/`` can be timed.

    python bench/step_timing.py                                # every case, 7 repeats
    python bench/step_timing.py --case abs-121x101 --repeats 5
    cp -r solver /tmp/old/   # before editing, then:
    python bench/step_timing.py --against /tmp/old --rounds 6 --repeats 3
    python bench/step_timing.py --kernels                      # median time of each film kernel per call

``--concurrent N`` runs N processes of a tree at once in every round, each waiting behind a file
barrier until all N have built their timers (steady flight, warm-up), so that their timed runs
overlap: whether a speed-up holds when every core of the machine runs a study (one dask worker per
core), not only on an idle machine.

    python bench/step_timing.py --case abs-121x101 --against /tmp/old --rounds 3 --repeats 3 --concurrent 2
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RAILS_SCENE = ROOT / "studies" / "scenes" / "benson1989.toml"
ABS_SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"
MTP_SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007_mtp.toml"
OVERRIDES = {"contact.mu": 0.5, "contact.alpha": 0.85}
#: Scene 2: steps of the short run; the long one has ``--abs-steps`` more, and their difference is timed.
ABS_SHORT = 10
#: Scene 2: steps timed by default (the difference of the two runs).  100 steps is a few tenths of a second of a
#: flying run, short enough for this shared machine's load to move one sample by half: use more for a verdict.
ABS_STEPS = 100
CASES = {
    "rails-101x21": (RAILS_SCENE, OVERRIDES),
    "rails-201x21": (RAILS_SCENE, {**OVERRIDES, "numerics.nx": 201}),
    "abs-121x101": (ABS_SCENE, {"numerics.settle_time": 0.0}),
    # Table I's stuck cell (dgamma 0.08): no flying equilibrium, the run starts held on the disk beyond the fold,
    # every step split into 8 contact substeps with the pad's cells near the wall
    "abs-stuck": (ABS_SCENE, {"numerics.settle_time": 0.0, "contact.delta_gamma": 0.08, "initial.zdot_spread": 1e-6}),
    "abs-mtp": (MTP_SCENE, {"numerics.settle_time": 0.0}),
}


def load_scene(path: Path, overrides: dict[str, object]):
    """The scene of a scene file with ``{"section.key": value}`` overrides (validated by the solver)."""
    from solver.kinds import scene_from_dict

    data = tomllib.loads(path.read_text())
    for key, value in overrides.items():
        section, _, name = key.partition(".")
        data.setdefault(section, {})[name] = value
    return scene_from_dict(data, source=str(path))


def per_step(run: Callable[[], int]) -> tuple[float, float]:
    """(wall, CPU) seconds of ``run()`` over the steps it returns."""
    wall, cpu = time.perf_counter(), time.process_time()
    steps = run()
    return (time.perf_counter() - wall) / steps, (time.process_time() - cpu) / steps


def rails_timer(overrides: dict[str, object]) -> Callable[[], tuple[float, float]]:
    """A function running scene 1 and returning its (wall, CPU) seconds per step."""
    from solver.rails.integrate import simulate
    from solver.rails.steady import fly

    scene = load_scene(RAILS_SCENE, overrides)
    steady = fly(scene)
    simulate(scene, steady)  # warm-up (JIT, caches)
    return lambda: per_step(lambda: simulate(scene, steady).work["steps"])


def abs_timer(path: Path, overrides: dict[str, object], steps: int = ABS_STEPS) -> Callable[[], tuple[float, float]]:
    """A function running a scene-2 file twice (ABS_SHORT steps, and ``steps`` more) and returning the (wall, CPU)
    seconds per extra step."""
    from solver.abs.integrate import simulate_abs
    from solver.abs.steady import fly_start

    dt = load_scene(path, overrides).numerics.dt
    n_short, n_long = ABS_SHORT, ABS_SHORT + steps
    short, long = (load_scene(path, {**overrides, "numerics.t_end": n * dt}) for n in (n_short, n_long))
    steady = fly_start(short)
    simulate_abs(short, steady)  # warm-up (JIT, caches)

    def run(scene) -> int:
        r = simulate_abs(scene, steady)
        if r.status != 0:
            raise RuntimeError(f"scene 2 run failed: {r.message}")
        return r.work["steps"]

    def once() -> tuple[float, float]:
        t_short = per_step(lambda: run(short))
        t_long = per_step(lambda: run(long))
        return tuple((b * n_long - a * n_short) / (n_long - n_short) for a, b in zip(t_short, t_long, strict=True))

    return once


def wait_for_peers(barrier: Path, peers: int, timeout: float = 600.0) -> None:
    """Mark this process ready in the folder ``barrier`` and wait until ``peers`` processes are."""
    (barrier / str(os.getpid())).touch()
    start = time.monotonic()
    while sum(1 for _ in barrier.iterdir()) < peers:
        if time.monotonic() - start > timeout:
            raise RuntimeError(f"barrier {barrier}: fewer than {peers} processes ready after {timeout:.0f} s")
        time.sleep(0.01)


def step_times(
    cases: list[str], repeats: int, barrier: Path | None = None, peers: int = 1, abs_steps: int = ABS_STEPS
) -> dict[str, list[tuple[float, float]]]:
    """(wall, CPU) seconds per step of each case, ``repeats`` samples each, cases interleaved.

    With ``barrier``, the timing starts once ``peers`` processes have built their timers (:func:`wait_for_peers`).
    """
    timers = {
        case: abs_timer(path, overrides, abs_steps) if path != RAILS_SCENE else rails_timer(overrides)
        for case, (path, overrides) in ((case, CASES[case]) for case in cases)
    }
    if barrier is not None:
        wait_for_peers(barrier, peers)
    samples: dict[str, list[tuple[float, float]]] = {case: [] for case in cases}
    for _ in range(repeats):
        for case, once in timers.items():
            samples[case].append(once())
    return samples


def kernel_calls() -> dict[str, Callable[[], object]]:
    """One call of the film steps and of the main scene-1 kernels on the steady films, by name."""
    from solver.abs.film import AbsFilm
    from solver.abs.steady import fly_start
    from solver.kernels import reynolds as kr
    from solver.rails.film import make_film
    from solver.rails.steady import fly

    scene = load_scene(RAILS_SCENE, OVERRIDES)
    steady = fly(scene)
    film = make_film(scene)
    P0 = steady.pressure / scene.air.ambient_pressure
    q_old = steady.q.copy()
    q_new = q_old + np.array([-0.01, 5.0, 10.0]) * scene.numerics.dt
    film.fill_spacing(0.5 * (q_old + q_new), film.H_mid, film.Hx_mid, film.Hy_mid)
    out = [np.zeros_like(P0) for _ in range(7)]  # R, Jcx, Jxm, Jxp, Jcy, Jym, Jyp
    diag = film.sigma / scene.numerics.dt * film.area[None] * film.H_mid
    rhs, delta, work = np.zeros_like(P0), np.empty_like(P0), np.empty_like(P0)
    rhs[:, 1:-1, 1:-1] = 1e-6

    def step() -> None:
        film.P = P0.copy()
        film.step(q_old, q_new, scene.numerics.dt)

    def assemble() -> None:
        geometry = (film.H_mid, film.Hx_mid, film.Hy_mid, film.dx, film.dy, film.dxc, film.dyc)
        kr.assemble(P0, *geometry, film.lam, film.kn, film.c1, film.c2, *out, True)

    abs_scene = load_scene(ABS_SCENE, CASES["abs-121x101"][1])
    abs_film = AbsFilm(abs_scene)
    abs_steady = fly_start(abs_scene, abs_film)
    abs_P0 = abs_film.P.copy()
    disk = np.zeros(abs_film.shape)
    abs_q_new = abs_steady.q + np.array([-1e-10, 1e-7, 1e-7])

    def abs_step() -> None:
        abs_film.P[...] = abs_P0
        abs_film.step(abs_steady.q, abs_q_new, disk, disk, abs_scene.numerics.dt)

    kernels: dict[str, Callable[[], object]] = {
        "film.step": step,
        "fill_spacing": lambda: film.fill_spacing(q_new, film.H, film.Hx, film.Hy),
        "assemble": assemble,
        "af_solve": lambda: kr.af_solve(diag, *out[1:], rhs, 0.5, delta, work),
        "load_moments": lambda: kr.load_moments(P0, film.area, film.x, film.y_abs),
        "abs film.step": abs_step,
    }
    for f in kernels.values():
        f()
    return kernels


def kernel_times(repeats: int, calls: int = 100) -> dict[str, float]:
    """Median seconds per call of each film kernel."""
    calls_of = kernel_calls()
    samples: dict[str, list[float]] = {name: [] for name in calls_of}
    for _ in range(repeats):
        for name, f in calls_of.items():
            t0 = time.perf_counter()
            for _ in range(calls):
                f()
            samples[name].append((time.perf_counter() - t0) / calls)
    return {name: statistics.median(v) for name, v in samples.items()}


def compare(
    others: list[Path], cases: list[str], rounds: int, repeats: int, concurrent: int = 1, abs_steps: int = ABS_STEPS
) -> None:
    """Interleaved A/B: fresh processes taking turns on the trees ``others`` and this one, medians and ratios.

    With ``concurrent`` > 1, each turn runs that many processes of the tree at once, timed together behind a
    barrier; a round's samples of a tree are then all of its processes' runs.

    Besides the medians over all runs, the ratio to the first tree is taken per round (the median of
    each process's runs over that of the first tree's process in the same round) and its median over
    the rounds printed: load that drifts over minutes cancels in it.
    """
    trees = [*(t.resolve() for t in others), ROOT]
    per_round = {tree: {c: [] for c in cases} for tree in trees}  # [round][run] -> (wall, cpu)
    for k in range(rounds):
        for tree in trees[k % len(trees) :] + trees[: k % len(trees)]:
            env = {**os.environ, "PYTHONPATH": str(tree)}
            cmd = [sys.executable, __file__, "--json", "--repeats", str(repeats), "--abs-steps", str(abs_steps),
                   "--case", *cases]  # fmt: skip
            with tempfile.TemporaryDirectory(prefix="step_timing_barrier_") as barrier:
                if concurrent > 1:
                    cmd += ["--barrier", barrier, "--peers", str(concurrent)]
                procs = [
                    subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                    for _ in range(concurrent)
                ]
                outputs = [(p, *p.communicate()) for p in procs]
            samples = {case: [] for case in cases}
            for p, out, err in outputs:
                if p.returncode != 0:
                    raise RuntimeError(f"the run on {tree} failed ({p.returncode}): {err.strip()[-2000:]}")
                report = json.loads(out.splitlines()[-1])
                if Path(report["solver"]).resolve() != tree / "solver" / "__init__.py":
                    raise RuntimeError(f"the run on {tree} imported {report['solver']}")
                for case in cases:
                    samples[case] += report["samples"][case]
            for case in cases:
                per_round[tree][case].append(samples[case])
    together = f", {concurrent} processes at once" if concurrent > 1 else ""
    print(f"{rounds} rounds per tree{together}, {repeats} runs per process and case; ms per step, wall and CPU time;")
    print("ratios to the first tree: of the medians / median of the per-round ratios (speed = 1 / time)")
    for case in cases:
        base = per_round[trees[0]][case]
        for tree in trees:
            rows = per_round[tree][case]
            text = []
            for m, what in enumerate(("wall", "CPU")):
                med = statistics.median(run[m] for runs in rows for run in runs)
                med0 = statistics.median(run[m] for runs in base for run in runs)
                paired = statistics.median(
                    statistics.median(r[m] for r in b) / statistics.median(r[m] for r in a)
                    for a, b in zip(base, rows, strict=True)
                )
                text.append(f"{what} {med * 1e3:8.4f} time {med / med0:.3f} / {paired:.3f}")
            print(f"{case:13s} {'  '.join(text)}  (n = {sum(map(len, rows))})  {tree}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", nargs="+", choices=list(CASES), default=list(CASES), help="cases to time")
    ap.add_argument("--repeats", type=int, default=7, help="runs per case (per process with --against)")
    ap.add_argument("--against", type=Path, nargs="+", help="folders holding other solver/ copies to compare with")
    ap.add_argument("--rounds", type=int, default=6, help="processes per tree with --against")
    ap.add_argument("--kernels", action="store_true", help="time the film kernels one by one instead")
    ap.add_argument("--concurrent", type=int, default=1, help="with --against: processes of a tree timed at once")
    ap.add_argument("--json", action="store_true", help="print the samples as one JSON line")
    ap.add_argument("--abs-steps", type=int, default=ABS_STEPS,
                    help=f"scene-2 steps timed per sample (default {ABS_STEPS}; more on a loaded machine)")  # fmt: skip
    ap.add_argument("--barrier", type=Path, help=argparse.SUPPRESS)  # set by --concurrent for its processes
    ap.add_argument("--peers", type=int, default=1, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.concurrent < 1:
        ap.error(f"--concurrent = {args.concurrent}: at least 1 process")
    if args.abs_steps < 1:
        ap.error(f"--abs-steps = {args.abs_steps}: at least 1 step")
    if args.kernels:
        print("  ".join(f"{k} {v * 1e6:.1f} us" for k, v in kernel_times(args.repeats).items()))
        return
    if args.against is not None:
        compare(args.against, args.case, args.rounds, args.repeats, args.concurrent, args.abs_steps)
        return
    samples = step_times(args.case, args.repeats, args.barrier, args.peers, args.abs_steps)
    if args.json:
        import solver

        print(json.dumps({"solver": solver.__file__, "samples": samples}))
        return
    for case, values in samples.items():
        wall, cpu = (statistics.median(v[m] for v in values) for m in (0, 1))
        print(f"{case:13s} median {wall * 1e3:.4f} ms/step wall, {cpu * 1e3:.4f} CPU  ({len(values)} runs)")


if __name__ == "__main__":
    main()
