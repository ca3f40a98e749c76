"""The commands behind ``hdi``: fly, simulate, plot, run, query, bench (``pipeline.cli`` parses and dispatches)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np


def fly_scene(scene, output: Path | None = None, plot: Path | None = None, quiet: bool = False, modes: bool = False):
    """Steady flight of a scene of any kind: print it, write its dataset and figure; returns the dataset.

    ``modes``: also the modes of the slider on its air bearing (kinds that have a modal analysis).
    """
    from .data.netcdf import write_netcdf
    from .figures.common import save_figure
    from .kinds import adapter_of, plot_dataset

    adapter = adapter_of(scene)
    if modes and adapter.modes is None:
        raise ValueError(f"--modes: scenes of kind {adapter.name!r} have no modal analysis (kind 'abs' has)")
    t0 = time.perf_counter()
    steady = adapter.solver.fly(scene)
    wall = time.perf_counter() - t0
    if not quiet:
        print("\n".join(adapter.fly_report(steady, scene, wall)))
    ds = adapter.fly_dataset(steady, scene, wall)
    if modes:
        lines, variables = adapter.modes(scene, steady)
        if not quiet:
            print("\n".join(lines))
        ds = ds.assign(variables)
    if output:
        print(f"wrote {write_netcdf(ds, output)}")
    if plot:
        print(f"wrote {save_figure(plot_dataset(ds), plot)}")
    return ds


def simulate_scene(scene, output: Path | None = None, plot: Path | None = None, quiet: bool = False):
    """Fly and simulate a scene of any kind: print the run and its classification, write files; returns the dataset."""
    from .data.netcdf import write_netcdf
    from .figures.common import save_figure
    from .kinds import adapter_of, plot_dataset

    adapter = adapter_of(scene)
    result = adapter.solver.simulate(scene, **adapter.run_inputs(scene))
    ds = adapter.run_dataset(result, scene)
    if not quiet:
        print("\n".join(adapter.run_report(result, ds, scene)))
    if output:
        print(f"wrote {write_netcdf(ds, output)}")
    if plot:
        print(f"wrote {save_figure(plot_dataset(ds), plot)}")
    return ds


def cmd_fly(args: argparse.Namespace) -> int:
    from .config import load_scene

    scene = load_scene(args.scene, args.overrides)
    _compile_for(scene)
    if args.ladder is not None:
        if args.modes:
            raise ValueError("--ladder and --modes: give one of them (the modes are of one grid's flight)")
        ladder_scene(scene, args.ladder, args.output, args.plot)
        return 0
    fly_scene(scene, args.output, args.plot, modes=args.modes)
    return 0


def ladder_scene(scene, grids: str = "default", output: Path | None = None, plot: Path | None = None):
    """The steady flight of ``scene`` on a ladder of grids (:mod:`pipeline.ladder`): print it, write its dataset
    and figure; returns the dataset.  ``grids``: "NXxNY,..." or "default"."""
    from .data.netcdf import write_netcdf
    from .figures.common import save_figure
    from .kinds import adapter_of, plot_dataset
    from .ladder import default_grids, grid_ladder, ladder_report, parse_grids

    if adapter_of(scene).name != "abs":
        raise ValueError(f"--ladder: scenes of kind {adapter_of(scene).name!r} have no grid ladder (kind 'abs' has)")
    ladder = default_grids(scene.numerics.nx, scene.numerics.ny) if grids == "default" else parse_grids(grids)
    print(f"grid ladder of {scene.name}: {', '.join(f'{a} x {b}' for a, b in ladder)}")
    ds = grid_ladder(scene, ladder)
    print("\n".join(ladder_report(ds)))
    if output:
        print(f"wrote {write_netcdf(ds, output)}")
    if plot:
        print(f"wrote {save_figure(plot_dataset(ds), plot)}")
    return ds


def cmd_simulate(args: argparse.Namespace) -> int:
    from .config import load_scene

    scene = load_scene(args.scene, args.overrides)
    _compile_for(scene)
    simulate_scene(scene, args.output, args.plot)
    return 0


def _compile_for(scene) -> None:
    """The kernels of the scene's kind compiled in a child process first (:func:`pipeline.run.runner.compile_kernels`),
    so that this command runs the code a study's workers run, to the last bit."""
    from .kinds import adapter_of
    from .run.runner import compile_kernels

    compile_kernels((adapter_of(scene).name,))


def cmd_plot(args: argparse.Namespace) -> int:
    from pipeline.data.netcdf import open_result
    from pipeline.figures.common import save_figure
    from pipeline.kinds import plot_dataset

    ds = open_result(args.file)
    overlay = open_result(args.overlay) if args.overlay else None
    print(f"wrote {save_figure(plot_dataset(ds, overlay), args.output)}")
    return 0


# Cost model for --dry-run when the ledger has no finished run of the study yet: cost per film node and step
# on this machine, by scene kind.  rails: measured by `hdi bench` (0.25-0.38 ms per step at 2 x 201 x 21 nodes);
# abs: the default chen_bogy2007 run of a pad that flies (1.24 ms per step at 121 x 101 nodes, dt 0.2 us, the
# film's trapezoid: the bench at 3f0078b; the midpoint at 0.1 us took 1.04 ms, at 0.05 us 2.18 ms).
SECONDS_PER_NODE_STEP = {"rails": 4.0e-8, "abs": 1.0e-7}
#: scene-2 regimes whose pad stays on the disk (pipeline.classify.abs_regime): sustained contact, stuck
HELD_REGIMES = (2, 3)


def node_steps(scene) -> float:
    """The cost model's unit of a run: film nodes x time steps (each case with its own grid and step)."""
    num = scene.numerics
    nodes = (2 if scene.kind == "rails" else 1) * num.nx * num.ny  # rails: two films
    return nodes * num.t_end / num.dt


def held_cost_ratio(ledger) -> tuple[float, int, int] | None:
    """Time per step of the ledger's scene-2 runs held on the disk over that of the runs that fly or touch.

    (median ratio, runs held, runs flying) from every record of the folder, whichever study wrote it; None
    with fewer than 3 of either.  A dry run cannot know a cell's regime, so it prints the factor beside
    an estimate made for flying runs.
    """
    import json
    import statistics

    held, free = [], []
    for path in ledger.folder.glob("*.json"):
        try:
            record = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError):
            continue
        wall, steps, regime = record.get("wall_time"), record.get("steps"), record.get("regime")
        if not (isinstance(wall, float) and isinstance(steps, int) and steps > 0 and isinstance(regime, int)):
            continue
        if regime < 0:
            continue
        (held if regime in HELD_REGIMES else free).append(wall / steps)
    if len(held) < 3 or len(free) < 3:
        return None
    return statistics.median(held) / statistics.median(free), len(held), len(free)


def _estimate(study, ledger, todo: int, workers: int) -> str:
    """Cost of the runs still to do: node-steps of each pending case times a rate per node-step.

    The rate is the study's own (wall time over node-steps of its finished runs in the ledger) once it has
    any, else the kind's constant above.  Grid mode sums the pending cases, so that an axis of time steps or
    grids counts each case's steps and nodes; the other modes count ``todo`` runs of the base case.
    """
    if study.mode == "multifidelity":
        from pipeline.study.multifidelity import cheap_study

        study = cheap_study(study)
    base = study.case((0,) * len(study.axes)).scene
    kind = base.kind
    done_walls, done_work, pending_work = 0.0, 0.0, 0.0
    if study.mode == "grid":
        for case in study.cases():
            record = ledger.finished(case.run_id)
            wall = record.get("wall_time") if record is not None else None
            if record is None:
                pending_work += node_steps(case.scene)
            elif isinstance(wall, float) and wall == wall:
                done_walls, done_work = done_walls + wall, done_work + node_steps(case.scene)
    else:
        pending_work = todo * node_steps(base)
    if done_work > 0:
        rate, basis = done_walls / done_work, "rate of this study's finished runs in the ledger"
    else:
        rate, basis = SECONDS_PER_NODE_STEP[kind], f"model: {SECONDS_PER_NODE_STEP[kind]:g} s per node and step"
    total = pending_work * rate
    per_run = total / todo if todo else 0.0
    text = (
        f"~{per_run:.2f} s per run ({basis}; {pending_work / max(todo, 1):.3g} node-steps per run); "
        f"{todo} runs ~ {total:.0f} core-s, ~{total / max(workers, 1) / 60:.1f} min on {workers} workers"
    )
    if kind == "abs" and done_work == 0:
        ratio = held_cost_ratio(ledger)
        text += (
            f"\n  (for pads that fly or touch: a run held on the disk took {ratio[0]:.0f}x the time per step in this "
            f"ledger, median of {ratio[1]} such runs against {ratio[2]})"
            if ratio
            else "\n  (for pads that fly or touch: a pad held on the disk by adhesion or preload costs many times more)"
        )
    return text


def cmd_run(args: argparse.Namespace) -> int:
    import os

    from pipeline.run.fanout import default_ledger, default_output, run_study
    from pipeline.run.ledger import Ledger
    from pipeline.study.spec import lattice, load_study

    study = load_study(args.study, args.overrides, mode=args.mode, realizations=args.realizations)
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
            from pipeline.study.multifidelity import cheap_study

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
        print_boundary(ds)
    if "refined" in ds:
        print(
            f"multi-fidelity: {ds.attrs['cells_refined']} of {int(ds['refined'].size)} cells re-run with the full "
            f"scene (waves {ds.attrs['refinement_waves']}); {ds.attrs['cells_changed']} changed class"
        )
    print(f"wrote {output}")
    if not args.no_plot:
        from pipeline.figures.common import save_figure
        from pipeline.kinds import plot_dataset

        png = args.plot or Path(output).with_suffix(".png")
        print(f"wrote {save_figure(plot_dataset(ds), png)}")
    return 0


def print_boundary(ds) -> None:
    from pipeline.data.query import boundary_table

    low = ds.attrs.get("boundary_classes", "stable (low)").split(" (")[0]
    print(f"boundary on {ds.attrs['boundary_axis']} ({ds.attrs['boundary_method']}), "
          f"{low} {ds.attrs['boundary_stable_side']}:")  # fmt: skip
    print(boundary_table(ds))


def cmd_query(args: argparse.Namespace) -> int:
    from pipeline.data.query import query

    print(query(args.file, args.where, args.var))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from .config import load_scene
    from .kinds import adapter_of

    scene = load_scene(args.scene)
    adapter = adapter_of(scene)
    if adapter.bench is None:
        raise ValueError(f"{args.scene}: scene kind {adapter.name!r} has no benchmark")
    _compile_for(scene)
    return adapter.bench(args)
