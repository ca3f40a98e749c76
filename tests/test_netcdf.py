"""netCDF files: CF-1.8 on disk (IOOS compliance checker), and values that survive the round trip unchanged."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from conftest import cf_errors

from pipeline.data.netcdf import TIME_UNITS, cf_encode, open_result, var, write_netcdf
from pipeline.provenance import base_attrs

RESULTS = Path(__file__).resolve().parents[1] / "results"


def sample_dataset() -> xr.Dataset:
    """Every kind of variable the commands write: int64 counters, booleans, string labels, a time axis."""
    t = np.arange(5) * 2e-7
    ds = xr.Dataset(
        {
            "z": var(np.linspace(1e-7, 2e-7, 5), ("time",), "m", "gimbal height"),
            "corner_spacing": var(np.arange(20.0).reshape(5, 4), ("time", "corner"), "m", "spacing at the corners"),
            "n_impacts": var(np.int64(7), (), "1", "number of impacts"),
            "impact_time": var(np.array([1e-6, 2e-6]), ("impact",), "s", "time of impact"),
            "held": var(np.array([True, False]), ("impact",), "1", "corner held after the impact"),
        },
        coords={
            "time": ("time", t, {"units": "s", "long_name": "time since the disturbance"}),
            "corner": ("corner", np.array(list("ABCD")), {"long_name": "flat corner"}),
            "impact": ("impact", np.arange(2), {"long_name": "impact number"}),
        },
    )
    ds.attrs.update(base_attrs("round trip"))
    return ds


def test_written_file_passes_the_cf_checker_and_reads_back_unchanged(tmp_path):
    ds = sample_dataset()
    path = write_netcdf(ds, tmp_path / "sample.nc")
    assert cf_errors(path) == []
    back = open_result(path)
    for name in ds.variables:
        np.testing.assert_array_equal(back[name].values, ds[name].values, err_msg=str(name))
    assert back["n_impacts"].dtype == np.int32 and back["held"].dtype == np.int8
    assert back.sel(corner="C")["corner_spacing"].values.tolist() == [2.0, 6.0, 10.0, 14.0, 18.0]
    assert back["time"].attrs["standard_name"] == "time" and back["time"].attrs["axis"] == "T"
    assert back["time"].attrs["units"] == TIME_UNITS
    with xr.open_dataset(path, decode_times=False) as raw:  # what another reader sees: labels as an auxiliary
        assert "corner_label" in raw.coords and "corner" not in raw.variables
        assert "_FillValue" not in raw["time"].encoding or raw["time"].encoding["_FillValue"] is None


def test_the_encoding_refuses_what_cf_cannot_hold():
    ds = sample_dataset()
    ds.attrs["order grid, uniform"] = "1.5, 2.0"
    with pytest.raises(ValueError, match="order grid, uniform"):
        cf_encode(ds)
    ds = sample_dataset()
    ds["big"] = var(np.int64(2**40), (), "1", "too large for int32")
    with pytest.raises(ValueError, match="big"):
        cf_encode(ds)


#: One file of each product (fly, run, study, bench) of each scene kind: the same writers made every other file in
#: results/.  The checker takes 2-20 s a file (its search for coordinate variables is quadratic in their number), so
#: the whole folder (43 files, about 6 minutes) is the slow test below.
CF_SAMPLE = (
    "benson1989_fly.nc",
    "benson1989_mu05_alpha080.nc",
    "fig17.nc",
    "bench_scene1.nc",
    "chen_bogy2007_fly.nc",
    "chen_bogy2007_run.nc",
    "pad_width.nc",
    "bench_scene2.nc",
    "statistics_grid.nc",
    "chen_bogy2007_ladder.nc",
)


@pytest.mark.parametrize("name", CF_SAMPLE)
def test_a_result_file_of_each_product_and_kind_passes_the_cf_checker(name):
    path = RESULTS / name
    assert cf_errors(path) == []
    assert open_result(path).attrs["Conventions"] == "CF-1.8"


def test_the_cf_sample_covers_every_product_of_every_kind():
    def product(path: Path) -> tuple[str | None, str | None]:
        attrs = open_result(path).attrs
        return attrs.get("scene_kind"), attrs.get("product")

    sampled = {product(RESULTS / name) for name in CF_SAMPLE}
    missing = {product(path) for path in RESULTS.glob("*.nc")} - sampled
    assert not missing, f"results/ holds (kind, product) {missing} that CF_SAMPLE has no file of"


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(RESULTS.glob("*.nc")), ids=lambda p: p.name)
def test_every_result_file_passes_the_cf_checker(path):
    assert cf_errors(path) == []
    assert open_result(path).attrs["Conventions"] == "CF-1.8"


def test_git_commit_is_dirty_for_modified_code_not_for_regenerated_results(tmp_path, monkeypatch):
    """A study regenerated after another in the same checkout keeps a clean commit: the outputs in results/ that
    the first rewrote do not count as modified code (they made every later file '+dirty'); a modified source does."""
    import subprocess

    from pipeline import provenance

    def git(*args):
        subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True)

    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "out.nc").write_text("a")
    (tmp_path / "code.py").write_text("a")
    git("init", "-q")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "x")
    monkeypatch.setattr(provenance, "PROJECT_ROOT", tmp_path)
    provenance.git_commit.cache_clear()
    try:
        (tmp_path / "results" / "out.nc").write_text("b")
        clean = provenance.git_commit()
        provenance.git_commit.cache_clear()
        (tmp_path / "code.py").write_text("b")
        dirty = provenance.git_commit()
    finally:
        provenance.git_commit.cache_clear()
    assert len(clean) == 40 and not clean.endswith("+dirty"), clean
    assert dirty == clean + "+dirty", dirty
