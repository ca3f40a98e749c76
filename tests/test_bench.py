"""The benchmark's arithmetic (observed orders, cost at equal error) and one real quick run end to end."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SCENE2_FILE, cf_errors

from pipeline.bench.rails import cost_at_error, observed_orders
from pipeline.cli import main
from pipeline.data.netcdf import open_result

RESULTS_DIR = Path(__file__).resolve().parents[1] / "results"


@pytest.mark.parametrize("order", [1.0, 2.0, 2.7])
def test_observed_orders_recover_a_power_law(order):
    h = [0.4, 0.2, 0.1, 0.05]
    errs = [3.0 * x**order for x in h]
    np.testing.assert_allclose(observed_orders(h, errs), order, rtol=1e-12, atol=0)


def test_observed_order_of_a_zero_error_is_nan():
    assert math.isnan(observed_orders([0.2, 0.1], [1e-3, 0.0])[0])


def test_cost_at_error_interpolates_log_log_and_refuses_to_extrapolate():
    # wall = 1e-3 / err^0.5 along the family: at err = 1e-4 the cost is exactly 0.1 s
    errs = [1e-2, 1e-3, 1e-5]
    walls = [1e-3 / e**0.5 for e in errs]
    assert cost_at_error(walls, errs, 1e-4) == pytest.approx(0.1, rel=1e-12, abs=0)
    assert math.isnan(cost_at_error(walls, errs, 1e-1))
    assert math.isnan(cost_at_error(walls, errs, 1e-6))


def test_quick_bench_writes_its_table_and_figure(tmp_path, monkeypatch):
    monkeypatch.setenv("HDI_CACHE_DIR", str(tmp_path / "cache"))
    out, png = tmp_path / "bench.nc", tmp_path / "wp.png"
    assert main(["bench", "--quick", "--repeats", "1", "-o", str(out), "--figure", str(png)]) == 0
    ds = open_result(out)
    assert cf_errors(out) == []
    families = set(ds["family"].values.tolist())
    assert {"grid, uniform across the rail", "fixed step", "adaptive step", "air-bearing level"} <= families
    # the quick reference is 201x21 clustered at dt 0.1 us: every Reynolds case has a finite, non-zero error,
    # and the clustered grid beats the uniform one at the same node count (101x11)
    rey = ds.where(ds["model"] == "reynolds", drop=True)
    assert np.isfinite(rey["max_impulse_error"]).all() and (rey["max_impulse_error"] > 0).all()
    assert float(ds["max_impulse_error"].sel(case="101x11 c")) < float(ds["max_impulse_error"].sel(case="101x11"))
    assert ds.attrs["recommended_case"] in ds["case"].values
    assert float(ds["baseline_wall_per_step"]) > 0 and ds["impulse_error"].attrs["units"] == "1"
    assert png.stat().st_size > 10_000
    again = tmp_path / "again.png"  # `hdi plot` knows a bench file
    assert main(["plot", str(out), "-o", str(again)]) == 0 and again.stat().st_size > 10_000


# scene 2 ---------------------------------------------------------------------------------------------------------


def test_mean_ci_is_the_student_t_interval():
    """Mean and 95 % CI half-width t_{0.975, n-1} s / sqrt(n): for 1, 2, 3 (s = 1) it is 4.3027 / sqrt(3)."""
    from pipeline.bench.abs import mean_ci

    mean, half = mean_ci(np.array([1.0, 2.0, 3.0]))
    assert mean == 2.0
    assert half == pytest.approx(4.302653 / math.sqrt(3.0), rel=1e-6, abs=0)  # t table, 2 degrees of freedom
    assert math.isnan(mean_ci(np.array([5.0]))[1])


def test_baseline_of_an_unknown_ref_is_skipped_with_its_reason(tmp_path):
    """A ref git cannot check out leaves no timing and says why, instead of failing the bench."""
    from pipeline.bench.abs import Baseline

    baseline = Baseline("no-such-ref-0123456789", str(tmp_path / "scene.toml"), {})
    try:
        baseline.time_one_run()
        assert baseline.walls == []
        assert "skipped" in baseline.describe() and "no-such-ref-0123456789" in baseline.describe()
    finally:
        baseline.close()
    assert Baseline("", "scene.toml", {}).describe() == "skipped: no baseline ref"


@pytest.mark.slow
def test_quick_scene2_bench_writes_its_table_and_figure(tmp_path):
    """The scene-2 bench end to end (0.2-ms runs, 2 tracks), with HEAD as the baseline solver: timings, ratios, CIs."""
    out, png = tmp_path / "bench2.nc", tmp_path / "bench2.png"
    argv = ["bench", "--scene", str(SCENE2_FILE), "--quick", "--repeats", "1", "--baseline-ref", "HEAD"]
    assert main([*argv, "-o", str(out), "--figure", str(png)]) == 0
    ds = open_result(out)
    assert cf_errors(out) == []
    from pipeline.bench.abs import SETTINGS

    assert list(ds["timed"].values) == [name for name, *_ in SETTINGS]
    assert float(ds["baseline_wall_per_step"]) > 0 and np.all(ds["setting_speedup"].values > 0)
    assert "HEAD" in ds.attrs["baseline_solver"]
    assert ds["bouncing_3sigma_by_seed"].shape == (len(SETTINGS) + 1, 2) and np.all(ds["run_status"].values == 0)
    from pipeline.bench.abs import REFERENCE

    assert list(ds["setting"].values)[-1] == REFERENCE[0]
    assert np.all(ds["bouncing_3sigma_ci"].values > 0) and float(ds["mean_flying_height_diff"][-1]) == 0.0
    assert png.stat().st_size > 10_000


def test_every_scene2_setting_loads_with_samples_on_its_own_step():
    """Each bench setting (and the reference) is a valid scene: dt scaled, the output interval a multiple of it."""
    from pipeline.bench.abs import REFERENCE, SETTINGS, STUDIED, setting_overrides
    from pipeline.config import load_scene

    for name, _, overrides, factor in (*SETTINGS, *STUDIED, REFERENCE):
        scene = load_scene(str(SCENE2_FILE), setting_overrides(str(SCENE2_FILE), {}, overrides, factor))
        num = scene.numerics
        assert num.dt == pytest.approx(load_scene(str(SCENE2_FILE)).numerics.dt * factor, rel=1e-12), name
        assert abs(num.output_interval / num.dt - round(num.output_interval / num.dt)) < 1e-9, name
        scene_interval = load_scene(str(SCENE2_FILE)).numerics.output_interval
        assert abs(num.output_interval - scene_interval) <= 0.5 * num.dt, name


def test_scene2_bench_figure_keeps_the_contact_force_panel_above_zero():
    """The stored bench's contact-force intervals reach below zero (a few tracks touch hard): the panel stops at 0,
    the bouncing panel keeps its data's range."""
    from pipeline.figures.bench import plot_scene2_bench

    ds = open_result(RESULTS_DIR / "bench_scene2.nc")
    lower = ds["mean_contact_force_mean"] - ds["mean_contact_force_ci"]
    assert float(lower.min()) < 0.0  # the case the rule is for
    fig = plot_scene2_bench(ds)
    assert fig.axes[2].get_ylim()[0] == 0.0
    assert fig.axes[1].get_ylim()[0] > 0.3  # the 3-sigma panel: zoomed on 0.4-0.7 nm
