"""Command line: ``hdi fly | simulate | run | query | plot | bench | reproduce``.

Every command validates its whole configuration before computing anything;
errors name the key, the value and what is allowed, and exit with status 2.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np

from solver.errors import SolverError
from solver.params import ParameterError

from . import __version__

DEFAULT_SCENE = Path(__file__).resolve().parent.parent / "studies" / "scenes" / "benson1989.toml"
RESULTS = Path(__file__).resolve().parent.parent / "results"
FIG17_STUDY = Path(__file__).resolve().parent.parent / "studies" / "fig17.toml"
CONVERGENCE_STUDY = FIG17_STUDY.with_name("convergence.toml")


def _add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="scene file (TOML), e.g. studies/scenes/benson1989.toml")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene value, e.g. --set contact.mu=0.5 (repeatable)",
    )


def _fmt_um(x: float) -> str:
    return f"{x * 1e6:.4f} um"


def cmd_fly(args: argparse.Namespace) -> int:
    from solver.rails.steady import fly

    from .config import load_scene
    from .store import fly_dataset, write_netcdf

    scene = load_scene(args.scene, args.overrides)
    if scene.kind == "abs":
        return _fly_abs(scene, args)
    t0 = time.perf_counter()
    steady = fly(scene)
    wall = time.perf_counter() - t0
    print(f"scene {scene.name} (calibration: {scene.calibration.mode})")
    print(f"  z                  {_fmt_um(steady.z)}")
    print(f"  pitch              {steady.pitch * 1e6:.3f} urad")
    print(f"  roll               {steady.roll * 1e6:.3f} urad")
    print(
        f"  minimum spacing    {_fmt_um(steady.min_spacing)} at x1 = {steady.min_spacing_x1 * 1e3:.3f} mm, "
        f"x2 = {steady.min_spacing_x2 * 1e3:.3f} mm"
    )
    print(
        "  corner spacings    "
        + ", ".join(f"{c} {h * 1e6:.4f}" for c, h in zip("ABCD", steady.corner_spacings, strict=True))
    )
    print(f"  bearing number     {steady.bearing_number:.1f} (6 eta V L / (p0 h_min^2))")
    print(f"  load               {steady.load:.5f} N (preload in force {steady.suspension.preload:.5f} N)")
    print(
        f"  centre of pressure x1 = {steady.centre_of_pressure[0] * 1e3:.4f} mm, "
        f"x2 = {steady.centre_of_pressure[1] * 1e3:.4f} mm"
    )
    print(f"  static moments     pitch {steady.suspension.static_pitch_moment:.4e} N m, "
          f"roll {steady.suspension.static_roll_moment:.4e} N m")  # fmt: skip
    print(
        f"  work               {steady.reynolds_solves} steady Reynolds solves, "
        f"{steady.newton_iterations} Newton iterations, {wall:.2f} s"
    )
    if args.output:
        path = write_netcdf(fly_dataset(steady, scene, {"wall_time": wall}), args.output)
        print(f"wrote {path}")
    if args.plot:
        from .figures import plot_fly, save_figure
        from .store import open_result

        fig = plot_fly(open_result(args.output)) if args.output else _fly_fig(steady, scene)
        print(f"wrote {save_figure(fig, args.plot)}")
    return 0


def _fly_abs(scene, args: argparse.Namespace) -> int:
    from solver.abs.film import AbsFilm
    from solver.abs.steady import fly_abs

    from .absstore import abs_fly_dataset
    from .store import write_netcdf

    film = AbsFilm(scene)
    steady = fly_abs(scene, film)
    sf = steady.surface
    nx, ny = film.shape
    print(f"scene {scene.name}: {scene.slider.length * 1e3:.2f} x {scene.slider.width * 1e3:.2f} mm, "
          f"trailing pad {scene.slider.trailing_pad_width * 1e6:.0f} um, "
          f"preload {scene.suspension.preload * 1e3:.3f} mN, "
          f"{scene.disk.speed:.2f} m/s, skew {scene.disk.skew} deg, slip {scene.models.slip}")  # fmt: skip
    print(f"  flying height      {steady.element_spacing * 1e9:.4f} nm at the element "
          f"(x = {scene.slider.element_x * 1e3:.3f} mm, y = {scene.slider.element_y * 1e3:.3f} mm)")  # fmt: skip
    print(f"  pitch              {steady.q[1] * 1e6:.3f} urad")
    print(f"  roll               {steady.q[2] * 1e6:.4f} urad")
    print(f"  z at the pivot     {steady.q[0] * 1e9:.3f} nm")
    print(f"  minimum spacing    {steady.min_spacing * 1e9:.4f} nm at x = {steady.min_spacing_x * 1e3:.4f} mm, "
          f"y = {steady.min_spacing_y * 1e3:.4f} mm")  # fmt: skip
    print(f"  air-bearing force  {steady.air_force[0] * 1e3:.5f} mN")
    print(f"  contact force      {sf.contact * 1e3:.6f} mN, adhesion {sf.adhesion * 1e3:.6f} mN "
          f"(RMS {scene.disk.rms * 1e9:g} nm, delta_gamma {scene.contact.delta_gamma} J/m2)")  # fmt: skip
    print(f"  work               grid {nx} x {ny}, {steady.iterations} attitude iterations, "
          f"{steady.reynolds_solves} sparse Reynolds solves, {steady.wall_time:.2f} s")  # fmt: skip
    ds = abs_fly_dataset(steady, scene, film.grid.depth)
    if args.output:
        print(f"wrote {write_netcdf(ds, args.output)}")
    if args.plot:
        from .absfigures import plot_abs_fly
        from .figures import save_figure

        print(f"wrote {save_figure(plot_abs_fly(ds), args.plot)}")
    return 0


def simulate_abs_scene(scene, output: Path | None, plot: Path | None, quiet: bool = False):
    """Fly, run over the moving track, print the bouncing and contact measures, write files."""
    from solver.abs.integrate import simulate_abs

    from .absstore import abs_run_dataset
    from .runner import abs_profile
    from .store import write_netcdf

    result = simulate_abs(scene, profile=abs_profile(scene))
    ds = abs_run_dataset(result, scene)
    if not quiet:
        c, d = scene.contact, scene.disk
        print(f"scene {scene.name}: pad {scene.slider.trailing_pad_width * 1e6:.0f} um, RMS {d.rms * 1e9:g} nm, "
              f"delta_gamma {c.delta_gamma} J/m2, mu {c.mu}, preload {scene.suspension.preload * 1e3:.3f} mN, "
              f"t_end {scene.numerics.t_end * 1e3:g} ms")  # fmt: skip
        print(f"  status {result.status}: {result.message}")
        print(f"  steady flying height {float(ds['steady_flying_height']) * 1e9:.4f} nm")
        print(f"  bouncing 3 sigma     {float(ds['bouncing_3sigma']) * 1e9:.4f} nm "
              f"(mean FH {float(ds['mean_flying_height']) * 1e9:.4f} nm)")  # fmt: skip
        print(f"  mean contact force   {float(ds['mean_contact_force']) * 1e3:.5f} mN "
              f"(max {float(ds['max_contact_force']) * 1e3:.4f} mN), contact fraction "
              f"{float(ds['contact_fraction']):.3f}")  # fmt: skip
        print(f"  spectral peaks       FH {float(ds['fh_peak_frequency']) * 1e-3:.1f} kHz, pitch "
              f"{float(ds['pitch_peak_frequency']) * 1e-3:.1f} kHz, "
              f"roll {float(ds['roll_peak_frequency']) * 1e-3:.1f} kHz")  # fmt: skip
        w = result.work
        print(f"  work: {w['steps']} steps on {w['nodes']} nodes, {w['newton_iterations']} Newton iterations, "
              f"{w['wall_time']:.2f} s ({w['wall_time'] / max(w['steps'], 1) * 1e3:.3f} ms/step)")  # fmt: skip
    if output:
        print(f"wrote {write_netcdf(ds, output)}")
    if plot:
        from .absfigures import plot_abs_run
        from .figures import save_figure

        print(f"wrote {save_figure(plot_abs_run(ds), plot)}")
    return ds


def _fly_fig(steady, scene):
    from .figures import plot_fly
    from .store import fly_dataset

    return plot_fly(fly_dataset(steady, scene))


def simulate_scene(scene, output: Path | None, plot: Path | None, quiet: bool = False):
    """Fly, simulate, print the impact history and classification, write files."""
    from solver.rails.integrate import simulate

    from .store import run_dataset, write_netcdf

    result = simulate(scene)
    ds = run_dataset(result, scene)
    if not quiet:
        c = scene.contact
        print(
            f"scene {scene.name}: mu = {c.mu}, alpha = {c.alpha}, zdot0 = {scene.initial.zdot} m/s, "
            f"t_end = {scene.numerics.t_end * 1e6:.0f} us"
        )
        print(f"  status {result.status}: {result.message}")
        for k, imp in enumerate(result.impacts):
            print(f"  impact {k + 1:3d}  t = {imp.time * 1e6:8.3f} us  corner {imp.corner_letter}  "
                  f"q = {imp.impulse * 1e6:.4f} uN s")  # fmt: skip
        verdict = "STABLE" if int(ds["stable"]) else "UNSTABLE"
        print(
            f"  {verdict}: {int(ds['n_impacts'])} impacts, {int(ds['n_larger_than_first'])} larger than the first, "
            f"{int(ds['n_front_corner_impacts'])} at front corners, max ratio {float(ds['max_impulse_ratio']):.3f}"
        )
        w = result.work
        print(
            f"  work: {w['steps']} steps, {w['newton_iterations']} Newton iterations, "
            f"{w['wall_time']:.2f} s ({w['wall_time'] / max(w['steps'], 1) * 1e3:.3f} ms/step)"
        )
    if output:
        print(f"wrote {write_netcdf(ds, output)}")
    if plot:
        from .figures import plot_run, save_figure

        print(f"wrote {save_figure(plot_run(ds), plot)}")
    return ds


def cmd_simulate(args: argparse.Namespace) -> int:
    from .config import load_scene

    scene = load_scene(args.scene, args.overrides)
    if scene.kind == "abs":
        simulate_abs_scene(scene, args.output, args.plot)
    else:
        simulate_scene(scene, args.output, args.plot)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from .figures import plot_dataset, save_figure
    from .store import open_result

    ds = open_result(args.file)
    overlay = open_result(args.overlay) if args.overlay else None
    print(f"wrote {save_figure(plot_dataset(ds, overlay), args.output)}")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    """The main job, into results/: scene-1 flight, the source's two contact runs, Figure 17, convergence, bench.

    Figure 17 runs as the full grid and as a traced boundary, each with its own
    ledger so that both report their real cost; running reproduce again resumes
    (or reuses) both from their ledgers.
    """
    from .config import load_scene
    from .fanout import run_study
    from .figures import plot_dataset, save_figure
    from .study import load_study

    out = Path(args.results)
    t0 = time.perf_counter()
    ns = argparse.Namespace(
        scene=str(DEFAULT_SCENE), overrides=[], output=out / "benson1989_fly.nc", plot=out / "benson1989_fly.png"
    )
    cmd_fly(ns)
    for alpha in ("0.80", "0.85"):
        scene = load_scene(DEFAULT_SCENE, [f"contact.alpha={alpha}", "contact.mu=0.5"])
        tag = alpha.replace(".", "")
        print()
        simulate_scene(scene, out / f"benson1989_mu05_alpha{tag}.nc", out / f"benson1989_mu05_alpha{tag}.png")
    if not args.skip_studies:
        outcomes = {}
        for mode in ("grid", "boundary"):
            study = load_study(FIG17_STUDY, mode=mode)
            name = "fig17" if mode == "grid" else "fig17_boundary"
            print(f"\nstudy {name}: {study.size if mode == 'grid' else 'bisection of'} runs on {args.workers or 'all'} "
                  "local workers", flush=True)  # fmt: skip
            outcomes[mode] = run_study(
                study, out / f"{name}.nc", ledger_dir=out / ".ledger" / name, workers=args.workers, quiet=args.quiet
            )
            o = outcomes[mode]
            print(f"study {name}: {o.computed} runs computed, {o.reused} from the ledger, {o.failed} failed, "
                  f"wall time {o.wall_time:.1f} s, run time {o.run_time:.1f} core-s")  # fmt: skip
            _print_boundary(o.dataset)
        fig = plot_dataset(outcomes["grid"].dataset, outcomes["boundary"].dataset)
        print(f"wrote {save_figure(fig, out / 'fig17.png')}")
        for path, mode, name in ((FIG17_STUDY, "multifidelity", "fig17_multifidelity"),
                                 (CONVERGENCE_STUDY, "grid", "convergence")):  # fmt: skip
            study = load_study(path, mode=mode)
            print(f"\nstudy {name} ({mode})", flush=True)
            o = run_study(study, out / f"{name}.nc", ledger_dir=out / ".ledger" / name, workers=args.workers,
                          quiet=args.quiet)  # fmt: skip
            print(f"study {name}: {o.computed} runs computed, {o.reused} from the ledger, {o.failed} failed, "
                  f"wall time {o.wall_time:.1f} s, run time {o.run_time:.1f} core-s")  # fmt: skip
            if "refined" in o.dataset:
                ds = o.dataset
                print(f"multi-fidelity: {ds.attrs['cells_refined']} of {int(ds['refined'].size)} cells re-run with "
                      f"the full scene; {ds.attrs['cells_changed']} changed class")  # fmt: skip
            print(f"wrote {save_figure(plot_dataset(o.dataset), out / f'{name}.png')}")
    if not args.skip_scene2:
        _reproduce_scene2(args, out)
    if not args.skip_bench:
        from .bench import run_bench

        print("\nbenchmark: speed against error", flush=True)
        run_bench(argparse.Namespace(scene=str(DEFAULT_SCENE), quick=False, repeats=3,
                                     output=out / "bench_scene1.nc", figure=out / "work_precision.png"))  # fmt: skip
    print(f"\nreproduce finished in {time.perf_counter() - t0:.1f} s")
    return 0


SCENE2 = DEFAULT_SCENE.with_name("chen_bogy2007.toml")
SCENE2_STUDIES = ("pad_width", "preload", "roughness_adhesion", "friction")


def _reproduce_scene2(args: argparse.Namespace, out: Path) -> None:
    """Scene 2: steady flight, one default 1-ms run, the four Table-I studies."""
    from .config import load_scene
    from .fanout import run_study
    from .figures import plot_dataset, save_figure
    from .study import load_study

    print("\nscene 2: partial-contact femto slider", flush=True)
    cmd_fly(argparse.Namespace(scene=str(SCENE2), overrides=[], output=out / "chen_bogy2007_fly.nc",
                               plot=out / "chen_bogy2007_fly.png"))  # fmt: skip
    print()
    simulate_abs_scene(load_scene(SCENE2), out / "chen_bogy2007_run.nc", out / "chen_bogy2007_run.png")
    if args.skip_studies:
        return
    for name in SCENE2_STUDIES:
        study = load_study(SCENE2.parent.parent / f"{name}.toml")
        print(f"\nstudy {name}: {study.size} runs", flush=True)
        o = run_study(study, out / f"{name}.nc", ledger_dir=out / ".ledger" / name, workers=args.workers,
                      quiet=args.quiet)  # fmt: skip
        print(f"study {name}: {o.computed} runs computed, {o.reused} from the ledger, {o.failed} failed, "
              f"wall time {o.wall_time:.1f} s, run time {o.run_time:.1f} core-s")  # fmt: skip
        print(f"wrote {save_figure(plot_dataset(o.dataset), out / f'{name}.png')}")


# Cost model for --dry-run when the ledger has no finished run of the study yet: film-step cost
# per node and step measured by `hdi bench` on this machine (0.25-0.38 ms per step at 2 x 201 x 21 nodes).
SECONDS_PER_NODE_STEP = 4.0e-8


def _estimate(study, ledger, todo: int, workers: int) -> str:
    import statistics

    walls = []
    if study.mode == "multifidelity":
        from .multifidelity import cheap_study

        study = cheap_study(study)
    for case in study.cases()[:50] if study.mode == "grid" else []:
        record = ledger.finished(case.run_id)
        if record is not None and record.get("wall_time") == record.get("wall_time"):
            walls.append(record["wall_time"])
    if walls:
        per_run, basis = statistics.median(walls), f"median of {len(walls)} finished runs in the ledger"
    else:
        num = study.case((0,) * len(study.axes)).scene.numerics
        nodes = 2 * num.nx * num.ny
        per_run = num.t_end / num.dt * nodes * SECONDS_PER_NODE_STEP
        basis = f"model: {nodes} nodes x {num.t_end / num.dt:.0f} steps x {SECONDS_PER_NODE_STEP:g} s"
    total = todo * per_run
    return (
        f"~{per_run:.2f} s per run ({basis}); {todo} runs ~ {total:.0f} core-s, "
        f"~{total / max(workers, 1) / 60:.1f} min on {workers} workers"
    )


def cmd_run(args: argparse.Namespace) -> int:
    import os

    from .fanout import default_ledger, default_output, run_study
    from .ledger import Ledger
    from .study import lattice, load_study

    study = load_study(args.study, args.overrides, mode=args.mode)
    output = args.output or default_output(study)
    ledger_dir = args.ledger or default_ledger(study, output)
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    cases = study.cases() if study.mode == "grid" else []
    if args.dry_run:
        ledger = Ledger(ledger_dir)
        print(f"study {study.name} ({study.path}), mode {study.mode}")
        print("  axes: " + ", ".join(f"{a.dim} ({a.key}) x {len(a.values)}" for a in study.axes))
        if study.mode == "grid":
            done = sum(ledger.finished(c.run_id) is not None for c in cases)
            print(f"  runs: {len(cases)}, already done: {done} (ledger {ledger.folder}), to run: {len(cases) - done}")
            todo = len(cases) - done
        elif study.mode == "multifidelity":
            from .multifidelity import cheap_study

            cheap = cheap_study(study).cases()
            done = sum(ledger.finished(c.run_id) is not None for c in cheap)
            print(f"  cheap pass ({study.multifidelity}): {len(cheap)} runs, {done} done; then the full scene on the "
                  "cells next to the class boundary")  # fmt: skip
            todo = len(cheap) - done
        else:
            n = len(lattice(study))
            lines = study.size // len(study.axis(study.boundary.axis).values)
            cold = 2 + int(np.ceil(np.log2(max(n - 1, 1))))
            print(f"  lines: {lines}, lattice of {n} values; at most {cold} runs per line, ~3 per continued line")
            todo = cold + 3 * (lines - 1)
        print("  estimate: " + _estimate(study, ledger, todo, workers))
        print(f"  output: {output}")
        return 0
    print(f"study {study.name}: mode {study.mode}, " + " x ".join(f"{len(a.values)} {a.dim}" for a in study.axes)
          + (f" = {len(cases)} runs" if cases else ""), flush=True)  # fmt: skip
    out = run_study(
        study,
        output,
        ledger_dir=ledger_dir,
        workers=args.workers,
        scheduler=args.scheduler,
        quiet=args.quiet,
    )
    ds = out.dataset
    print(
        f"\nstudy {study.name} finished: {out.computed} runs computed, {out.reused} taken from the ledger, "
        f"{out.failed} failed; wall time {out.wall_time:.1f} s (run time {out.run_time:.1f} core-s)"
    )
    if "boundary_lower" in ds:
        _print_boundary(ds)
    if "refined" in ds:
        print(
            f"multi-fidelity: {ds.attrs['cells_refined']} of {int(ds['refined'].size)} cells re-run with the full "
            f"scene (waves {ds.attrs['refinement_waves']}); {ds.attrs['cells_changed']} changed class"
        )
    print(f"wrote {output}")
    if not args.no_plot:
        from .figures import plot_dataset, save_figure

        png = args.plot or Path(output).with_suffix(".png")
        print(f"wrote {save_figure(plot_dataset(ds), png)}")
    return 0


def _print_boundary(ds) -> None:
    from .query import boundary_table

    print(f"boundary on {ds.attrs['boundary_axis']} ({ds.attrs['boundary_method']}), "
          f"stable {ds.attrs['boundary_stable_side']}:")  # fmt: skip
    print(boundary_table(ds))


def cmd_query(args: argparse.Namespace) -> int:
    from .query import query

    print(query(args.file, args.where, args.var))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from .config import read_toml

    if read_toml(args.scene).get("kind") == "abs":
        from .bench2 import run_bench_abs

        return run_bench_abs(args)
    from .bench import run_bench

    return run_bench(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hdi", description="Slider air-bearing and head-disk contact dynamics")
    parser.add_argument("--version", action="version", version=f"hdi-slider {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log diagnostics")
    parser.add_argument("--debug", action="store_true", help="on an error, show the Python traceback")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("fly", help="steady flying attitude of a scene")
    _add_scene_args(p)
    p.add_argument("-o", "--output", type=Path, help="netCDF file for the steady state")
    p.add_argument("--plot", type=Path, help="PNG of the steady pressure")
    p.set_defaults(func=cmd_fly)

    p = sub.add_parser("simulate", help="one run: steady flight + disturbance, contacts, classification")
    _add_scene_args(p)
    p.add_argument("-o", "--output", type=Path, help="netCDF file of the run")
    p.add_argument("--plot", type=Path, help="PNG of the run")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("plot", help="draw the figure that fits a result file")
    p.add_argument("file", type=Path)
    p.add_argument("--overlay", type=Path, help="a boundary study of the same axes, drawn over a grid study")
    p.add_argument("-o", "--output", type=Path, required=True, help="PNG file")
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("run", help="run (or resume) a study: a grid of runs, or a traced boundary, on dask")
    p.add_argument("study", help="study file (TOML), e.g. studies/fig17.toml")
    p.add_argument("-o", "--output", type=Path, help="netCDF file (default results/NAME.nc, NAME_boundary.nc)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="local worker processes (default: one per core; 0: in this process)")
    where.add_argument("--scheduler", help="address of a running dask scheduler, e.g. tcp://127.0.0.1:8786")
    p.add_argument("--mode", choices=("grid", "boundary", "multifidelity"), help="override the study's mode")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a base-scene value for every run, e.g. --set numerics.nx=101")  # fmt: skip
    p.add_argument("--ledger", type=Path, help="folder of per-run records (default OUTPUT_FOLDER/.ledger/NAME)")
    p.add_argument("--dry-run", action="store_true", help="count runs and done runs, estimate the cost, run nothing")
    p.add_argument("--plot", type=Path, help="PNG of the study (default: next to the netCDF)")
    p.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    p.add_argument("-q", "--quiet", action="store_true", help="no line per finished run")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("query", help="print cells of a study dataset as a table")
    p.add_argument("file", type=Path)
    p.add_argument("--where", action="append", default=[], metavar="KEY=VALUE",
                   help="axis (scene key or dimension) = value, e.g. --where contact.mu=0.5 (repeatable)")  # fmt: skip
    p.add_argument("--var", action="append", default=None, help="variable to show (repeatable)")
    p.set_defaults(func=cmd_query)

    p = sub.add_parser(
        "bench", help="speed against error: grids, time steps (fixed, adaptive) and air-bearing levels, scene 1"
    )
    p.add_argument("--scene", default=str(DEFAULT_SCENE))
    p.add_argument("--quick", action="store_true", help="fewer cases and a coarse reference (a smoke check)")
    p.add_argument("--repeats", type=int, default=3, help="timed repeats per case (median reported)")
    p.add_argument("-o", "--output", type=Path, help="netCDF file of the benchmark table")
    p.add_argument("--figure", type=Path, help="work-precision figure (PNG; needs --output)")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("reproduce", help="the main job: scene-1 flight, two contact runs, Figure 17, into results/")
    p.add_argument("--results", default=str(RESULTS), help="output folder (default: results/)")
    p.add_argument("--workers", type=int, help="local worker processes for the studies (default: one per core)")
    p.add_argument("--skip-studies", action="store_true", help="only the flight and the two contact runs")
    p.add_argument("--skip-bench", action="store_true", help="leave out the benchmark (about 3 minutes)")
    p.add_argument("--skip-scene2", action="store_true", help="leave out scene 2 (flight, one run, four studies)")
    p.add_argument("-q", "--quiet", action="store_true", help="no line per finished study run")
    p.set_defaults(func=cmd_reproduce)
    return parser


#: Exit status of a command whose input was rejected, and of one whose computation found no answer.
EXIT_BAD_INPUT, EXIT_NO_ANSWER = 2, 1


def error_line(err: BaseException) -> tuple[str, int]:
    """The one line a failed command prints, and its exit status.

    Bad input (a parameter, a file) names the key, the value and what is allowed; a computation that found no
    answer (a :class:`solver.errors.SolverError`) adds what to try; anything else is a bug, reported as such.
    """
    if isinstance(err, SolverError):
        hint = f"; try {err.hint}" if err.hint else ""
        return f"hdi: error: {err}{hint}", EXIT_NO_ANSWER
    if isinstance(err, ParameterError | FileNotFoundError | ValueError):
        return f"hdi: error: {err}", EXIT_BAD_INPUT
    if isinstance(err, OSError):
        return f"hdi: error: {err.strerror or err}" + (f": {err.filename}" if err.filename else ""), EXIT_BAD_INPUT
    return (
        f"hdi: error: unexpected {type(err).__name__}: {err} (a bug: run again with --debug for the traceback "
        "and report it)",
        EXIT_NO_ANSWER,
    )


#: Arguments that name files or folders a command writes: checked before any work starts.
OUTPUT_ARGUMENTS = {"output": "-o/--output", "plot": "--plot", "figure": "--figure", "results": "--results"}


def check_outputs(args: argparse.Namespace) -> None:
    """Every file a command will write can be written: its folder exists (or is made) and takes a new file."""
    import tempfile

    for attr, option in OUTPUT_ARGUMENTS.items():
        value = getattr(args, attr, None)
        if not value:
            continue
        path = Path(value)
        folder = path if attr == "results" else path.parent
        if path.is_dir() and attr != "results":
            raise ParameterError(f"{option} {path}: is a folder; give a file name")
        try:
            folder.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryFile(dir=folder):
                pass
        except OSError as err:
            raise ParameterError(f"{option} {path}: cannot write in {folder} ({err.strerror or err})") from None


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING, format="%(name)s: %(message)s")
    try:
        check_outputs(args)
        return args.func(args)
    except KeyboardInterrupt:
        print("\nhdi: interrupted; finished runs are kept in the ledger: run the same command to resume",
              file=sys.stderr)  # fmt: skip
        return 130
    except Exception as err:
        if args.debug:
            raise
        line, status = error_line(err)
        print(line, file=sys.stderr)
        return status
