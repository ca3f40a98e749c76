"""``hdi reproduce``: the main job, every canonical file in results/."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .commands import fly_scene, ladder_scene, print_boundary, simulate_scene
from .config import DEFAULT_SCENE, load_scene

FIG17_STUDY = Path(__file__).resolve().parent.parent / "studies" / "fig17.toml"


CONVERGENCE_STUDY = FIG17_STUDY.with_name("convergence.toml")
#: Figure 17 over friction and corner radius with Thornton's restitution (README, "Restitution that depends on
#: impact velocity"): 462 runs and their bisection, about a minute on 2 workers.
FIG17_THORNTON_STUDY = FIG17_STUDY.with_name("fig17_thornton.toml")


def _grid_and_boundary(args: argparse.Namespace, out: Path, path: Path) -> None:
    """A map as the full grid (``<name>.nc``) and as a traced boundary (``<name>_boundary.nc``), each with its own
    ledger so that both report their real cost; the figure ``<name>.png`` overlays the bisection on the grid."""
    from pipeline.figures.common import save_figure
    from pipeline.kinds import plot_dataset
    from pipeline.run.fanout import run_study
    from pipeline.study.spec import load_study

    outcomes = {}
    for mode in ("grid", "boundary"):
        study = load_study(path, mode=mode)
        name = study.name if mode == "grid" else f"{study.name}_boundary"
        print(f"\nstudy {name}: {study.size if mode == 'grid' else 'bisection of'} runs on {args.workers or 'all'} "
              "local workers", flush=True)  # fmt: skip
        outcomes[mode] = run_study(
            study, out / f"{name}.nc", ledger_dir=out / ".ledger" / name, workers=args.workers, quiet=args.quiet
        )
        o = outcomes[mode]
        print(f"study {name}: {o.computed} runs computed, {o.reused} from the ledger, {o.failed} failed, "
              f"wall time {o.wall_time:.1f} s, run time {o.run_time:.1f} core-s")  # fmt: skip
        print_boundary(o.dataset)
    fig = plot_dataset(outcomes["grid"].dataset, outcomes["boundary"].dataset)
    print(f"wrote {save_figure(fig, out / f'{study.name}.png')}")


def cmd_reproduce(args: argparse.Namespace) -> int:
    """The main job, into results/: scene-1 flight, the source's two contact runs, Figure 17, convergence, Figure 17
    with Thornton's restitution, bench; scene 2 (flight, one run, Table-I sweeps, regime map and, unless --quick,
    the statistics study).

    Figure 17 (and its Thornton map) runs as the full grid and as a traced boundary, each with its own ledger so
    that both report their real cost; running reproduce again resumes (or reuses) both from their ledgers.
    """
    from pipeline.figures.common import save_figure
    from pipeline.kinds import plot_dataset
    from pipeline.run.fanout import run_study
    from pipeline.study.spec import load_study

    out = Path(args.results)
    t0 = time.perf_counter()
    fly_scene(load_scene(DEFAULT_SCENE), out / "benson1989_fly.nc", out / "benson1989_fly.png")
    for alpha in ("0.80", "0.85"):
        scene = load_scene(DEFAULT_SCENE, [f"contact.alpha={alpha}", "contact.mu=0.5"])
        tag = alpha.replace(".", "")
        print()
        simulate_scene(scene, out / f"benson1989_mu05_alpha{tag}.nc", out / f"benson1989_mu05_alpha{tag}.png")
    if not args.skip_studies:
        _grid_and_boundary(args, out, FIG17_STUDY)
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
        _grid_and_boundary(args, out, FIG17_THORNTON_STUDY)
    if not args.skip_scene2:
        _reproduce_scene2(args, out)
    if not args.skip_bench:
        from pipeline.bench.rails import run_bench

        print("\nbenchmark: speed against error", flush=True)
        run_bench(argparse.Namespace(scene=str(DEFAULT_SCENE), quick=False, repeats=3,
                                     output=out / "bench_scene1.nc", figure=out / "work_precision.png"))  # fmt: skip
    print(f"\nreproduce finished in {time.perf_counter() - t0:.1f} s")
    return 0


SCENE2 = DEFAULT_SCENE.with_name("chen_bogy2007.toml")


#: Scene 2's studies in reproduce: the four Table-I sweeps and the regime map, 8 track realisations per cell
#: (4 in the map, whose flying boundary is then traced per track by bisection); then, unless --quick, the
#: statistics study (3 time steps x 8 realisations; its dt = 0.025 us runs cost 4 times its 0.1-us ones).  The
#: studies pin the numerics they were run with (the film's midpoint step at 0.1 us, the default until 2026-12-07).
#: They share one ledger (``.ledger/scene2``): a run is keyed by its scene, so the default cell that every sweep,
#: the map and the statistics hold is computed once (268 runs, 198 distinct).
SCENE2_STUDIES = ("pad_width", "preload", "roughness_adhesion", "friction", "pad_preload_map")
SCENE2_STATISTICS = "statistics"


def _reproduce_scene2(args: argparse.Namespace, out: Path) -> None:
    """Scene 2: steady flight with its modes and its grid ladder, one default 1-ms run, the four Table-I studies
    and the pad-preload regime map, and (unless --quick) the statistics study with its report, on one shared
    ledger."""
    from pipeline.figures.common import save_figure
    from pipeline.kinds import plot_dataset
    from pipeline.run.fanout import run_study
    from pipeline.study.spec import load_study

    print("\nscene 2: partial-contact femto slider", flush=True)
    fly_scene(load_scene(SCENE2), out / "chen_bogy2007_fly.nc", out / "chen_bogy2007_fly.png", modes=True)
    print()
    ladder_scene(load_scene(SCENE2), "default", out / "chen_bogy2007_ladder.nc", out / "chen_bogy2007_ladder.png")
    print()
    simulate_scene(load_scene(SCENE2), out / "chen_bogy2007_run.nc", out / "chen_bogy2007_run.png")
    if args.skip_studies:
        return
    from pipeline.data.sampling import report_text

    names = SCENE2_STUDIES if args.quick else (*SCENE2_STUDIES, SCENE2_STATISTICS)
    for name in names:
        study = load_study(SCENE2.parent.parent / f"{name}.toml")
        runs = len({case.run_id for case in study.cases()})
        print(f"\nstudy {name}: {study.size} cells x realisations, {runs} distinct runs", flush=True)
        o = run_study(study, out / f"{name}.nc", ledger_dir=out / ".ledger" / "scene2", workers=args.workers,
                      quiet=args.quiet)  # fmt: skip
        print(f"study {name}: {o.computed} runs computed, {o.reused} from the ledger, {o.failed} failed, "
              f"wall time {o.wall_time:.1f} s, run time {o.run_time:.1f} core-s")  # fmt: skip
        overlay = None
        if study.boundary is not None:  # the map's boundary, traced per track on the same ledger (the grid's runs
            # on the bisection lattice are reused): <name>_boundary.nc, drawn over the map
            bisect = load_study(study.path, mode="boundary")
            traced = run_study(bisect, out / f"{name}_boundary.nc", ledger_dir=out / ".ledger" / "scene2",
                               workers=args.workers, quiet=args.quiet)  # fmt: skip
            print(f"study {name}_boundary: {traced.computed} runs computed, {traced.reused} from the ledger, "
                  f"{traced.failed} failed, wall time {traced.wall_time:.1f} s")  # fmt: skip
            print_boundary(traced.dataset)
            overlay = traced.dataset
        print(f"wrote {save_figure(plot_dataset(o.dataset, overlay), out / f'{name}.png')}")
        if "se_slope_range" in o.dataset:
            print(report_text(o.dataset))
