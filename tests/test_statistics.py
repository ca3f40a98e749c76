"""Scene-2 statistics over track realisations: the default number of realisations, smooth-disk cells run once,
every cell's grid checked before any run, regime fractions, and the report that intervals shrink as 1/sqrt(n)
and overlap under time-step refinement (:mod:`pipeline.data.sampling`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import cf_errors
from scipy import stats

from pipeline.config import ConfigError
from pipeline.data import sampling
from pipeline.data.netcdf import open_result
from pipeline.data.query import query
from pipeline.figures.common import save_figure
from pipeline.kinds import plot_dataset
from pipeline.run.fanout import run_study
from pipeline.study.spec import DEFAULT_REALIZATIONS, load_study

ROOT = Path(__file__).resolve().parents[1]
SCENE2 = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"
#: Scene 2 on a coarse face, 10-us runs on a 0.6-nm track (the seeds differ visibly), no adhesion.
TINY = ["numerics.nx=61", "numerics.ny=41", "numerics.refine=2", "numerics.t_end=1e-5",
        "numerics.settle_time=2e-6", "disk.rms=0.6e-9", "contact.delta_gamma=0.0"]  # fmt: skip


def write(folder: Path, head: str, axes: str, scene: Path = SCENE2) -> Path:
    path = folder / "s.toml"
    path.write_text(f'[study]\nname = "s"\nscene = "{scene}"\n{head}\n{axes}\n')
    return path


def axis(key: str, values: list) -> str:
    return f'[[axes]]\nkey = "{key}"\nvalues = {values}\n'


# ---- sampling: intervals, fractions, the 1/sqrt(n) fit --------------------------------------------------


def test_nested_half_widths_are_students_t_intervals_of_the_first_n():
    x = np.random.default_rng(5).normal(3.0, 0.7, size=9)
    halves = sampling.nested_half_widths(x)
    assert halves.shape == (8,)
    for n in range(2, 10):
        low, high = stats.t.interval(0.95, n - 1, loc=x[:n].mean(), scale=stats.sem(x[:n]))
        assert halves[n - 2] == pytest.approx(0.5 * (high - low), rel=1e-12, abs=0)


def test_the_log_sd_bias_is_the_mean_log_of_a_chi_variable():
    """b(k) = E[log(s / sigma)] for k degrees of freedom: checked against scipy's chi distribution."""
    for k in (1, 2, 5, 15):
        mean_log = stats.chi(k).expect(np.log) - 0.5 * np.log(k)
        assert sampling.log_sd_bias(k) == pytest.approx(mean_log, abs=1e-9)


def test_the_fitted_slope_of_independent_normal_samples_is_minus_one_half():
    """Over 3000 sets of 16 independent normal samples the mean fitted slope is -1/2 within 3 standard errors
    of that mean; without the log-bias correction it is not (the correction is what makes -1/2 the reference)."""
    x = np.random.default_rng(11).standard_normal((3000, 16))
    halves = sampling.nested_half_widths(x)
    slopes = sampling.standard_error_slope(halves)
    error = slopes.std(ddof=1) / np.sqrt(slopes.size)
    assert abs(slopes.mean() - sampling.INDEPENDENT_SLOPE) < 3.0 * error
    n = np.arange(2, 17)[1:]
    y = np.log(halves[:, 1:] / sampling.t_factor(n))
    centred = np.log(n) - np.log(n).mean()
    raw = (y * centred).sum(axis=1) / (centred**2).sum()
    assert abs(raw.mean() - sampling.INDEPENDENT_SLOPE) > 10.0 * error


def test_samples_that_do_not_shrink_give_a_slope_outside_the_independent_range():
    """The 95 % range of the fit for independent samples contains -1/2 and is reproducible; sets whose later
    realisations all repeat the mean (not independent samples: their spread collapses after the 8th, so the
    standard error falls faster than 1/sqrt(n)) give slopes outside it."""
    rng = np.random.default_rng(2)
    low, high = sampling.independent_slope_range(64)
    assert low < sampling.INDEPENDENT_SLOPE < high
    assert sampling.independent_slope_range(64) == (low, high), "the range is a reproducible number"
    x = rng.standard_normal((200, 64))
    x[:, 8:] = 0.0  # all later realisations equal the mean of zero: the spread collapses, se falls faster
    slopes = sampling.standard_error_slope(sampling.nested_half_widths(x))
    assert np.mean((slopes < low) | (slopes > high)) > 0.9


def test_display_units_follow_the_quantity_and_its_range():
    from pipeline.data.units import display_scale

    assert display_scale("m", [2.1e-9, np.nan]) == (1e9, "nm")  # a flying height
    assert display_scale("m", [60e-6, 140e-6]) == (1e6, "um")  # a pad width
    assert display_scale("N", [7.8e-3]) == (1e3, "mN")
    assert display_scale("Hz", [7.0e5]) == (1e-3, "kHz")
    assert display_scale("rad", [1.3e-4]) == (1e6, "urad")
    assert display_scale("s", [1e-7, 2.5e-8]) == (1e6, "us")  # a time step
    assert display_scale("s", [24.0]) == (1.0, "s") and display_scale("s") == (1.0, "s")  # a wall time
    assert display_scale("J m-2", [0.08]) == (1.0, "J m-2") and display_scale("") == (1.0, "1")


def test_category_fractions_sum_to_one_over_classified_samples():
    flags = np.array([[0, 1, 1, 3], [-1, -1, 2, 2], [-1, -1, -1, -1]])
    fractions, count = sampling.category_fractions(flags, 4)
    np.testing.assert_array_equal(count, [4, 2, 0])
    np.testing.assert_allclose(fractions[0], [0.25, 0.5, 0.0, 0.25], rtol=0, atol=0)
    np.testing.assert_allclose(fractions[1], [0.0, 0.0, 1.0, 0.0], rtol=0, atol=0)
    assert np.isnan(fractions[2]).all()


# ---- study files: default realisations, smooth disks, grid check -------------------------------------------


def test_a_seeded_kind_gets_the_default_realizations_and_one_must_be_explicit(tmp_path):
    pad = axis("slider.trailing_pad_width", [100.0e-6])
    assert load_study(write(tmp_path, "", pad)).axis("realization").values == tuple(range(1, DEFAULT_REALIZATIONS + 1))
    assert "realization" not in load_study(write(tmp_path, "realizations = 1", pad)).dims
    assert load_study(write(tmp_path, "", pad), realizations=3).axis("realization").values == (1, 2, 3)
    with pytest.raises(ConfigError, match="default 8"):
        load_study(write(tmp_path, "realizations = 0", pad))
    rails = write(tmp_path, "", axis("contact.mu", [0.0]), scene=ROOT / "studies" / "scenes" / "benson1989.toml")
    assert load_study(rails).dims == ("mu",), "a deterministic kind has no realisations by default"
    for name in ("pad_width", "preload", "friction", "roughness_adhesion"):  # the Table-I sweeps: the default
        assert len(load_study(ROOT / "studies" / f"{name}.toml").axis("realization").values) == 8
    assert len(load_study(ROOT / "studies" / "pad_preload_map.toml").axis("realization").values) == 4  # its cost


def test_smooth_disk_cells_run_once_and_their_interval_is_zero(tmp_path):
    study = load_study(write(tmp_path, "realizations = 3", axis("disk.rms", [0.0, 0.6e-9])), TINY[:5])
    ids = {c.coords["rms"]: set() for c in study.cases()}
    for case in study.cases():
        ids[case.coords["rms"]].add(case.run_id)
    assert len(ids[0.0]) == 1 and len(ids[0.6e-9]) == 3
    out = run_study(study, tmp_path / "s.nc", workers=0, quiet=True)
    assert out.computed == 4 and out.reused == 2 and out.failed == 0
    ds = out.dataset
    assert float(ds["bouncing_3sigma_ci95"].sel(rms=0.0)) == 0.0
    assert np.ptp(ds["bouncing_3sigma"].sel(rms=0.0).values) == 0.0
    assert float(ds["bouncing_3sigma_ci95"].sel(rms=0.6e-9)) > 0.0


def test_a_cell_whose_grid_misses_the_pad_fails_the_study_before_any_run(tmp_path):
    path = write(tmp_path, "realizations = 2", axis("slider.trailing_pad_width", [100.0e-6, 10.0e-6]))
    with pytest.raises(ConfigError, match=r"cell slider.trailing_pad_width = 1e-05: cannot run: numerics.n[xy]"):
        load_study(path, ["numerics.nx=61", "numerics.ny=41", "numerics.refine=1"])
    with pytest.raises(ConfigError, match="'regime_map' is not a study figure of kind 'rails'"):
        load_study(write(tmp_path, 'figure = "regime_map"', axis("contact.mu", [0.0]),
                         scene=ROOT / "studies" / "scenes" / "benson1989.toml"))  # fmt: skip
    # the statistics figure compares each value of its first axis with the last: a refinement, a number (a string
    # axis ran all its runs, then failed on the report)
    with pytest.raises(ConfigError, match=r"axis 'numerics.film_update' has the values \['none', 'secant'\] "
                       r"\(allowed: numbers\)"):  # fmt: skip
        load_study(write(tmp_path, 'figure = "statistics"', axis("numerics.film_update", ["none", "secant"])))
    assert load_study(write(tmp_path, 'figure = "statistics"', axis("numerics.dt", [0.1e-6, 0.05e-6]))).figure


# ---- the statistics study and the regime map through real dask workers ------------------------------------


def test_statistics_study_on_dask_workers_reports_fractions_intervals_and_refinement(tmp_path):
    study = load_study(ROOT / "studies" / "statistics.toml", TINY, realizations=4)
    assert study.dims == ("dt", "realization") and study.size == 12
    out = run_study(study, tmp_path / "statistics.nc", workers=2, quiet=True)
    assert out.computed == 12 and out.failed == 0
    assert cf_errors(tmp_path / "statistics.nc") == []
    ds = open_result(tmp_path / "statistics.nc")
    fractions = ds["regime_fraction"]
    assert fractions.dims == ("dt", "regimes") and list(ds["regimes"].values) == [
        "flying", "intermittent_contact", "sustained_contact", "stuck"]  # fmt: skip
    np.testing.assert_allclose(fractions.sum("regimes").values, 1.0, rtol=1e-12)
    for k in range(3):  # the fractions are the counts of the per-run flags
        runs = ds["regime"].isel(dt=k).values
        assert fractions.isel(dt=k).values == pytest.approx([np.mean(runs == r) for r in range(4)], abs=1e-15)
    x = ds["bouncing_3sigma"]
    assert float(ds["bouncing_3sigma_paired_difference"].isel(dt=-1)) == 0.0
    assert int(ds["bouncing_3sigma_overlap"].isel(dt=-1)) == 1
    diff = (x.isel(dt=0) - x.isel(dt=-1)).values
    low, high = stats.t.interval(0.95, 3, loc=diff.mean(), scale=stats.sem(diff))
    assert float(ds["bouncing_3sigma_paired_difference_ci95"].isel(dt=0)) == pytest.approx(0.5 * (high - low),
                                                                                           rel=1e-12)  # fmt: skip
    assert ds["bouncing_3sigma_ci95_nested"].isel(dt=1, samples=-1).item() == pytest.approx(
        float(ds["bouncing_3sigma_ci95"].isel(dt=1)), rel=1e-12)  # fmt: skip
    text = query(tmp_path / "statistics.nc", [], ["regime", "bouncing_3sigma"])
    assert "regime (fraction of realisations)" in text and "slope of the standard error" in text
    assert text.count("overlap ") == 4 * 3
    png = save_figure(plot_dataset(ds), tmp_path / "statistics.png")
    assert png.stat().st_size > 20_000
