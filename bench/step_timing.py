"""Wall time per time step of the scene-1 contact run, and of each film kernel.

Runs ``simulate`` on scene 1 (mu = 0.5, alpha = 0.85) several times and
prints the median wall time per step.  Several solver packages can be timed
side by side, interleaved so that the load of a shared machine hits them
alike, e.g. against an untouched copy ``solver_orig`` of the package:

    python bench/step_timing.py                       # this solver, 7 repeats
    PYTHONPATH=/tmp/old python bench/step_timing.py solver solver_orig --repeats 9
    python bench/step_timing.py --kernels             # median time of each film kernel per call
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import time
from collections.abc import Callable

import numpy as np

from pipeline.cli import DEFAULT_SCENE
from pipeline.config import load_scene

OVERRIDES = ["contact.mu=0.5", "contact.alpha=0.85"]


def run_timer(package: str) -> Callable[[], tuple[float, list]]:
    """A function running scene 1 with ``package`` and returning (s per step, impacts)."""
    integrate = importlib.import_module(f"{package}.integrate")
    steady_mod = importlib.import_module(f"{package}.steady")
    scene = load_scene(DEFAULT_SCENE, OVERRIDES)
    steady = steady_mod.fly(scene)
    integrate.simulate(scene, steady)  # warm-up (JIT, caches)

    def once() -> tuple[float, list]:
        r = integrate.simulate(scene, steady)
        return r.work["wall_time"] / r.work["steps"], r.impacts

    return once


def kernel_calls(package: str) -> dict[str, Callable[[], object]]:
    """One call of the film step and of its main kernels of ``package`` on the steady scene-1 film, by name."""
    kr = importlib.import_module(f"{package}.kernels.reynolds")
    airbearing = importlib.import_module(f"{package}.airbearing")
    steady_mod = importlib.import_module(f"{package}.steady")
    scene = load_scene(DEFAULT_SCENE, OVERRIDES)
    steady = steady_mod.fly(scene)
    film = airbearing.make_film(scene)
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

    kernels: dict[str, Callable[[], object]] = {
        "film.step": step,
        "fill_spacing": lambda: film.fill_spacing(q_new, film.H, film.Hx, film.Hy),
        "assemble": assemble,
        "af_solve": lambda: kr.af_solve(diag, *out[1:], rhs, 0.5, delta, work),
        "load_moments": lambda: kr.load_moments(P0, film.area, film.x, film.y_abs),
    }
    for f in kernels.values():
        f()
    return kernels


def kernel_times(packages: list[str], repeats: int, calls: int = 300) -> dict[str, dict[str, float]]:
    """Median seconds per call of each film kernel, packages interleaved."""
    calls_of = {pkg: kernel_calls(pkg) for pkg in packages}
    samples = {pkg: {name: [] for name in calls_of[pkg]} for pkg in packages}
    for _ in range(repeats):
        for pkg in packages:
            for name, f in calls_of[pkg].items():
                t0 = time.perf_counter()
                for _ in range(calls):
                    f()
                samples[pkg][name].append((time.perf_counter() - t0) / calls)
    return {pkg: {name: statistics.median(v) for name, v in s.items()} for pkg, s in samples.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("packages", nargs="*", default=["solver"], help="importable solver packages to time")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--kernels", action="store_true", help="time the film kernels one by one instead")
    args = ap.parse_args()
    if args.kernels:
        for pkg, times in kernel_times(args.packages, args.repeats).items():
            print(f"{pkg:14s}", "  ".join(f"{k} {v * 1e6:.1f} us" for k, v in times.items()))
        return
    timers = {pkg: run_timer(pkg) for pkg in args.packages}
    samples: dict[str, list[float]] = {pkg: [] for pkg in args.packages}
    impacts: dict[str, list] = {}
    for _ in range(args.repeats):
        for pkg, once in timers.items():
            per_step, impacts[pkg] = once()
            samples[pkg].append(per_step)
    base = statistics.median(samples[args.packages[0]])
    for pkg in args.packages:
        med = statistics.median(samples[pkg])
        print(
            f"{pkg:14s} median {med * 1e3:.4f} ms/step  (min {min(samples[pkg]) * 1e3:.4f}, "
            f"{len(impacts[pkg])} impacts)  {med / base:.3f} x the first"
        )
    if len(args.packages) > 1:
        ref = impacts[args.packages[0]]
        for pkg in args.packages[1:]:
            other = impacts[pkg]
            if [a.corner for a in other] != [b.corner for b in ref]:
                print(f"{pkg} vs {args.packages[0]}: different impact sequences")
                continue
            pairs = list(zip(other, ref, strict=True))
            dq = max((abs(a.impulse - b.impulse) / abs(b.impulse) for a, b in pairs), default=0.0)
            dt = max((abs(a.time - b.time) / abs(b.time) for a, b in pairs), default=0.0)
            print(f"{pkg} vs {args.packages[0]}: same corners, max rel. difference impulse {dq:.2e}, time {dt:.2e}")


if __name__ == "__main__":
    main()
