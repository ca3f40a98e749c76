"""The grid study's figure (bench/statistics_grid.py), drawn again from its stored file."""

from __future__ import annotations

from pathlib import Path

import xarray as xr
from conftest import bench_script

ROOT = Path(__file__).resolve().parents[1]


def _script():
    return bench_script("statistics_grid")


def test_non_negative_panels_stop_at_zero_where_an_interval_reaches_below(tmp_path):
    """The stored file has cells whose contact-force interval reaches below zero (one track in hard contact):
    the figure draws them, and the panels of quantities that cannot be negative end at zero."""
    script = _script()
    with xr.open_dataset(ROOT / "results" / "statistics_grid.nc") as ds:
        ds = ds.load()
    lower = ds["mean_contact_force_mean"] - ds["mean_contact_force_ci95"]
    assert float(lower.min()) < 0.0  # the case the rule is for
    fig = script.figure(ds, tmp_path / "grid.png")
    assert (tmp_path / "grid.png").stat().st_size > 10_000
    names = [m[0] for m in script.MEASURES]
    for name in script.NON_NEGATIVE:
        assert fig.axes[names.index(name)].get_ylim()[0] == 0.0
    # the others keep their data's range (the flying height is far from zero)
    assert fig.axes[names.index("mean_flying_height")].get_ylim()[0] > 1.0
