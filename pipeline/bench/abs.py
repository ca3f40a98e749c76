"""Benchmark of scene-2 runs (kind "abs"): cost per step and per simulated millisecond against error.

``hdi bench --scene studies/scenes/chen_bogy2007.toml``.  Three parts, measured in one session so that ratios
survive this machine's noise:

1. Settings.  The default 1-ms run (0.2 nm RMS track, adhesion, friction) with each film coupling and time step of
   ``SETTINGS``, timed here: the median over ``repeats`` runs on one core (the steady flight, solved once, is left
   out).  The solver of the issue's day (``--baseline-ref``, a temporary ``git worktree``) times its own default
   run (its own scene file and time step, 0.2 us at c3337da) in a subprocess, one run per round between the rounds
   of the settings; each setting's cost is reported per step, per simulated millisecond and as a ratio to that
   baseline per simulated millisecond.  Without git or the ref the ratio is skipped, and the bench says why.
2. Accuracy over track realisations.  Every setting and a fine reference (``REFERENCE``: the film's midpoint step
   at 0.025 us, the finest step of ``studies/statistics.toml``) run the 1-ms default on ``seeds`` tracks (disk.seed
   = 1 .. n).
   A seed is the same track at any dt and setting, so the runs pair: the mean and 95 % CI (Student t) of the
   bouncing 3-sigma, mean contact force and mean flying height of each setting, and of its paired differences
   with the reference and with the default; a setting agrees with the reference on a statistic when the CI of
   the differences contains 0.
3. Grids and time steps (``CASES``), one run each, and their errors.  The rough track is split differently on
   every grid (each cell's resolved mean and unresolved RMS), so its 3-sigma is not a numerical quantity that
   converges; the deterministic error run is a smooth disk and a 5 mm/s drop from steady flight, 200 us, compared
   with the reference case sample by sample (max |FH(t) - FH_ref(t)|), plus the steady flying height.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pipeline.config import load_scene
from pipeline.data.netcdf import var, write_netcdf
from pipeline.provenance import PROJECT_ROOT, base_attrs
from solver.abs.integrate import simulate_abs, summarize
from solver.abs.steady import fly_start

#: (label, nx, ny, dt [s]) of the grid and time-step cases; the last one is the reference.
CASES = (
    ("coarse 81x67, dt 0.2 us", 81, 67, 0.2e-6),
    ("default 121x101, dt 0.2 us", 121, 101, 0.2e-6),
    ("default 121x101, dt 0.1 us", 121, 101, 0.1e-6),
    ("default 121x101, dt 0.05 us", 121, 101, 0.05e-6),
    ("fine 181x151, dt 0.2 us", 181, 151, 0.2e-6),
    ("reference 241x201, dt 0.025 us", 241, 201, 0.025e-6),
)
QUICK = (("coarse 81x67, dt 0.2 us", 81, 67, 0.2e-6), ("reference 81x67, dt 0.1 us", 81, 67, 0.1e-6))

#: The scene-2 default from 2026-11-28 to 2026-12-07, at dt 0.1 us (a dt factor of 0.5 on the scene's 0.2 us): the
#: film's midpoint step, its derivatives every 50 steps (5 us), contact substeps to dt / 8 (12.5 ns), no refresh gap.
MIDPOINT = {"numerics.film_scheme": "midpoint", "numerics.film_jacobian_every": 50, "numerics.contact_splits": 3,
            "numerics.film_refresh_gap": 0.0}  # fmt: skip
#: The midpoint at 0.2 us (a factor of 1): the derivatives every 25 steps (5 us), contact substeps to dt / 16.
MIDPOINT_2DT = MIDPOINT | {"numerics.film_jacobian_every": 25, "numerics.contact_splits": 4}
#: The scene-2 default until November 2026 (dt 0.05 us with these): fixed steps, rho_inf 0.5 to damp the contact,
#: the film advanced along the extrapolated acceleration's path.
PREVIOUS_DEFAULT = MIDPOINT | {"numerics.rho_infinity": 0.5, "numerics.contact_omega_dt": 0.0,
                               "numerics.film_jacobian_every": 100,
                               "numerics.film_predictor": "extrapolated"}  # fmt: skip

#: (name, description, overrides, dt factor) of the compared settings, on the scene's grid and dt x factor (the
#: scene's dt is 0.2 us).
SETTINGS = (
    (
        "default",
        "the scene's numerics: dt 0.2 us, the film's trapezoidal step with its start flux carried, rho_inf 0.9, "
        "contact substeps to omega_c h <= 0.5 (at most 16), the film's derivatives every 25 steps and where a "
        "trailing corner moved 1 nm, the film advanced along the step's solution with the film on its tangent",
        {},
        1.0,
    ),
    (
        "midpoint 0.1 us",
        "the default from 2026-11-28 to 2026-12-07: dt 0.1 us, the film's midpoint step, its derivatives every 50 "
        "steps, contact substeps to dt / 8",
        MIDPOINT,
        0.5,
    ),
    (
        "previous default",
        "the default until November 2026: dt 0.05 us, the midpoint, rho_inf 0.5, fixed steps, the film's "
        "derivatives every 100 steps, the extrapolated path",
        PREVIOUS_DEFAULT,
        0.25,
    ),
    (
        "midpoint 0.2 us",
        "the film's midpoint step at 0.2 us: its derivatives every 25 steps (5 us), contact substeps to dt / 16 "
        "(12.5 ns), no refresh gap",
        MIDPOINT_2DT,
        1.0,
    ),
)
#: Settings studied on many tracks (``bench/rare_landings.py``) and not recommended, so the bench does not time
#: them (README, "Derivatives refreshed where the pad moves", "The film's time scheme"): the same form as ``SETTINGS``.
#: Their names are those of their day, relative to the default of then, the midpoint at 0.1 us ("2 dt": 0.2 us).
STUDIED = (
    (
        "extrapolated",
        "the default until 2026-11-28: the midpoint at 0.1 us with the film advanced along the extrapolated "
        "acceleration's path",
        MIDPOINT | {"numerics.film_predictor": "extrapolated"},
        0.5,
    ),
    (
        "1.5 dt, film split",
        "the midpoint at 0.15 us: the film's derivatives every 33 steps (5 us), contact substeps to dt / 16 (9.4 "
        "ns), and a step split where the film is stiffer than omega_f h = 1 (numerics.film_omega_dt: a pad near "
        "sustained contact; the default face's 728-kHz mode is at 0.76-0.80)",
        MIDPOINT | {"numerics.film_jacobian_every": 33, "numerics.contact_splits": 4, "numerics.film_omega_dt": 1.0},
        0.75,
    ),
    (
        "2 dt, secant",
        "the midpoint at 0.2 us with the film's derivatives corrected by the secant of every re-pass "
        "(numerics.film_update 'secant', film_repass 0.02 nm) and kept per step size, refreshed every 25 steps (5 "
        "us); contact substeps to dt / 16 (12.5 ns)",
        MIDPOINT_2DT | {"numerics.film_repass": 2e-11, "numerics.film_update": "secant"},
        1.0,
    ),
    (
        "2 dt, film at dt",
        "the midpoint at 0.2 us with the film advanced in two steps of 0.1 us within each (numerics.film_dt 0.1 us: "
        "the slider's balance solved once per 0.2 us, the film over the track sampled every 0.1 us); derivatives "
        "every 25 steps (5 us), contact substeps to dt / 16 (12.5 ns)",
        MIDPOINT_2DT | {"numerics.film_dt": 1e-7},
        1.0,
    ),
    (
        "default, refresh gap",
        "the midpoint at 0.1 us with the film's derivatives refreshed also where the attitude has moved a corner of "
        "the trailing edge 0.5 nm from their last refresh (numerics.film_refresh_gap), the test of whether stale "
        "derivatives of a pad coming down make the rare landings (they do not: the fine reference lands as often)",
        MIDPOINT | {"numerics.film_refresh_gap": 5e-10},
        0.5,
    ),
    (
        "2 dt, secant, refresh gap",
        "'2 dt, secant' with the film's derivatives refreshed also where the attitude has moved a corner of the "
        "trailing edge 0.5 nm from their last refresh (numerics.film_refresh_gap)",
        MIDPOINT_2DT
        | {"numerics.film_repass": 2e-11, "numerics.film_update": "secant", "numerics.film_refresh_gap": 5e-10},
        1.0,
    ),
    (
        "2 dt, bdf2",
        "the midpoint at 0.2 us with the film's BDF2 step instead (numerics.film_scheme 'bdf2'), whose mean film "
        "force on the rough track is far closer to the converged one (README, 'The film's time scheme': every track "
        "bounces)",
        MIDPOINT_2DT | {"numerics.film_scheme": "bdf2"},
        1.0,
    ),
    (
        "2 dt, bdf2, refresh gap",
        "'2 dt, bdf2' with the film's derivatives refreshed also where a trailing corner moved 0.5 nm (flies, but "
        "lands a track in seven)",
        MIDPOINT_2DT | {"numerics.film_scheme": "bdf2", "numerics.film_refresh_gap": 5e-10},
        1.0,
    ),
    (
        "2 dt, trapezoid",
        "the midpoint at 0.2 us with the film's linearly implicit trapezoidal step instead (numerics.film_scheme "
        "'trapezoid': each flux at one time's pressure and spacing), the start's flux evaluated (two flux "
        "evaluations a step), no refresh gap",
        MIDPOINT_2DT | {"numerics.film_scheme": "trapezoid", "numerics.film_start_flux": "evaluated"},
        1.0,
    ),
    (
        "2 dt, trapezoid, refresh gap",
        "'2 dt, trapezoid' with the film's derivatives refreshed also where a trailing corner moved 0.5 nm",
        MIDPOINT_2DT
        | {
            "numerics.film_scheme": "trapezoid",
            "numerics.film_start_flux": "evaluated",
            "numerics.film_refresh_gap": 5e-10,
        },
        1.0,
    ),
    (
        "2 dt, trapezoid, gap 1 nm",
        "the default's numerics spelt out (the name it was studied under before it became the default, 2026-12-07): "
        "the trapezoid at 0.2 us, its start flux carried, the derivatives every 25 steps and where a trailing "
        "corner moved 1 nm, contact substeps to dt / 16",
        MIDPOINT_2DT
        | {
            "numerics.film_scheme": "trapezoid",
            "numerics.film_start_flux": "carried",
            "numerics.film_refresh_gap": 1e-9,
        },
        1.0,
    ),
    (
        "2 dt, trapezoid, gap 1 nm, evaluated",
        "'2 dt, trapezoid, gap 1 nm' with the start's flux evaluated over the start's pressure and spacing "
        "(numerics.film_start_flux 'evaluated'): two flux evaluations a step",
        MIDPOINT_2DT
        | {
            "numerics.film_scheme": "trapezoid",
            "numerics.film_start_flux": "evaluated",
            "numerics.film_refresh_gap": 1e-9,
        },
        1.0,
    ),
)
#: The fine reference of the accuracy runs (not timed): the midpoint at 0.025 us (the reference of the bench's runs
#: before 2026-12-07 under the name "default dt/4"), whose generalized-alpha damping of the 728-kHz mode is 1e-7
#: against its physical 1.58e-3.
REFERENCE = ("fine reference", "fine reference: the film's midpoint step at 0.025 us", MIDPOINT, 0.125)
#: The setting the bench recommends (the scene default).
RECOMMENDED = "default"
#: Run statistics compared over the seeds, with their units.
STATISTICS = {"bouncing_3sigma": "m", "mean_contact_force": "N", "mean_flying_height": "m"}
#: The solver of the issue's day (scene 2: 22 s per 1-ms run at dt 0.2 us, rho_inf 0), before the speed work.
BASELINE_REF = "c3337da"

#: The error run: a smooth disk (deterministic, no profile) and a 5 mm/s drop from steady flight.
DISTURBANCE = {"disk.rms": 0.0, "initial.zdot": -0.005, "numerics.t_end": 2e-4, "numerics.settle_time": 0.0}

#: Runs the baseline's own solver in its worktree: argv = scene file, overrides (JSON), runs; prints JSON walls.
BASELINE_SCRIPT = """
import json, sys, time, tomllib
from solver.kinds import scene_from_dict
from solver.abs.integrate import simulate_abs
from solver.abs.steady import fly_start

def scene(path, overrides):
    data = tomllib.loads(open(path).read())
    for key, value in overrides.items():
        section, _, name = key.partition(".")
        data.setdefault(section, {})[name] = value
    return scene_from_dict(data)

path, overrides, runs = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3])
run = scene(path, overrides)
steady = fly_start(run)
dt = run.numerics.dt
simulate_abs(scene(path, {**overrides, "numerics.t_end": 10 * dt, "numerics.settle_time": 0.0}), steady)  # compile
walls, steps = [], 0
for _ in range(runs):
    t0 = time.perf_counter()
    result = simulate_abs(run, steady)
    walls.append(time.perf_counter() - t0)
    steps = result.work["steps"]
print(json.dumps({"walls": walls, "steps": steps, "status": result.status}))
"""


def run_bench(args: argparse.Namespace) -> int:
    quick = args.quick
    run = {"numerics.t_end": 2e-4, "numerics.settle_time": 5e-5} if quick else {}
    repeats = max(1, args.repeats)
    seeds = max(1, getattr(args, "seeds", None) or (2 if quick else 8))
    settings = time_settings(args.scene, run, repeats, getattr(args, "baseline_ref", BASELINE_REF))
    accuracy = seed_statistics(args.scene, run, seeds)
    rows = grid_cases(args.scene, QUICK if quick else CASES, quick)
    if args.output:
        ds = bench_dataset(rows, settings, accuracy)
        print(f"wrote {write_netcdf(ds, args.output)}")
        if getattr(args, "figure", None):
            from pipeline.figures.bench import plot_scene2_bench
            from pipeline.figures.common import save_figure

            print(f"wrote {save_figure(plot_scene2_bench(ds), args.figure, dpi=130)}")
    return 0


# 1. settings against today's solver ----------------------------------------------------------------------------


def setting_overrides(scene_path: str, run: dict[str, Any], overrides: dict[str, Any], dt_factor: float):
    """A setting's overrides on top of ``run``: its own, and dt scaled by dt_factor, with the output interval the
    nearest whole multiple of it to the scene's (0.45 us at dt 0.15 us for the scene's 0.4)."""
    numerics = load_scene(scene_path, run).numerics
    dt = numerics.dt * dt_factor
    interval = max(1, round(numerics.output_interval / dt)) * dt
    return {**run, **overrides, "numerics.dt": dt, "numerics.output_interval": interval}


def time_settings(scene_path: str, run: dict[str, Any], repeats: int, baseline_ref: str) -> dict[str, Any]:
    """Median wall time per run of each setting and of the baseline solver, in interleaved rounds."""
    overrides = {name: setting_overrides(scene_path, run, o, f) for name, _, o, f in SETTINGS}
    scenes = {name: load_scene(scene_path, o) for name, o in overrides.items()}
    steady = fly_start(scenes[SETTINGS[0][0]])
    walls: dict[str, list[float]] = {name: [] for name in scenes}
    steps: dict[str, int] = {}
    for name, scene in scenes.items():  # load (or compile) the kernels outside the timing
        short = {"numerics.t_end": 10 * scene.numerics.dt, "numerics.settle_time": 0.0}
        simulate_abs(load_scene(scene_path, overrides[name] | short), steady=steady)
    baseline = Baseline(baseline_ref, scene_path, run)
    try:
        for _ in range(repeats):
            baseline.time_one_run()
            for name, scene in scenes.items():
                t0 = time.perf_counter()
                result = simulate_abs(scene, steady=steady)
                walls[name].append(time.perf_counter() - t0)
                steps[name] = result.work["steps"]
    finally:
        baseline.close()
    t_ms = scenes[SETTINGS[0][0]].numerics.t_end / 1e-3
    base_wall = statistics.median(baseline.walls) if baseline.walls else math.nan
    base_step = base_wall / baseline.steps if baseline.walls else math.nan
    print(f"\nsettings: {t_ms:g}-ms default run, median of {repeats} on one core; baseline: {baseline.describe()}")
    print(f"{'setting':18s} {'steps':>6s} {'ms/step':>8s} {'s/ms':>7s} {'x baseline':>10s}")
    if baseline.walls:
        print(f"{'baseline':18s} {baseline.steps:6d} {base_step * 1e3:8.3f} {base_wall / t_ms:7.2f} {1.0:10.2f}")
    out = {"name": [], "wall_per_run": [], "wall_per_step": [], "steps": [], "speedup": []}
    for name in scenes:
        wall = statistics.median(walls[name])
        speedup = base_wall / wall
        out["name"].append(name)
        out["wall_per_run"].append(wall)
        out["wall_per_step"].append(wall / steps[name])
        out["steps"].append(steps[name])
        out["speedup"].append(speedup)
        print(f"{name:18s} {steps[name]:6d} {wall / steps[name] * 1e3:8.3f} {wall / t_ms:7.2f} {1.0 / speedup:10.2f}")
    out.update(t_ms=t_ms, baseline_wall=base_wall, baseline_step=base_step, baseline=baseline.describe())
    return out


class Baseline:
    """The solver of ``ref`` in a temporary git worktree, timed in a subprocess (one run per call).

    It runs its own copy of the scene file (the ref's defaults, and no key it does not know) when the scene is
    part of this project and the ref has it, else the given file.  ``walls`` stays empty, and ``reason`` says
    why, when git, the ref or the run is unavailable.
    """

    def __init__(self, ref: str, scene_path: str, run: dict[str, Any]) -> None:
        self.ref, self.walls, self.steps, self.commit, self.reason = ref, [], 0, "", ""
        self.scene_path, self.run = str(Path(scene_path).resolve()), run
        self.tree: Path | None = None
        if not ref:
            self.reason = "no baseline ref"
            return
        git = shutil.which("git")
        if git is None:
            self.reason = "git is not available"
            return
        tree = Path(tempfile.mkdtemp(prefix="hdi-baseline-")) / "tree"
        done = subprocess.run([git, "worktree", "add", "--detach", str(tree), ref], cwd=PROJECT_ROOT,
                              capture_output=True, text=True)  # fmt: skip
        if done.returncode != 0:
            self.reason = f"git worktree add {ref} failed: {done.stderr.strip().splitlines()[-1:]}"
            return
        self.tree = tree
        try:
            own = tree / Path(self.scene_path).relative_to(PROJECT_ROOT.resolve())
        except ValueError:
            own = None
        if own is not None and own.exists():
            self.scene_path = str(own)
        self.commit = subprocess.run(
            [git, "rev-parse", "HEAD"], cwd=tree, capture_output=True, text=True
        ).stdout.strip()

    def time_one_run(self) -> None:
        if self.tree is None or self.reason:
            return
        done = subprocess.run(
            [sys.executable, "-c", BASELINE_SCRIPT, self.scene_path, json.dumps(self.run), "1"],
            cwd=self.tree, env=_env_for(self.tree), capture_output=True, text=True,
        )  # fmt: skip
        try:
            report = json.loads(done.stdout.strip().splitlines()[-1])
        except (IndexError, json.JSONDecodeError):
            self.reason = f"the baseline run failed: {(done.stderr.strip().splitlines() or ['no output'])[-1]}"
            return
        self.walls.extend(report["walls"])
        self.steps = report["steps"]

    def describe(self) -> str:
        if self.walls:
            return (f"{self.ref} ({self.commit[:10]}) in a git worktree, timed in a subprocess, its own default run "
                    f"({self.steps} steps)")  # fmt: skip
        return f"skipped: {self.reason}"

    def close(self) -> None:
        if self.tree is not None:
            subprocess.run(["git", "worktree", "remove", "--force", str(self.tree)], cwd=PROJECT_ROOT,
                           capture_output=True)  # fmt: skip
            shutil.rmtree(self.tree.parent, ignore_errors=True)
            self.tree = None


def _env_for(tree: Path) -> dict[str, str]:
    """The environment of a subprocess that imports the solver of ``tree`` (not this checkout's)."""
    import os

    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree)
    return env


# 2. accuracy over track realisations ---------------------------------------------------------------------------


def mean_ci(values: np.ndarray) -> tuple[float, float]:
    """Mean and the half-width of its 95 % confidence interval (Student t; nan for fewer than 2 values)."""
    from scipy.stats import t as student

    values = np.asarray(values, dtype=float)
    n = values.size
    if n < 2:
        return float(values.mean()) if n else math.nan, math.nan
    return float(values.mean()), float(student.ppf(0.975, n - 1) * values.std(ddof=1) / math.sqrt(n))


def seed_statistics(scene_path: str, run: dict[str, Any], seeds: int) -> dict[str, Any]:
    """STATISTICS of every setting and of the reference on tracks 1 .. seeds, paired with the reference."""
    everything = (*SETTINGS, REFERENCE)
    names = [s[0] for s in everything]
    values = {name: {key: np.full(seeds, np.nan) for key in STATISTICS} for name in names}
    status = {name: np.zeros(seeds, dtype=int) for name in names}
    steady = None
    for k in range(seeds):
        for name, _, overrides, factor in everything:
            scene = load_scene(
                scene_path, {**setting_overrides(scene_path, run, overrides, factor), "disk.seed": k + 1}
            )
            steady = steady or fly_start(scene)
            result = simulate_abs(scene, steady=steady)
            status[name][k] = result.status
            if result.status == 0:
                summary = summarize(result, scene)
                for key in STATISTICS:
                    values[name][key][k] = summary[key]
    ref, today = REFERENCE[0], SETTINGS[0][0]
    print(f"\naccuracy over {seeds} tracks (disk.seed 1..{seeds}): mean +- 95 % CI")
    print(f"{'setting':24s} {'3-sigma [nm]':>24s} {'contact force [uN]':>24s} {'mean FH [nm]':>24s}")
    scale = {"bouncing_3sigma": 1e9, "mean_contact_force": 1e6, "mean_flying_height": 1e9}
    table: dict[str, Any] = {"values": values, "status": status, "names": names, "seeds": seeds}
    for name in names:
        cells = []
        for key in STATISTICS:
            mean, ci = mean_ci(values[name][key])
            table[(name, key)] = (mean, ci)
            table[(name, key, ref)] = mean_ci(values[name][key] - values[ref][key])
            table[(name, key, today)] = mean_ci(values[name][key] - values[today][key])
            cells.append(f"{mean * scale[key]:9.4f} +- {ci * scale[key]:7.4f}")
        print(f"{name:24s} " + " ".join(f"{c:>24s}" for c in cells))
    print("paired differences (same track), mean +- 95 % CI, and whether the CI contains 0")
    for other in (ref, today):
        for name in names:
            if name in (other, ref if other == today else ""):
                continue
            cells = []
            for key in STATISTICS:
                diff, diff_ci = table[(name, key, other)]
                agree = "yes" if abs(diff) <= diff_ci else ("n/a" if math.isnan(diff_ci) else "NO")
                cells.append(f"{diff * scale[key]:+8.4f} +- {diff_ci * scale[key]:7.4f} {agree:>3s}")
            print(f"{name + ' - ' + other:24s} " + " ".join(f"{c:>24s}" for c in cells))
    return table


# 3. grids and time steps ---------------------------------------------------------------------------------------


def grid_cases(scene_path: str, cases, quick: bool) -> list[dict[str, Any]]:
    """Run (and time, once) every grid / time-step case and its error run; compare both with the last case.

    Samples every 0.5 us (the scene's interval, below the 729-kHz mode's Nyquist period) at every dt; costs are
    relative to the default grid at the scene's dt.
    """
    t_end = 2e-4 if quick else 1e-3
    settle = 5e-5 if quick else 2e-4
    scene_dt = load_scene(scene_path).numerics.dt
    rows = []
    print(f"\n{'case':30s} {'nodes':>6s} {'steps':>6s} {'ms/step':>8s} {'s/ms':>7s} {'FH0 [nm]':>9s} "
          f"{'meanFH':>8s} {'3sig [nm]':>9s} {'Fc [uN]':>8s}")  # fmt: skip
    for label, nx, ny, dt in cases:
        grid = {"numerics.nx": nx, "numerics.ny": ny, "numerics.dt": dt,
                "numerics.output_interval": max(1, round(0.5e-6 / dt)) * dt}  # fmt: skip
        scene = load_scene(scene_path, grid | {"numerics.t_end": t_end, "numerics.settle_time": settle})
        steady = fly_start(scene)
        t0 = time.perf_counter()
        result = simulate_abs(scene, steady=steady)
        wall = time.perf_counter() - t0
        s = summarize(result, scene)
        steps = result.work["steps"]
        probe = load_scene(scene_path, grid | DISTURBANCE)
        drop = simulate_abs(probe, steady=fly_start(probe))
        row = {
            "case": label, "nx": nx, "ny": ny, "dt": dt, "nodes": nx * ny, "steps": steps,
            "wall_per_run": wall, "wall_per_step": wall / max(steps, 1),
            "wall_per_ms": wall / (scene.numerics.t_end / 1e-3), "status": result.status,
            "steady_flying_height": steady.element_spacing, "mean_flying_height": s["mean_flying_height"],
            "bouncing_3sigma": s["bouncing_3sigma"], "mean_contact_force": s["mean_contact_force"],
            "halvings": result.work["step_halvings"], "drop_t": drop.t, "drop_fh": drop.series["flying_height"],
        }  # fmt: skip
        rows.append(row)
        print(f"{label:30s} {nx * ny:6d} {steps:6d} {row['wall_per_step'] * 1e3:8.3f} {row['wall_per_ms']:7.2f} "
              f"{row['steady_flying_height'] * 1e9:9.4f} {row['mean_flying_height'] * 1e9:8.4f} "
              f"{row['bouncing_3sigma'] * 1e9:9.5f} {row['mean_contact_force'] * 1e6:8.4f}", flush=True)  # fmt: skip
    ref = rows[-1]
    base = next((r for r in rows if r["case"].startswith("default") and abs(r["dt"] - scene_dt) < 1e-15), rows[0])
    print(f"\nerrors against {ref['case']}; cost relative to {base['case']} measured in this session")
    print(
        "  drop: smooth disk, zdot0 = -5 mm/s, 200 us; max |FH(t) - FH_ref(t)| over the run and its largest excursion"
    )
    print(
        f"{'case':30s} {'FH0 err [nm]':>12s} {'drop err [nm]':>13s} {'excursion':>9s} {'3sig [%]':>9s} {'cost x':>7s}"
    )
    for r in rows:
        r["steady_fh_error"] = abs(r["steady_flying_height"] - ref["steady_flying_height"])
        ref_fh = np.interp(r["drop_t"], ref["drop_t"], ref["drop_fh"])
        r["drop_error"] = float(np.max(np.abs(r["drop_fh"] - ref_fh)))
        r["drop_excursion"] = float(np.max(np.abs(ref["drop_fh"] - ref["drop_fh"][0])))
        r["mean_fh_error"] = abs(r["mean_flying_height"] - ref["mean_flying_height"])
        r["bouncing_error"] = abs(r["bouncing_3sigma"] / ref["bouncing_3sigma"] - 1.0)
        r["cost_ratio"] = r["wall_per_run"] / base["wall_per_run"]
        print(f"{r['case']:30s} {r['steady_fh_error'] * 1e9:12.5f} {r['drop_error'] * 1e9:13.5f} "
              f"{r['drop_excursion'] * 1e9:9.4f} {100 * r['bouncing_error']:9.2f} {r['cost_ratio']:7.2f}")  # fmt: skip
    for r in rows:
        r["reference_case"], r["baseline_case"] = ref["case"], base["case"]
    return rows


# the file ------------------------------------------------------------------------------------------------------


def bench_dataset(rows: list[dict[str, Any]], settings: dict[str, Any], accuracy: dict[str, Any]) -> xr.Dataset:
    """The three parts on the dimensions ``case`` (grids), ``setting`` (timed and compared) and ``seed``."""
    data = {
        key: var([r[key] for r in rows], ("case",), units, key.replace("_", " "))
        for key, units in (
            ("nodes", "1"),
            ("steps", "1"),
            ("dt", "s"),
            ("wall_per_run", "s"),
            ("wall_per_step", "s"),
            ("wall_per_ms", "s"),
            ("steady_flying_height", "m"),
            ("mean_flying_height", "m"),
            ("bouncing_3sigma", "m"),
            ("mean_contact_force", "N"),
            ("steady_fh_error", "m"),
            ("drop_error", "m"),
            ("mean_fh_error", "m"),
            ("bouncing_error", "1"),
            ("cost_ratio", "1"),
            ("halvings", "1"),
        )  # fmt: skip
    }
    timed = settings["name"]
    t_ms = settings["t_ms"]
    data["setting_wall_per_step"] = var(settings["wall_per_step"], ("timed",), "s", "median wall time per step")
    data["setting_wall_per_ms"] = var(np.array(settings["wall_per_run"]) / t_ms, ("timed",), "s",
                                      "median wall time per simulated millisecond")  # fmt: skip
    data["setting_speedup"] = var(settings["speedup"], ("timed",), "1",
                                  "baseline wall time per run / this setting's (same session)")  # fmt: skip
    data["baseline_wall_per_step"] = var(settings["baseline_step"], (), "s",
                                         "median wall time per step of the baseline solver (own run)")  # fmt: skip
    data["baseline_wall_per_ms"] = var(settings["baseline_wall"] / t_ms, (), "s",
                                       "median wall time per simulated millisecond of the baseline solver")  # fmt: skip
    names = accuracy["names"]
    ref, today = REFERENCE[0], SETTINGS[0][0]
    for key, units in STATISTICS.items():
        long = key.replace("_", " ")
        data[key + "_by_seed"] = var([accuracy["values"][n][key] for n in names], ("setting", "seed"), units, long)
        for suffix, entry, index, what in (
            ("mean", (), 0, "mean over the tracks"), ("ci", (), 1, "95 % CI half-width of the mean"),
            ("diff", (ref,), 0, "mean paired difference with the reference"),
            ("diff_ci", (ref,), 1, "95 % CI half-width of the paired difference with the reference"),
            ("diff_today", (today,), 0, f"mean paired difference with {today}"),
            ("diff_today_ci", (today,), 1, f"95 % CI half-width of the paired difference with {today}"),
        ):  # fmt: skip
            values = [accuracy[(n, key, *entry)][index] for n in names]
            data[f"{key}_{suffix}"] = var(values, ("setting",), units, f"{long}: {what}")
    data["run_status"] = var([accuracy["status"][n] for n in names], ("setting", "seed"), "1", "run status (0: ok)")
    ds = xr.Dataset(
        data,
        coords={
            "case": ("case", np.array([r["case"] for r in rows]), {"long_name": "grid and time-step case"}),
            "timed": ("timed", np.array(timed), {"long_name": "timed setting"}),
            "setting": ("setting", np.array(names), {"long_name": "compared setting (the last is the reference)"}),
            "seed": ("seed", np.arange(1, accuracy["seeds"] + 1), {"long_name": "disk.seed of the track"}),
        },
    )
    ds.attrs.update(base_attrs("Scene 2 benchmark: cost per step and per simulated ms against error"),
                    scene_kind="abs", product="bench")  # fmt: skip
    ds.attrs["reference"] = rows[-1]["reference_case"]
    ds.attrs["baseline"] = rows[-1]["baseline_case"]
    ds.attrs["baseline_solver"] = settings["baseline"]
    ds.attrs["accuracy_reference"] = REFERENCE[0]
    ds.attrs["recommended_setting"] = RECOMMENDED
    ds.attrs["settings"] = "; ".join(f"{name}: {what}" for name, what, _, _ in (*SETTINGS, REFERENCE))
    ds.attrs["simulated_ms"] = t_ms
    return ds
