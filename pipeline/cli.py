"""Command line: ``hdi fly | simulate | run | query | plot | bench | reproduce``.

Every command validates its whole configuration before computing anything;
errors name the key, the value and what is allowed, and exit with status 2.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from solver.errors import SolverError
from solver.params import ParameterError

from . import __version__
from .commands import cmd_bench, cmd_fly, cmd_plot, cmd_query, cmd_run, cmd_simulate
from .config import DEFAULT_SCENE, RESULTS
from .reproduce import cmd_reproduce


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
    p.add_argument(
        "--modes",
        action="store_true",
        help="also the slider's modes on its air bearing: frequencies, damping ratios, shapes, and the damping "
        "the scene's time step adds to each (kind abs)",
    )
    p.add_argument(
        "--ladder",
        nargs="?",
        const="default",
        metavar="GRIDS",
        help="the flight on a ladder of grids instead (kind abs): NXxNY,NXxNY,... or, without a value, the "
        "scene's grid with its intervals scaled by 2/3, 1, 4/3, 2 and 8/3; fits f0 + b h^p and Richardson's "
        "estimate to the flying height, pitch, roll and smallest spacing (-o writes the ladder, --plot its figure)",
    )
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
    p.add_argument("--realizations", type=int, metavar="N",
                   help="realisations per cell instead of the study file's (default 8 for a rough track)")  # fmt: skip
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
        "bench",
        help="speed against error: grids, time steps and models (scene 1), settings against today's solver "
        "and over track realisations (scene 2)",
    )
    p.add_argument("--scene", default=str(DEFAULT_SCENE))
    p.add_argument("--quick", action="store_true", help="fewer cases and a coarse reference (a smoke check)")
    p.add_argument("--repeats", type=int, default=3, help="timed repeats per case (median reported)")
    p.add_argument("-o", "--output", type=Path, help="netCDF file of the benchmark table")
    p.add_argument("--figure", type=Path, help="work-precision figure (PNG; needs --output)")
    p.add_argument(
        "--seeds", type=int, help="scene 2: track realisations of the accuracy comparison (default 8, 2 quick)"
    )
    p.add_argument("--baseline-ref", default="c3337da",
                   help="scene 2: git ref of today's solver, timed in a temporary worktree ('' to skip)")  # fmt: skip
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("reproduce", help="the main job: scenes 1 and 2, their studies and the bench, into results/")
    p.add_argument("--results", default=str(RESULTS), help="output folder (default: results/)")
    p.add_argument("--workers", type=int, help="local worker processes for the studies (default: one per core)")
    p.add_argument("--skip-studies", action="store_true", help="only the flight and the two contact runs")
    p.add_argument("--skip-bench", action="store_true", help="leave out the benchmark (about 3 minutes)")
    p.add_argument(
        "--skip-scene2",
        action="store_true",
        help="leave out scene 2 (flight, one run, four Table-I studies, regime map, statistics)",
    )
    p.add_argument("--quick", action="store_true",
                   help="scene 2 without the statistics study (3 time steps x 8 realisations; the dt = 0.05 and "
                        "0.025 us runs cost 2 and 4 times the default)")  # fmt: skip
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
