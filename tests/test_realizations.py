"""Realisations of a stochastic input: a study's ``realization`` axis over the kind's seed, each cell's mean with
its 95 % confidence interval (Student's t), the query's mean +- half-width and the figure's error bars."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
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


def write(folder: Path, kind_scene: str, realizations: int, axis: str) -> Path:
    path = folder / "real.toml"
    path.write_text(f'[study]\nname = "real"\nscene = "{kind_scene}"\nrealizations = {realizations}\n\n{axis}\n')
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
    for k in range(2):
        low, high = stats.t.interval(0.95, 2, loc=sigma[k].mean(), scale=stats.sem(sigma[k]))
        assert float(ds["bouncing_3sigma_mean"][k]) == pytest.approx(sigma[k].mean(), rel=1e-14, abs=0)
        assert float(ds["bouncing_3sigma_ci95"][k]) == pytest.approx(0.5 * (high - low), rel=1e-12, abs=0)
    text = table(ds, [], ["bouncing_3sigma", "mean_contact_force"])
    header, _columns, _index, *rows = text.splitlines()
    assert "over 3 realisations" in header and len(rows) == 2 and all(row.count(" +- ") == 2 for row in rows)
    png = save_figure(plot_dataset(ds), tmp_path / "real.png")
    assert png.stat().st_size > 10_000
