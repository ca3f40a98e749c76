"""The study layer with real parts: study files, the ledger, dask workers, netCDF datasets.

Dask runs use real worker processes (an embedded LocalCluster, or a
``dask scheduler`` and two ``dask worker`` processes started from the shell);
datasets are written to netCDF and read back.  The scenes are scene 1 on a
small grid (61 x 9 nodes per rail, 100 us), so that a run costs ~0.1 s.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from conftest import cf_errors

from pipeline.cli import main
from pipeline.commands import held_cost_ratio
from pipeline.config import ConfigError
from pipeline.data.netcdf import open_result
from pipeline.data.studyset import grid_boundary
from pipeline.figures.common import pyplot
from pipeline.figures.rails import log_spaced, plot_stability_map
from pipeline.run.fanout import dask_client, execute, run_study
from pipeline.run.ledger import Ledger
from pipeline.run.runner import run_case
from pipeline.study.boundary import BisectionPlanner
from pipeline.study.spec import axis_range, load_study
from solver.params import ParameterError

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "studies" / "scenes" / "benson1989.toml"
SMALL = """
[set]
"numerics.nx" = 61
"numerics.nx_taper" = 11
"numerics.ny" = 9
"numerics.t_end" = 100e-6
"""


def write_study(folder: Path, axes: str, name: str = "small", extra: str = "") -> Path:
    path = folder / f"{name}.toml"
    path.write_text(
        f'[study]\nname = "{name}"\ntitle = "test study {name}"\nscene = "{SCENE}"\n{SMALL}\n{axes}\n{extra}'
    )
    return path


MU_ALPHA = """
[[axes]]
key = "contact.mu"
dim = "mu"
values = [0.0, 0.5]

[[axes]]
key = "contact.alpha"
dim = "alpha"
start = 0.5
stop = 1.0
step = 0.25
"""
BOUNDARY = '[boundary]\naxis = "contact.alpha"\ntolerance = 0.25\n'


# The dask command of the interpreter running the tests: a virtual environment that is not activated has no
# `dask` on PATH, and a global one would be another installation.
DASK = str(Path(sys.executable).with_name("dask"))


def cli(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "pipeline", *args], capture_output=True, text=True, cwd=ROOT, timeout=300, **kwargs
    )


def same_results(a: xr.Dataset, b: xr.Dataset) -> None:
    """Every variable equal (NaN == NaN), except the runs' wall times; the same run ids."""
    assert set(a.data_vars) == set(b.data_vars)
    for name in a.data_vars:
        if name == "wall_time":
            continue
        xr.testing.assert_identical(a[name], b[name])


# ----------------------------------------------------------------------------- study files


def test_axis_range_includes_stop_and_rounds():
    mu = axis_range(0.0, 1.0, 0.1)
    assert len(mu) == 11 and mu[3] == 0.3 and mu[-1] == 1.0
    alpha = axis_range(0.0, 1.0, 0.05)
    assert len(alpha) == 21 and alpha[17] == 0.85


def test_fig17_study_file_expands_to_the_issue_grid():
    study = load_study(ROOT / "studies" / "fig17.toml")
    assert study.dims == ("mu", "alpha", "zdot0")
    assert study.shape == (11, 21, 2) and study.size == 462
    assert study.axis("zdot0").values == (-0.01, -0.02)
    cases = study.cases()
    assert len({c.run_id for c in cases}) == 462
    case = study.case((5, 17, 0))
    assert (case.scene.contact.mu, case.scene.contact.alpha, case.scene.initial.zdot) == (0.5, 0.85, -0.01)


RADII = '[[axes]]\nkey = "contact.corner_radius"\nvalues = [1e-6, 3.162e-6, 10e-6, 31.62e-6, 100e-6]\n'


def test_fig17_thornton_study_file_expands_to_the_issue_grid():
    # friction 0-1 by corner radius 1-100 um (10 per decade) by the two disturbances; restitution by Thornton's law
    study = load_study(ROOT / "studies" / "fig17_thornton.toml")
    assert study.dims == ("mu", "corner_radius", "zdot0") and study.shape == (11, 21, 2)
    radii = np.array(study.axis("corner_radius").values)
    np.testing.assert_allclose(radii, np.logspace(-6, -4, 21), rtol=5e-4)
    case = study.case((5, 10, 1))
    c = case.scene.contact
    assert (c.restitution, c.mu, c.corner_radius, case.scene.initial.zdot) == ("thornton", 0.5, 10e-6, -0.02)
    assert {"first_impact_alpha", "first_yield_velocity"} <= set(study.variables)
    assert study.boundary.lattice == "axis" and study.boundary.tolerance is None
    assert load_study(study.path, mode="boundary").mode == "boundary"


@pytest.mark.parametrize(
    ("axes", "extra", "expected"),
    [
        ('[[axes]]\nkey = "contact.mu"\nvalues = [0.1]\nunits = "m"\n', "", "unknown key 'units'"),
        ('[[axes]]\nkey = "contact.friction"\nvalues = [0.1]\n', "", "axis 'contact.friction': the scene has no such"),
        ('[[axes]]\nkey = "contact.mu"\nvalues = []\n', "", "is empty"),
        ('[[axes]]\nkey = "contact.mu"\nstart = 1.0\nstop = 0.0\nstep = 0.1\n', "", "is empty"),
        ('[[axes]]\nkey = "contact.alpha"\nvalues = [0.5, 1.2]\n', "", "value 1.2 is not allowed"),
        ('[[axes]]\nkey = "contact.mu"\nvalues = [0.1, 0.1]\n', "", "repeats a value"),
        ('[[axes]]\nkey = "contact.mu"\nvalues = [0.1]\n', "[outputs]\nvariables = ['stability']\n", "'stability'"),
        ('[[axes]]\nkey = "contact.mu"\nvalues = [0.1]\n', "[extras]\na = 1\n", "unknown section"),
        ('[[axes]]\nkey = "contact.mu"\nvalues = [0.1]\n', '[boundary]\naxis = "contact.alpha"\ntolerance = 0.1\n',
         "not one of the axes"),
        (RADII, '[boundary]\naxis = "contact.corner_radius"\nlattice = "log"\n', "'log' is not allowed"),
        (RADII, '[boundary]\naxis = "contact.corner_radius"\nlattice = "axis"\ntolerance = 1e-6\n',
         "[boundary] tolerance: is not used with lattice = 'axis'"),
        (RADII.replace("1e-6, 3.162e-6", "3.162e-6, 1e-6"), '[boundary]\naxis = "contact.corner_radius"\n'
         'lattice = "axis"\n', "in increasing order"),
        (RADII.replace("[1e-6", "[-1e-6"), "", "contact.corner_radius = -1e-06 is not allowed: must be > 0 [m]"),
    ],
)  # fmt: skip
def test_bad_study_files_are_rejected_naming_file_and_key(tmp_path, axes, extra, expected):
    path = write_study(tmp_path, axes, extra=extra)
    with pytest.raises(ConfigError) as err:
        load_study(path)
    assert expected in str(err.value)
    assert str(path) in str(err.value)


def test_cli_rejects_bad_input_before_any_run(tmp_path, capsys):
    bad = write_study(tmp_path, '[[axes]]\nkey = "contact.mu"\nvalues = [-0.5]\n')
    assert main(["run", str(bad), "-o", str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err
    assert "contact.mu" in err and "-0.5" in err and str(bad) in err
    assert not (tmp_path / ".ledger").exists()
    assert main(["run", str(SCENE)]) == 2
    assert "not a study file" in capsys.readouterr().err
    study = write_study(tmp_path, MU_ALPHA)
    assert main(["run", str(study), "--set", "contact.alpha=0.3"]) == 2
    assert "is an axis" in capsys.readouterr().err


def test_dry_run_counts_and_runs_nothing(tmp_path, capsys):
    study = write_study(tmp_path, MU_ALPHA)
    out = tmp_path / "small.nc"
    assert main(["run", str(study), "-o", str(out), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "runs: 6, already done: 0" in text and "estimate" in text
    assert not out.exists()
    assert len(Ledger(tmp_path / ".ledger" / "small")) == 0


def test_dry_run_estimate_counts_each_cases_time_steps(tmp_path, capsys):
    # An axis of time steps: the run at dt / 2 has twice the steps, so the pair costs 1.5 times two runs at dt.
    def per_run(axes: str, name: str) -> float:
        study = write_study(tmp_path, axes, name=name)
        assert main(["run", str(study), "-o", str(tmp_path / f"{name}.nc"), "--dry-run"]) == 0
        text = capsys.readouterr().out
        return float(re.search(r"([0-9.e+]+) node-steps per run", text).group(1))

    dt = tomllib.loads(SCENE.read_text())["numerics"]["dt"]
    at_dt = per_run(MU_ALPHA, "same")  # every case at the scene's dt
    halved = per_run(f'[[axes]]\nkey = "numerics.dt"\ndim = "dt"\nvalues = [{dt!r}, {dt / 2!r}]\n', "halved")
    assert at_dt == pytest.approx(2 * 61 * 9 * 100e-6 / dt, rel=5e-3)  # two films of 61 x 9 nodes
    assert halved / at_dt == pytest.approx(1.5, rel=5e-3)


def test_held_cost_ratio_reads_the_ledgers_regimes(tmp_path):
    ledger = Ledger(tmp_path)
    for i, (regime, wall, steps) in enumerate([(0, 1.0, 100), (1, 1.2, 100), (0, 2.0, 200), (3, 12.0, 100),
                                               (2, 24.0, 200), (3, 13.0, 100), (-1, 99.0, 100)]):  # fmt: skip
        ledger.put({"run_id": f"r{i}", "status": 0, "regime": regime, "wall_time": wall, "steps": steps})
    ledger.put({"run_id": "rails", "status": 0, "wall_time": 5.0, "steps": 100})  # no regime: not counted
    ratio, held, free = held_cost_ratio(ledger)
    assert (held, free) == (3, 3)
    assert ratio == pytest.approx(0.12 / 0.010)  # medians of the time per step: 12 ms against 1 ms
    (tmp_path / "r5.json").unlink()
    assert held_cost_ratio(ledger) is None  # fewer than 3 held runs


# ----------------------------------------------------------------------------- ledger and runs


def test_ledger_round_trip_is_atomic_and_keeps_nan(tmp_path):
    ledger = Ledger(tmp_path)
    ledger.put({"run_id": "abc", "status": 0, "max_impulse_ratio": float("nan"), "impacts": {"time": [1e-6]}})
    record = ledger.get("abc")
    assert np.isnan(record["max_impulse_ratio"]) and record["impacts"]["time"] == [1e-6]
    ledger.put({"run_id": "bad", "status": -1, "message": "boom"})
    assert ledger.finished("abc") is not None and ledger.finished("bad") is None
    (tmp_path / "torn.json").write_text('{"run_id": "torn", "sta')  # a file cut short reads as missing
    assert ledger.get("torn") is None
    assert not list(tmp_path.glob("*.tmp"))


def test_failing_run_is_recorded_with_status_and_message_and_the_study_completes(tmp_path):
    # The second calibration height puts the rear corners below the asperities: the run raises ContactError.
    axes = '[[axes]]\nkey = "calibration.z"\ndim = "z_cal"\nvalues = [0.115e-6, 0.03e-6]\n'
    study = load_study(write_study(tmp_path, axes))
    out = run_study(study, tmp_path / "fail.nc", workers=0, quiet=True)
    ds = open_result(tmp_path / "fail.nc")
    assert out.failed == 1 and out.computed == 2
    assert ds["status"].values.tolist() == [0, -1]
    assert ds["stable"].values[1] == -1 and ds["n_impacts"].values[1] == -1
    message = str(ds["message"].values[1])
    assert message.startswith("ContactError: a corner starts below the asperity height"), message
    assert ds["status"].values[0] == 0 and ds["n_impacts"].values[0] >= 1
    # the failure is in the ledger too, and a second invocation retries only the failed run
    again = run_study(study, tmp_path / "fail.nc", workers=0, quiet=True)
    assert (again.computed, again.reused) == (1, 1)


def test_a_study_run_with_overrides_says_so_in_its_title(tmp_path):
    """--set changes the study's runs, so its title (figures, netCDF) names the overrides; the file's stays as is."""
    path = write_study(tmp_path, MU_ALPHA)
    assert load_study(path).title == "test study small"
    study = load_study(path, ["numerics.dt=0.2e-6"])
    assert study.title == "test study small [--set numerics.dt=0.2e-6]"
    assert study.base["numerics"]["dt"] == 0.2e-6


def test_dataset_written_and_read_back_has_cf_attributes(tmp_path):
    study = load_study(write_study(tmp_path, MU_ALPHA, extra=BOUNDARY))
    path = tmp_path / "cf.nc"
    run_study(study, path, workers=0, quiet=True)
    assert cf_errors(path) == []
    with xr.open_dataset(path) as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        assert ds.attrs["title"] == "test study small"
        assert "hdi-slider" in ds.attrs["source"] and ds.attrs["package_version"] in ds.attrs["source"]
        assert ds.attrs["history"][:4].isdigit() and "created by hdi-slider" in ds.attrs["history"]
        assert ds.attrs["study_toml"] == study.text and "[contact]" in ds.attrs["scene_toml"]
        assert len(ds.attrs["config_hash"]) == 16 and ds.attrs["git_commit"]
        for name, v in {**ds.data_vars, **ds.coords}.items():
            assert "long_name" in v.attrs, name
            if name not in ("message", "run_id", "impact_corner", "impact"):
                assert "units" in v.attrs, name
        assert ds["stable"].dtype == np.int8 and ds["stable"].attrs["flag_meanings"].split() == [
            "not_classified", "unstable", "stable"]  # fmt: skip
        assert list(ds["stable"].attrs["flag_values"]) == [-1, 0, 1]
        assert ds["status"].dtype == np.int8 and "not_run" in ds["status"].attrs["flag_meanings"]
        assert ds["mu"].attrs["scene_key"] == "contact.mu" and ds["alpha"].attrs["units"] == "1"
        assert ds.sizes == {"mu": 2, "alpha": 3, "impact": 20}
        # the grid's boundary bracket: stable at lower, unstable at upper, on every line
        for mu in ds["mu"].values:
            line = ds.sel(mu=mu)
            assert line["stable"].sel(alpha=float(line["boundary_lower"])) == 1
            assert line["stable"].sel(alpha=float(line["boundary_upper"])) == 0


def test_query_prints_the_selected_cells(tmp_path, capsys):
    study = load_study(write_study(tmp_path, MU_ALPHA))
    path = tmp_path / "q.nc"
    run_study(study, path, workers=0, quiet=True)
    capsys.readouterr()
    assert main(["query", str(path), "--where", "contact.mu=0.5", "--var", "stable", "--var", "n_impacts"]) == 0
    rows = [r for r in capsys.readouterr().out.splitlines() if r.strip().startswith(("0.5", "0.75", "1.0"))]
    assert len(rows) == 3
    ds = open_result(path)
    for row in rows:
        alpha = float(row.split()[-3])
        assert int(row.split()[-2]) == int(ds["stable"].sel(mu=0.5, alpha=alpha))
    assert main(["query", str(path), "--where", "mu=0.3"]) == 2
    assert "not on the mu axis" in capsys.readouterr().err


def test_stability_map_figure_is_rendered(tmp_path):
    study = load_study(write_study(tmp_path, MU_ALPHA, extra=BOUNDARY))
    run_study(study, tmp_path / "g.nc", workers=0, quiet=True)
    bstudy = load_study(write_study(tmp_path, MU_ALPHA, extra=BOUNDARY), mode="boundary")
    run_study(bstudy, tmp_path / "b.nc", workers=0, quiet=True)
    png = tmp_path / "map.png"
    assert main(["plot", str(tmp_path / "g.nc"), "--overlay", str(tmp_path / "b.nc"), "-o", str(png)]) == 0
    import matplotlib.image

    image = matplotlib.image.imread(png)
    assert image.shape[0] > 300 and image.shape[1] > 300
    assert np.unique(image.reshape(-1, image.shape[-1]), axis=0).shape[0] > 10


# ----------------------------------------------------------------------------- boundary bisection


def threshold_runner(boundary_of_mu):
    """A stand-in run for testing the planner alone: stable iff alpha <= boundary_of_mu(mu)."""

    def run(scene_dict, run_id, impacts_kept):
        c = scene_dict["contact"]
        return {"run_id": run_id, "status": 0, "stable": int(c["alpha"] <= boundary_of_mu(c["mu"]) + 1e-12),
                "message": "threshold", "wall_time": 0.0}  # fmt: skip

    return run


@pytest.mark.parametrize("side", ["linear", "all_stable", "all_unstable", "jumpy"])
def test_bisection_finds_the_grid_boundary_with_fewer_runs(tmp_path, side):
    boundary = {
        "linear": lambda mu: 0.85 - 0.3 * mu,
        "all_stable": lambda mu: 2.0,
        "all_unstable": lambda mu: -1.0,
        "jumpy": lambda mu: 0.2 if mu > 0.45 else 0.9,
    }[side]
    axes = MU_ALPHA.replace("values = [0.0, 0.5]", "start = 0.0\nstop = 1.0\nstep = 0.1").replace(
        "start = 0.5\nstop = 1.0\nstep = 0.25", "start = 0.0\nstop = 1.0\nstep = 0.05"
    )
    extra = '[boundary]\naxis = "contact.alpha"\ntolerance = 0.05\n'
    grid = load_study(write_study(tmp_path, axes, extra=extra))
    runner = threshold_runner(boundary)
    g = run_study(grid, tmp_path / "g.nc", workers=0, quiet=True, runner=runner, ledger_dir=tmp_path / "lg")
    b = run_study(load_study(grid.path, mode="boundary"), tmp_path / "b.nc", workers=0, quiet=True, runner=runner,
                  ledger_dir=tmp_path / "lb")  # fmt: skip
    gd, bd = g.dataset, b.dataset
    np.testing.assert_array_equal(gd["boundary_lower"].values, bd["boundary_lower"].values)
    np.testing.assert_array_equal(gd["boundary_upper"].values, bd["boundary_upper"].values)
    assert g.computed == 231
    # cold line: 2 ends + ceil(log2 20) = 7; continued lines a few runs each
    assert b.computed <= 7 + 10 * (5 if side == "jumpy" else 3), b.computed
    assert b.computed < 231 / 4


def test_bisection_on_the_axis_values_of_a_log_axis_finds_the_grid_boundary(tmp_path):
    # lattice = "axis": the bisection probes the axis's own (log-spaced) values, so its runs are the grid's
    radii = [float(f"{r:.4g}") for r in np.logspace(-6, -4, 21)]
    axes = MU_ALPHA.replace("values = [0.0, 0.5]", "start = 0.0\nstop = 1.0\nstep = 0.1").replace(
        'key = "contact.alpha"\ndim = "alpha"\nstart = 0.5\nstop = 1.0\nstep = 0.25',
        f'key = "contact.corner_radius"\ndim = "corner_radius"\nvalues = {radii}',
    )
    extra = '[boundary]\naxis = "contact.corner_radius"\nlattice = "axis"\n'
    grid = load_study(write_study(tmp_path, axes, extra=extra))

    def run(scene_dict, run_id, impacts_kept):  # stable iff R <= 30 um x 10^(-2 mu)
        c = scene_dict["contact"]
        return {"run_id": run_id, "status": 0, "stable": int(c["corner_radius"] <= 30e-6 * 10 ** (-2 * c["mu"]))}

    g = run_study(grid, tmp_path / "g.nc", workers=0, quiet=True, runner=run, ledger_dir=tmp_path / "lg")
    b = run_study(load_study(grid.path, mode="boundary"), tmp_path / "b.nc", workers=0, quiet=True, runner=run,
                  ledger_dir=tmp_path / "lb")  # fmt: skip
    lower, upper = g.dataset["boundary_lower"].values, g.dataset["boundary_upper"].values
    np.testing.assert_array_equal(b.dataset["boundary_lower"].values, lower)
    np.testing.assert_array_equal(b.dataset["boundary_upper"].values, upper)
    assert lower[0] == 25.12e-6 and upper[0] == 31.62e-6 and np.isnan(lower[-1]) and upper[-1] == 1e-6
    np.testing.assert_array_equal(b.dataset["corner_radius"].values, radii)
    assert b.dataset.attrs["boundary_lattice"] == "the axis values" and "boundary_tolerance" not in b.dataset.attrs
    assert b.computed < g.computed / 3
    # the map draws a log-spaced axis on a log scale, the boundary through the bracket's geometric middle
    fig = plot_stability_map(g.dataset, b.dataset)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log" and ax.get_xscale() == "linear"
    line = next(line for line in ax.get_lines() if line.get_label() == "boundary (grid)")
    np.testing.assert_allclose(line.get_ydata(), np.sqrt(lower * upper), rtol=1e-15)
    pyplot().close(fig)


def test_log_spaced_axes_are_told_from_linear_ones():
    assert log_spaced(np.array([float(f"{r:.4g}") for r in np.logspace(-6, -4, 21)]))
    assert not log_spaced(np.linspace(0.0, 1.0, 21))  # fig17's alpha
    assert not log_spaced(np.array([1000.0, 1001.0, 1002.0]))  # nearly geometric, but a constant step
    assert not log_spaced(np.array([1e-6, 1e-5]))  # two values say nothing about the spacing


def test_bisection_reuses_grid_runs_from_the_ledger(tmp_path):
    study = load_study(write_study(tmp_path, MU_ALPHA, extra=BOUNDARY))
    runner = threshold_runner(lambda mu: 0.7)
    run_study(study, tmp_path / "g.nc", workers=0, quiet=True, runner=runner)
    b = run_study(load_study(study.path, mode="boundary"), tmp_path / "b.nc", workers=0, quiet=True, runner=runner)
    assert b.computed == 0 and b.reused > 0
    assert b.dataset["boundary_lower"].values.tolist() == [0.5, 0.5]


def test_grid_boundary_flags_several_crossings():
    lo, hi, mono = grid_boundary(np.array([[1, 1, 0, 0], [1, 0, 1, 0], [1, 1, 1, 1], [0, 0, 0, 0]]))
    assert lo.tolist() == [1, 0, 3, -1] and hi.tolist() == [2, 1, 4, 0]
    assert mono.tolist() == [True, False, True, True]


def test_bisection_planner_sees_failed_probes_and_narrows_around_them(tmp_path):
    study = load_study(write_study(tmp_path, MU_ALPHA.replace("values = [0.0, 0.5]", "values = [0.2]").replace(
        "start = 0.5\nstop = 1.0\nstep = 0.25", "start = 0.0\nstop = 1.0\nstep = 0.1"), extra=BOUNDARY.replace(
        "0.25", "0.1")), mode="boundary")  # fmt: skip

    def run(scene_dict, run_id, impacts_kept):
        a = scene_dict["contact"]["alpha"]
        if abs(a - 0.5) < 1e-9:
            return {"run_id": run_id, "status": -1, "message": "failed on purpose"}
        return {"run_id": run_id, "status": 0, "stable": int(a < 0.65)}

    planner = BisectionPlanner(study)
    taken = execute(study, planner, Ledger(tmp_path / "l"), None, runner=run)
    (line,) = planner.summary()
    assert (line["lower"], line["upper"]) == (0.6, 0.7)
    assert 5 in line["probed"] and len(taken) == line["runs"]


# ----------------------------------------------------------------------------- multi-fidelity maps

MULTI = '[multifidelity.cheap]\nmodels.air_bearing = "linearized"\n'


def two_level_runner(full_boundary, cheap_boundary):
    """Stand-in runs: the cheap level (linearized bearing) puts the boundary elsewhere than the full one."""

    def run(scene_dict, run_id, impacts_kept):
        c = scene_dict["contact"]
        cheap = scene_dict["models"]["air_bearing"] == "linearized"
        edge = (cheap_boundary if cheap else full_boundary)(c["mu"])
        return {"run_id": run_id, "status": 0, "stable": int(c["alpha"] <= edge + 1e-12), "message": "level",
                "wall_time": 0.0}  # fmt: skip

    return run


@pytest.mark.parametrize("shift", [0.0, 0.1, 0.25])
def test_multifidelity_map_equals_the_full_grid_and_reruns_few_cells(tmp_path, shift):
    axes = MU_ALPHA.replace("values = [0.0, 0.5]", "start = 0.0\nstop = 1.0\nstep = 0.1").replace(
        "start = 0.5\nstop = 1.0\nstep = 0.25", "start = 0.0\nstop = 1.0\nstep = 0.05"
    )
    path = write_study(tmp_path, axes, extra=MULTI)
    runner = two_level_runner(lambda mu: 0.8 - 0.4 * mu, lambda mu: 0.8 - 0.4 * mu + shift)
    full = run_study(load_study(path), tmp_path / "g.nc", workers=0, quiet=True, runner=runner,
                     ledger_dir=tmp_path / "lg")  # fmt: skip
    multi = run_study(load_study(path, mode="multifidelity"), tmp_path / "m.nc", workers=0, quiet=True,
                      runner=runner, ledger_dir=tmp_path / "lm")  # fmt: skip
    ds = multi.dataset
    # the boundary-following waves recover the full model's map exactly
    np.testing.assert_array_equal(ds["stable"].values, full.dataset["stable"].values)
    # every re-run cell is a full-model run; the count of changed cells is that of the shifted band
    band = int((ds["stable"].values != ds["stable_cheap"].values).sum())
    assert ds.attrs["cells_changed"] == band
    assert band == 0 if shift == 0.0 else band > 0
    refined = int(ds["refined"].sum())
    assert ds.attrs["cells_refined"] == refined
    # 231 cheap runs + the refined cells: 2 cells per mu line when the cheap boundary is right,
    # plus the band between the two boundaries and one cell either side otherwise
    assert multi.computed == 231 + refined
    assert refined <= 11 * 2 + band + 2 * 11, refined
    # run again on the same ledger (as after an interruption): nothing is recomputed, the map is the same
    again = run_study(load_study(path, mode="multifidelity"), tmp_path / "m2.nc", workers=0, quiet=True,
                      runner=runner, ledger_dir=tmp_path / "lm")  # fmt: skip
    assert again.computed == 0 and again.reused == multi.computed
    np.testing.assert_array_equal(again.dataset["stable"].values, ds["stable"].values)
    assert again.dataset.attrs["cells_changed"] == ds.attrs["cells_changed"]
    # reading back: the multi-fidelity variables survive netCDF
    back = xr.open_dataset(tmp_path / "m.nc")
    assert int(back.attrs["cells_changed"]) == band and "stable_cheap" in back
    back.close()


def test_multifidelity_needs_a_cheap_table_that_changes_the_scene(tmp_path):
    path = write_study(tmp_path, MU_ALPHA)
    with pytest.raises(ConfigError, match="multifidelity"):
        load_study(path, mode="multifidelity")
    path = write_study(tmp_path, MU_ALPHA, extra='[multifidelity.cheap]\nmodels.air_bearing = "reynolds"\n')
    with pytest.raises(ConfigError, match="does not change the scene"):
        load_study(path)
    path = write_study(tmp_path, MU_ALPHA, extra='[multifidelity.cheap]\nmodels.air_bearing = "table"\n')
    with pytest.raises(ConfigError, match="air_bearing"):
        load_study(path)
    path = write_study(tmp_path, MU_ALPHA, extra='[multifidelity]\naxes = ["contact.nope"]\n' + MULTI)
    with pytest.raises(ConfigError, match=r"\[multifidelity\] axes"):
        load_study(path)


# ----------------------------------------------------------------------------- real dask processes


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_study_on_a_dask_scheduler_and_two_workers_started_by_hand(tmp_path):
    study = write_study(tmp_path, MU_ALPHA)
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--dashboard-address", ":0"], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]  # fmt: skip
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([DASK, "worker", address, "--nthreads", "1", "--no-dashboard"], env=env,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))  # fmt: skip
        from distributed import Client

        with Client(address, timeout="60s") as probe:
            probe.wait_for_workers(2, timeout=60)
            threads = probe.run(lambda: os.environ.get("NUMBA_NUM_THREADS"))
            assert sorted(threads.values()) == ["1", "1"]
        res = cli("run", str(study), "-o", str(tmp_path / "remote.nc"), "--scheduler", address, "--no-plot")
        assert res.returncode == 0, res.stderr
        assert "6 runs computed" in res.stdout
        remote = open_result(tmp_path / "remote.nc")
        workers = {json.loads(p.read_text())["worker"] for p in (tmp_path / ".ledger" / "small").glob("*.json")}
        assert len(workers) == 2  # both worker processes ran cases
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=30)
    local = run_study(load_study(study), tmp_path / "local.nc", workers=0, quiet=True, ledger_dir=tmp_path / "l2")
    same_results(remote, local.dataset)


def test_sigkill_midway_then_resume_recomputes_nothing_finished(tmp_path):
    axes = MU_ALPHA.replace("values = [0.0, 0.5]", "values = [0.0, 0.25, 0.5, 0.75]").replace(
        "step = 0.25", "step = 0.125"
    )  # 4 x 5 = 20 runs
    study = write_study(tmp_path, axes)
    ledger = tmp_path / ".ledger" / "small"
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(study), "-o", str(tmp_path / "k.nc"),
                             "--workers", "1", "--no-plot"], cwd=ROOT, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    deadline = time.time() + 240
    while time.time() < deadline and len(list(ledger.glob("*.json"))) < 3 and proc.poll() is None:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in ledger.glob("*.json")}
    assert 3 <= len(before) < 20, "the kill must land midway"
    assert not (tmp_path / "k.nc").exists()
    res = cli("run", str(study), "-o", str(tmp_path / "k.nc"), "--workers", "1", "--no-plot")
    assert res.returncode == 0, res.stderr
    assert f"{20 - len(before)} runs computed, {len(before)} taken from the ledger" in res.stdout
    for name, (mtime, data) in before.items():
        assert ((ledger / name).stat().st_mtime_ns, (ledger / name).read_bytes()) == (mtime, data)
    resumed = open_result(tmp_path / "k.nc")
    clean = run_study(load_study(study), tmp_path / "clean.nc", workers=0, quiet=True, ledger_dir=tmp_path / "l2")
    same_results(resumed, clean.dataset)


def test_killed_worker_is_replaced_and_the_study_completes(tmp_path):
    study = load_study(write_study(tmp_path, MU_ALPHA))
    with dask_client(workers=2) as client:
        client.wait_for_workers(2)
        killed = []

        def kill_one(case, record):
            if not killed:  # SIGKILL a worker while the other runs are in flight
                pid = next(iter(client.run(os.getpid).values()))
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)

        out = run_study(study, tmp_path / "w.nc", client=client, quiet=True, on_record=kill_one)
        assert killed
        assert out.computed == 6 and out.failed == 0
        assert (out.dataset["status"].values == 0).all()
        client.wait_for_workers(2, timeout=60)  # the nanny started a new worker
        assert killed[0] not in client.run(os.getpid).values()


def crash_at_high_alpha(scene_dict, run_id, impacts_kept):
    """A run that kills its worker process (alpha = 1), for the worker-death test."""
    if scene_dict["contact"]["alpha"] == 1.0:
        os._exit(1)
    return run_case(scene_dict, run_id, impacts_kept)


def test_a_run_that_keeps_killing_workers_ends_as_a_recorded_failure(tmp_path):
    study = load_study(write_study(tmp_path, MU_ALPHA.replace("values = [0.0, 0.5]", "values = [0.0]")))
    out = run_study(study, tmp_path / "c.nc", workers=2, quiet=True, runner=crash_at_high_alpha)
    ds = out.dataset
    assert ds["status"].sel(alpha=1.0).item() == -1
    assert "KilledWorker" in str(ds["message"].sel(alpha=1.0).item())
    assert (ds["status"].sel(alpha=[0.5, 0.75]).values == 0).all()


#: Study files whose smoke run takes a minute (pad_preload_map: 25 cells x 2 realisations, each a steady flight).
SLOW_SMOKE = {"pad_preload_map.toml"}


@pytest.mark.parametrize(
    "path",
    [
        pytest.param(p, marks=pytest.mark.slow) if p.name in SLOW_SMOKE else p
        for p in sorted((ROOT / "studies").glob("*.toml"))
    ],
    ids=lambda p: p.name,
)
def test_every_study_file_smoke_runs_on_a_tiny_grid(tmp_path, path):
    tiny = ["numerics.nx=21", "numerics.nx_taper=5", "numerics.ny=5", "numerics.t_end=2e-5"]
    full = load_study(path)
    if full.base.get("kind") == "abs":  # scene 2: a coarse face, 10-us runs, 2 realisations per cell
        # (refine 3: the micro pad of chen_bogy2007_mtp, 20 um long, needs 3 nodes along x)
        assert "realization" in full.dims and full.axis("realization").values[0] == 1
        tiny = ["numerics.nx=61", "numerics.ny=41", "numerics.refine=3", "numerics.t_end=1e-5",
                "numerics.settle_time=5e-6", "numerics.dt=0.5e-6", "numerics.output_interval=1e-6"]  # fmt: skip
        if "numerics.dt" in {a.key for a in full.axes}:  # statistics.toml: its time steps, samples every 0.8 us
            tiny = tiny[:5]
        study = load_study(path, tiny, realizations=2)
        # each axis's first and last values (its corners; the values between run the same code), two realisations
        corners = tuple(
            a
            if a.dim == "realization" or len(a.values) <= 2
            else dataclasses.replace(a, values=a.values[:: len(a.values) - 1])
            for a in study.axes
        )
        study = dataclasses.replace(study, axes=corners)
        out = run_study(study, tmp_path / f"{study.name}.nc", workers=0, quiet=True)
        # realisations on a smooth disk (rms = 0) are one run
        assert out.computed == len({c.run_id for c in study.cases()}) and out.computed + out.reused == study.size
        assert out.failed == 0
        ds = open_result(tmp_path / f"{study.name}.nc")
        assert cf_errors(tmp_path / f"{study.name}.nc") == []
        assert set(ds["bouncing_3sigma"].dims) == set(study.dims) and (ds["status"].values == 0).all()
        assert np.isfinite(ds["bouncing_3sigma"].values).all() and (ds["mean_contact_force"].values >= 0).all()
        assert ds["flying_height"].dims[-1] == "time"
        np.testing.assert_allclose(ds["regime_fraction"].sum("regimes").values, 1.0, rtol=1e-12)
        # each run's flying-height, pitch and roll spectra are kept, and their peaks are the run's peak outputs
        for name, peak in (("flying_height", "fh"), ("pitch", "pitch"), ("roll", "roll")):
            amp = ds[f"{name}_spectrum"].transpose(*study.dims, "frequency").values
            found = ds["frequency"].values[1:][np.argmax(amp[..., 1:], axis=-1)]
            np.testing.assert_array_equal(found, ds[f"{peak}_peak_frequency"].transpose(*study.dims).values)
        from pipeline.figures.common import save_figure
        from pipeline.kinds import plot_dataset

        fig = plot_dataset(ds)
        first = ds[study.dims[0]]
        if first.dtype.kind in "OUS":  # a named axis (a model law): its names on the ticks of both panels
            for ax in fig.axes[:2]:
                assert [t.get_text() for t in ax.get_xticklabels()] == [str(v).replace("_", " ") for v in first.values]
        assert save_figure(fig, tmp_path / f"{study.name}.png").stat().st_size > 10_000
        return
    axes = load_study(path).axes
    grid_axes = {a.key for a in axes} & {"numerics.nx", "numerics.ny"}
    if grid_axes:  # a study over the grid itself (convergence.toml) keeps its grids, and only shortens the runs
        tiny = ["numerics.t_end=2e-5"]
    study = load_study(path, tiny)
    out = run_study(study, tmp_path / f"{study.name}.nc", workers=0, quiet=True)
    assert out.computed == study.size and out.failed == 0
    ds = open_result(tmp_path / f"{study.name}.nc")
    assert set(ds["stable"].dims) == set(study.dims) and (ds["status"].values >= 0).all()


def _dt_study(folder: Path, values: str) -> Path:
    """A scene-2 study that pins an output interval of 0.5 us (not a whole multiple of the scene's 0.2 us) and has a
    dt axis."""
    path = folder / "dt_axis.toml"
    scene2 = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"
    path.write_text(f'[study]\nname = "dt_axis"\ntitle = "dt axis"\nscene = "{scene2}"\nrealizations = 1\n\n[set]\n'
                    f'numerics.output_interval = 0.5e-6\n\n[[axes]]\nkey = "numerics.dt"\ndim = "dt"\n'
                    f"values = {values}\n")  # fmt: skip
    return path


def test_a_base_valid_only_at_its_dt_axis_values_is_a_study(tmp_path):
    """The pinned output interval of a study made at another default holds at every dt of its axis, not at the
    scene's own dt: the study loads, each case has the axis's dt and the pinned interval."""
    study = load_study(_dt_study(tmp_path, "[0.1e-6, 0.05e-6]"))
    dts = [case.scene.numerics.dt for case in study.cases()]
    assert dts == [0.1e-6, 0.05e-6]
    assert {case.scene.numerics.output_interval for case in study.cases()} == {0.5e-6}


def test_a_base_valid_at_no_axis_value_names_the_scene_error(tmp_path):
    """0.5 us is no whole multiple of 0.3 us either: the base's own error, naming the key and the rule."""
    with pytest.raises(ParameterError) as err:
        load_study(_dt_study(tmp_path, "[0.3e-6]"))
    assert "numerics.output_interval = 5e-07 is not allowed with numerics.dt = 2e-07" in str(err.value)
