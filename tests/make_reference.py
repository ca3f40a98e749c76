"""Regenerate the stored reference datasets that ``tests/test_reference.py`` compares fresh runs with.

THE command to regenerate, from the repository root, after a change of results that is meant::

    python tests/make_reference.py

(``python tests/make_reference.py NAME ...`` regenerates only the named files, e.g. ``abs_run.nc``.)
Then review what changed (``hdi query``, or the failure messages of the test before regenerating)
and commit the new ``tests/data/*.nc`` with the change that explains them.

Each reference is one ``hdi`` command, run in-process through :func:`pipeline.cli.main`, on a grid
small enough that the whole comparison takes seconds:

- ``rails_fly.nc``: steady flight of scene 1 (``hdi fly``), pressure field included;
- ``rails_run.nc``: a scene-1 contact run (``hdi simulate``) with several impacts at both corner pairs;
- ``abs_run.nc``: a short scene-2 run (``hdi simulate``) on a 0.3-nm track, with light asperity contact;
- ``rails_study.nc``: a 2 x 3 scene-1 study (``hdi run tests/data/reference_study.toml``) in this process.

The commands live in :data:`REFERENCES` only; the test imports them, so the stored files and the
runs they are compared with cannot drift apart.  This script depends on the command line and on
``pipeline.data.netcdf`` alone, never on the modules behind them.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from pipeline.cli import main
from pipeline.data.netcdf import open_result

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).resolve().parent / "data"
SCENE1 = str(ROOT / "studies" / "scenes" / "benson1989.toml")
SCENE2 = str(ROOT / "studies" / "scenes" / "chen_bogy2007.toml")
STUDY = str(DATA / "reference_study.toml")


def overrides(*settings: str) -> list[str]:
    """``--set KEY=VALUE`` arguments."""
    return [arg for setting in settings for arg in ("--set", setting)]


#: Scene 1 on 41 x 7 nodes per rail (9 on the taper); the study file sets the same grid.
RAILS_GRID = overrides("numerics.nx=41", "numerics.nx_taper=9", "numerics.ny=7")

#: Arguments of each reference, without the output file (see :func:`argv`).
REFERENCES: dict[str, list[str]] = {
    "rails_fly.nc": ["fly", SCENE1, *RAILS_GRID],
    "rails_run.nc": [
        "simulate",
        SCENE1,
        *RAILS_GRID,
        *overrides("numerics.t_end=60e-6", "numerics.output_interval=1.2e-6", "contact.mu=0.5", "contact.alpha=0.85"),
    ],
    # 61 x 51 nodes fly, with light asperity contact; so does 61 x 41 with refine = 2, but a 0.5-us step crashes
    # that grid into full contact, and adhesion (delta_gamma = 0.008 J/m2) pulls either grid into full contact.
    "abs_run.nc": [
        "simulate",
        SCENE2,
        *overrides("numerics.nx=61", "numerics.ny=51", "numerics.t_end=2e-5", "numerics.settle_time=5e-6"),
        *overrides("contact.delta_gamma=0.0", "disk.rms=0.3e-9"),  # 0.3 nm: light contact on the fitted face
    ],
    "rails_study.nc": ["run", STUDY, "--workers", "0", "--no-plot", "-q"],
}


def argv(name: str, output: Path, scratch: Path) -> list[str]:
    """The ``hdi`` arguments that write reference ``name`` to ``output``; a study's ledger goes to ``scratch``."""
    args = [*REFERENCES[name], "-o", str(output)]
    if args[0] == "run":
        args += ["--ledger", str(scratch / "ledger" / Path(output).stem)]
    return args


def run_reference(name: str, output: Path, scratch: Path) -> xr.Dataset:
    """Run the command of reference ``name`` in this process and open what it wrote."""
    status = main(argv(name, output, scratch))
    if status != 0:
        raise RuntimeError(f"hdi {' '.join(argv(name, output, scratch))} exited with status {status}")
    return open_result(output)


def not_worth_keeping(name: str, ds: xr.Dataset) -> str | None:
    """Why a fresh reference no longer exercises what it is there for (None: keep it)."""
    if name == "rails_run.nc" and int(ds["n_impacts"]) < 2:
        return f"only {int(ds['n_impacts'])} impacts"
    if name == "abs_run.nc" and (int(ds["status"]) != 0 or float(ds["contact_fraction"]) >= 0.5):
        return f"status {int(ds['status'])}, contact fraction {float(ds['contact_fraction']):.2f}: it does not fly"
    if name == "rails_study.nc" and len(np.unique(ds["stable"])) < 2:
        return "its cells are all of one class"
    return None


def regenerate(names: list[str]) -> None:
    """Run the named references and store them in tests/data/ (each only if it is worth keeping)."""
    unknown = sorted(set(names) - set(REFERENCES))
    if unknown:
        raise SystemExit(f"unknown reference(s) {unknown}; known: {sorted(REFERENCES)}")
    DATA.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            fresh = Path(tmp) / name
            ds = run_reference(name, fresh, Path(tmp))
            problem = not_worth_keeping(name, ds)
            if problem:
                raise SystemExit(f"{name}: not stored: {problem}; tests/data/{name} is unchanged")
            shutil.move(fresh, DATA / name)
            print(f"stored {DATA / name} ({(DATA / name).stat().st_size / 1e3:.1f} kB)")


if __name__ == "__main__":
    regenerate(sys.argv[1:] or list(REFERENCES))
