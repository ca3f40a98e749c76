"""The benchmark's arithmetic (observed orders, cost at equal error) and one real quick run end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import cf_errors

from pipeline.bench.rails import cost_at_error, observed_orders
from pipeline.cli import main
from pipeline.data.netcdf import open_result


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
