"""Realisations of a stochastic input: a study's ``realization`` axis over the kind's seed, each cell's mean with
its 95 % confidence interval (Student's t), the query's mean +- half-width and the figure's error bars."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import cf_errors
from scipy import stats

from pipeline.config import ConfigError
from pipeline.data.netcdf import open_result
from pipeline.data.query import table
from pipeline.data.studyset import realization_statistics
from pipeline.figures.common import save_figure
from pipeline.kinds import plot_dataset
from pipeline.run.fanout import run_study
from pipeline.study.spec import load_study

ROOT = Path(__file__).resolve().parents[1]
#: Scene 2 on a coarse face, 10-us runs with a rough track (0.6 nm RMS, so that the seeds differ visibly).
TINY_ABS = ["numerics.nx=61", "numerics.ny=41", "numerics.refine=2", "numerics.t_end=1e-5",
            "numerics.settle_time=2e-6", "numerics.dt=0.5e-6", "numerics.output_interval=1e-6",
            "disk.rms=0.6e-9", "contact.delta_gamma=0.0"]  # fmt: skip


def write(folder: Path, kind_scene: str, realizations: int, axis: str, head: str = "") -> Path:
    path = folder / "real.toml"
    path.write_text(f'[study]\nname = "real"\nscene = "{kind_scene}"\nrealizations = {realizations}\n{head}\n{axis}\n')
    return path


PAD_AXIS = '[[axes]]\nkey = "slider.trailing_pad_width"\ndim = "pad_width"\nvalues = [100.0e-6, 120.0e-6]\n'


def test_the_interval_is_students_t_over_the_finite_samples():
    import xarray as xr

    rng = np.random.default_rng(3)
    values = rng.normal(2.0, 0.3, size=(2, 5))
    values[1, 4] = np.nan  # a failed realisation: four samples left in that cell
    ds = xr.Dataset({"x": (("cell", "realization"), values, {"units": "m", "long_name": "x"})})
    out = realization_statistics(ds, ["x"])
    for cell in range(2):
        sample = values[cell][np.isfinite(values[cell])]
        low, high = stats.t.interval(0.95, sample.size - 1, loc=sample.mean(), scale=stats.sem(sample))
        assert float(out["x_mean"][cell]) == pytest.approx(sample.mean(), rel=1e-14, abs=0)
        assert float(out["x_ci95"][cell]) == pytest.approx(0.5 * (high - low), rel=1e-12, abs=0)
    assert out["x_ci95"].attrs["units"] == "m" and "95 %" in out["x_ci95"].attrs["long_name"]


def test_a_deterministic_kind_refuses_realizations(tmp_path):
    path = write(tmp_path, str(ROOT / "studies/scenes/benson1989.toml"), 3, '[[axes]]\nkey = "contact.mu"\n'
                 'dim = "mu"\nvalues = [0.0, 0.5]\n')  # fmt: skip
    with pytest.raises(ConfigError, match="deterministic"):
        load_study(path)
    with pytest.raises(ConfigError, match="realizations"):
        load_study(write(tmp_path, str(ROOT / "studies/scenes/chen_bogy2007.toml"), 0, PAD_AXIS))


def test_a_study_with_realizations_gives_means_intervals_query_and_error_bars(tmp_path):
    study = load_study(write(tmp_path, str(ROOT / "studies/scenes/chen_bogy2007.toml"), 3, PAD_AXIS), TINY_ABS)
    assert study.dims == ("pad_width", "realization") and study.axis("realization").values == (1, 2, 3)
    out = run_study(study, tmp_path / "real.nc", workers=0, quiet=True)
    assert out.computed == 6 and out.failed == 0
    ds = open_result(tmp_path / "real.nc")
    assert ds["realization"].attrs["scene_key"] == "disk.seed"
    sigma = ds["bouncing_3sigma"].values
    assert np.ptp(sigma, axis=1).min() > 0.0, "the seeds should give different tracks"
    # the work counters: every step is one substep or more, each advances the film, damped ones are substeps
    steps, substeps = ds["steps"].values, ds["substeps"].values
    assert (steps > 0).all() and (substeps >= steps).all() and (ds["reynolds_solves"].values >= substeps).all()
    assert ((ds["contact_damped"].values >= 0) & (ds["contact_damped"].values <= substeps)).all()
    for k in range(2):
        low, high = stats.t.interval(0.95, 2, loc=sigma[k].mean(), scale=stats.sem(sigma[k]))
        assert float(ds["bouncing_3sigma_mean"][k]) == pytest.approx(sigma[k].mean(), rel=1e-14, abs=0)
        assert float(ds["bouncing_3sigma_ci95"][k]) == pytest.approx(0.5 * (high - low), rel=1e-12, abs=0)
    text = table(ds, [], ["bouncing_3sigma", "mean_contact_force"])
    header, columns, index, *rows = text.splitlines()
    assert "over 3 realisations" in header and len(rows) == 2 and all(row.count(" +- ") == 2 for row in rows)
    # display units: nanometres, millinewtons, the pad width in micrometres
    assert "bouncing_3sigma [nm]" in columns and "mean_contact_force [mN]" in columns and "pad_width [um]" in index
    width, sigma_nm, _, sigma_half = rows[0].split()[:4]
    assert float(width) == pytest.approx(float(ds["pad_width"][0]) * 1e6, rel=1e-3)
    assert float(sigma_nm) == pytest.approx(float(ds["bouncing_3sigma_mean"][0]) * 1e9, rel=1e-3)
    assert float(sigma_half) == pytest.approx(float(ds["bouncing_3sigma_ci95"][0]) * 1e9, rel=1e-1)
    png = save_figure(plot_dataset(ds), tmp_path / "real.png")
    assert png.stat().st_size > 10_000
    # the force axis draws the cells' means in the unit its label names: uN for forces all below 0.1 mN
    for factor, unit, scale in ((1e-9, "uN", 1e6), (1e9, "mN", 1e3)):
        forces = ds["mean_contact_force_mean"] * 0.0 + factor * (1.0 + ds["pad_width"])
        scaled = ds.assign(mean_contact_force_mean=forces)
        axis = plot_dataset(scaled).axes[1]
        assert f"[{unit}]" in axis.get_ylabel()
        drawn = np.concatenate([bars.lines[0].get_ydata() for bars in axis.containers])  # the points, not the caps
        want = scaled["mean_contact_force_mean"].values * scale
        assert np.allclose(np.sort(drawn[np.isfinite(drawn)]), np.sort(want), rtol=1e-12, atol=0)


def test_a_value_label_goes_to_the_side_away_from_the_other_lines():
    """The top line at an x labels above its point, the bottom one below, a middle one by its parity; a lone line
    (or one whose neighbours are nan there) above."""
    from pipeline.figures.abs import _label_offset

    column = np.array([0.50, 0.55, 0.40])
    above, below = (4, 4), (4, -11)
    assert _label_offset(column, 1) == above and _label_offset(column, 2) == below
    assert _label_offset(column, 0) == above  # in the middle, even
    assert _label_offset(np.array([0.5, 0.6, 0.4, 0.45]), 3) == below  # in the middle, odd
    assert _label_offset(np.array([0.5]), 0) == above and _label_offset(np.array([0.5, np.nan]), 0) == above


def test_the_initial_kick_is_a_seeded_normal_draw_of_its_own():
    """initial.zdot_spread: zdot + spread N(0, 1) per seed, reproducible, sample moments within their 99.9 % bounds
    over 4000 seeds; no spread gives zdot exactly."""
    from solver.abs.params import AbsInitial

    zdot, spread, n = -1.0e-3, 2.0e-4, 4000
    init = AbsInitial(zdot=zdot, pitch_rate=3.0, roll_rate=-2.0, zdot_spread=spread)
    v = np.array([init.velocities(seed) for seed in range(n)])
    assert np.array_equal(v[:, 1:], np.tile([3.0, -2.0], (n, 1)))
    assert np.array_equal(v[17], init.velocities(17)) and np.unique(v[:, 0]).size == n
    z = (v[:, 0] - zdot) / spread
    assert abs(z.mean()) <= stats.norm.ppf(0.9995) / np.sqrt(n)
    low, high = stats.chi2.ppf([0.0005, 0.9995], n - 1) / (n - 1)
    assert low <= z.var(ddof=1) <= high
    assert np.array_equal(AbsInitial(zdot=zdot).velocities(5), [zdot, 0.0, 0.0])


def test_a_smooth_disk_cell_is_one_run_unless_its_initial_state_is_sampled(tmp_path):
    """A smooth disk ignores the seed: its realisations share one run and a zero interval.  With
    initial.zdot_spread each realisation is a run of its own, the flights differ and the interval is not 0."""
    path = write(tmp_path, str(ROOT / "studies/scenes/chen_bogy2007.toml"), 3, PAD_AXIS)
    smooth = [*TINY_ABS, "disk.rms=0.0"]
    out = run_study(load_study(path, smooth), tmp_path / "one.nc", workers=0, quiet=True)
    assert out.computed == 2 and out.failed == 0
    ds = open_result(tmp_path / "one.nc")
    assert np.all(np.ptp(ds["mean_flying_height"].values, axis=1) == 0.0)
    assert np.all(ds["mean_flying_height_ci95"].values == 0.0)
    out = run_study(load_study(path, [*smooth, "initial.zdot_spread=2e-3"]), tmp_path / "kick.nc", workers=0,
                    quiet=True)  # fmt: skip
    assert out.computed == 6 and out.failed == 0
    ds = open_result(tmp_path / "kick.nc")
    assert np.ptp(ds["mean_flying_height"].values, axis=1).min() > 0.0
    assert np.all(ds["mean_flying_height_ci95"].values > 0.0)


# ----------------------------------------------------------------------------- scene-2 boundary: one line per track

PAD_PRELOAD_BOUNDARY = (
    '[[axes]]\nkey = "slider.trailing_pad_width"\ndim = "pad_width"\n'
    "start = 60.0e-6\nstop = 140.0e-6\nstep = 5.0e-6\n\n"
    '[[axes]]\nkey = "suspension.preload"\ndim = "preload"\nvalues = [1.0e-3, 10.0e-3, 20.0e-3]\n\n'
    '[boundary]\naxis = "slider.trailing_pad_width"\ntolerance = 5.0e-6\nstable_side = "above"\n'
)


def touchdown_width(preload: float, seed: int) -> float:
    """The stand-in's rule: the pad flies from this width up, narrower it touches [m]."""
    return 70e-6 + 3e-3 * preload + 2.5e-6 * seed


def regime_runner(scene_dict, run_id, impacts_kept):
    """A stand-in scene-2 run: flying (0) above the touchdown width, intermittent contact (1) within 20 um below
    it, stuck (3) further down; the flag is all the boundary reads."""
    width = scene_dict["slider"]["trailing_pad_width"]
    edge = touchdown_width(scene_dict["suspension"]["preload"], scene_dict["disk"]["seed"])
    regime = 0 if width >= edge - 1e-12 else (1 if width > edge - 20e-6 else 3)
    return {"run_id": run_id, "status": 0, "regime": regime, "bouncing_3sigma": 1e-9 * (1 + regime),
            "contact_fraction": 0.0 if regime == 0 else 0.1, "message": "threshold", "wall_time": 0.0}  # fmt: skip


def test_a_scene2_boundary_is_bisected_per_track_with_the_mean_and_interval_of_the_tracks(tmp_path):
    path = write(tmp_path, str(ROOT / "studies/scenes/chen_bogy2007.toml"), 4, PAD_PRELOAD_BOUNDARY,
                 'figure = "regime_map"')  # fmt: skip
    grid = load_study(path)
    assert grid.boundary.threshold == "intermittent_contact"  # the kind's default: flying against touching
    g = run_study(grid, tmp_path / "g.nc", workers=0, quiet=True, runner=regime_runner, ledger_dir=tmp_path / "lg")
    b = run_study(load_study(path, mode="boundary"), tmp_path / "b.nc", workers=0, quiet=True, runner=regime_runner,
                  ledger_dir=tmp_path / "lb")  # fmt: skip
    gd, bd = g.dataset, open_result(tmp_path / "b.nc")
    assert gd.attrs["study"] == bd.attrs["study"] == "real"
    assert gd["boundary_lower"].dims == ("preload", "realization") and bd.attrs["boundary_method"] == "bisection"
    widths = bd["pad_width"].values
    assert len(widths) == 17 and g.computed == 17 * 3 * 4  # the grid holds the whole lattice
    for p, preload in enumerate(bd["preload"].values):
        for r, seed in enumerate(bd["realization"].values):
            edge = touchdown_width(preload, seed)
            upper = widths[widths >= edge - 1e-12].min()  # the narrowest lattice width that flies
            assert float(bd["boundary_upper"][p, r]) == pytest.approx(upper, rel=1e-12)
            assert float(bd["boundary_lower"][p, r]) == pytest.approx(upper - 5e-6, rel=1e-12)
    np.testing.assert_array_equal(gd["boundary_lower"].values, bd["boundary_lower"].values)
    np.testing.assert_array_equal(gd["boundary_upper"].values, bd["boundary_upper"].values)
    mids = 0.5 * (bd["boundary_lower"] + bd["boundary_upper"]).values
    for p in range(3):
        low, high = stats.t.interval(0.95, 3, loc=mids[p].mean(), scale=stats.sem(mids[p]))
        assert float(bd["boundary_mean"][p]) == pytest.approx(mids[p].mean(), rel=1e-14)
        assert float(bd["boundary_ci95"][p]) == pytest.approx(0.5 * (high - low), rel=1e-12)
    assert bd["boundary_closed"].values.tolist() == [4, 4, 4]
    assert "flying" in bd["boundary_upper"].attrs["long_name"] and bd.attrs["boundary_threshold"] == (
        "intermittent_contact")  # fmt: skip
    assert b.computed < g.computed / 2, (b.computed, g.computed)
    assert cf_errors(tmp_path / "g.nc") == [] and cf_errors(tmp_path / "b.nc") == []
    png = save_figure(plot_dataset(gd, bd), tmp_path / "map.png")
    import matplotlib.image

    image = matplotlib.image.imread(png)
    assert np.unique(image.reshape(-1, image.shape[-1]), axis=0).shape[0] > 10
    assert save_figure(plot_dataset(bd), tmp_path / "b.png").stat().st_size > 10_000
    with pytest.raises(ValueError, match="draws no overlay"):  # the sweep figure of a study without a map
        plot_dataset(open_result(tmp_path / "g.nc").assign_attrs(figure=""), bd)


def test_a_scene2_boundary_at_the_stuck_threshold_and_an_open_bracket(tmp_path):
    text = PAD_PRELOAD_BOUNDARY.replace('stable_side = "above"\n', 'stable_side = "above"\nthreshold = "stuck"\n')
    path = write(tmp_path, str(ROOT / "studies/scenes/chen_bogy2007.toml"), 2, text)
    b = run_study(load_study(path, mode="boundary"), tmp_path / "b.nc", workers=0, quiet=True, runner=regime_runner)
    ds = b.dataset
    assert ds.attrs["boundary_classes"] == "below stuck (low) / stuck (high)"
    # stuck from 20 um below the touchdown width: at 1 mN (touchdown 75.5 / 78 um) it never sticks on 60-140 um
    assert np.isnan(ds["boundary_lower"].values[0]).all() and ds["boundary_upper"].values[0].tolist() == [60e-6] * 2
    assert int(ds["boundary_closed"][0]) == 0 and np.isnan(float(ds["boundary_mean"][0]))
    assert int(ds["boundary_closed"][2]) == 2 and np.isfinite(float(ds["boundary_mean"][2]))


@pytest.mark.parametrize(("line", "error"), [
    ('threshold = "flying"', "'flying' is not allowed (allowed: intermittent_contact, sustained_contact, stuck"),
    ('threshold = "touching"', "'touching' is not allowed"),
])  # fmt: skip
def test_a_scene2_boundary_threshold_must_be_a_regime_that_starts_the_high_class(tmp_path, line, error):
    text = PAD_PRELOAD_BOUNDARY.replace('stable_side = "above"\n', f'stable_side = "above"\n{line}\n')
    with pytest.raises(ConfigError, match=error.replace("(", r"\(")):
        load_study(write(tmp_path, str(ROOT / "studies/scenes/chen_bogy2007.toml"), 2, text))


def test_a_two_valued_class_takes_no_threshold(tmp_path):
    axes = ('[[axes]]\nkey = "contact.alpha"\ndim = "alpha"\nvalues = [0.5, 1.0]\n\n[boundary]\naxis = '
            '"contact.alpha"\ntolerance = 0.1\nthreshold = "stable"\n')  # fmt: skip
    with pytest.raises(ConfigError, match=r"\[boundary\] threshold.*two values"):
        load_study(write(tmp_path, str(ROOT / "studies/scenes/benson1989.toml"), 1, axes))


def test_the_traced_classes_of_both_kinds():
    from pipeline.kinds import adapter_of

    regime = adapter_of("abs").traced
    flags = np.array([-1, 0, 1, 2, 3])
    assert regime.classes(flags).tolist() == [-1, 1, 0, 0, 0]
    assert regime.classes(flags, "sustained_contact").tolist() == [-1, 1, 1, 0, 0]
    assert regime.classes(flags, "stuck").tolist() == [-1, 1, 1, 1, 0]
    assert regime.names() == ("flying", "intermittent_contact or above")
    stable = adapter_of("rails").traced
    assert stable.classes(np.array([-1, 0, 1])).tolist() == [-1, 0, 1] and stable.names() == ("stable", "unstable")
