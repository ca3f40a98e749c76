"""bench/scene2_findings.py: the verdict rules of the source's five scene-2 findings (README, "The five findings"),
on study files written here with known per-track values, so that every rule's outcome is fixed by construction."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from pipeline.classify import REGIME_FLAGS, REGIMES

pytestmark = pytest.mark.jitless

ROOT = Path(__file__).resolve().parents[1]
GF = 9.80665e-3
TRACKS = 4
NOISE = np.array([-1.0, 0.5, 1.5, -1.0]) * 1e-2  # per-track wiggle of a paired change (sums to 0)


def load_bench():
    spec = importlib.util.spec_from_file_location("scene2_findings", ROOT / "bench" / "scene2_findings.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


def study(name: str, axes: dict[str, list[float]], sigma_nm, force_un, regime=None) -> xr.Dataset:
    """A study file's variables: sigma_nm(cell) and force_un(cell) give each cell's values per track (arrays)."""
    dims = [*axes, "realization"]
    shape = [len(v) for v in axes.values()] + [TRACKS]
    s3, fc = np.empty(shape), np.empty(shape)
    flags = np.full(shape, REGIMES.index("intermittent_contact"), dtype=np.int8)
    for index in np.ndindex(*shape[:-1]):
        cell = {k: v[i] for (k, v), i in zip(axes.items(), index, strict=True)}
        s3[index] = sigma_nm(cell) * 1e-9
        fc[index] = force_un(cell) * 1e-6
        if regime is not None:
            flags[index] = regime(cell)
    coords = {**axes, "realization": np.arange(1, TRACKS + 1)}
    ds = xr.Dataset({"bouncing_3sigma": (dims, s3), "mean_contact_force": (dims, fc),
                     "regime": (dims, flags, dict(REGIME_FLAGS))}, coords=coords, attrs={"study": name})  # fmt: skip
    return ds


def write_design(folder: Path, *, adhesion_sigma: float, stuck_at_high: bool, pad_force: float,
                 preload_force: float) -> str:  # fmt: skip
    """The four study files of one design; the arguments set findings 1, 4 and 5, the rest agree."""
    base = 1.5 + NOISE  # the default cell's 3-sigma per track [nm]

    def ra_sigma(c):
        if c["rms"] == 0.0:
            return np.full(TRACKS, 1e-5)
        high = c["delta_gamma"] > 0.01  # the strong adhesion adds adhesion_sigma with a wiggle of its own
        return base * (c["rms"] / 0.2e-9) ** 0.5 + (adhesion_sigma + np.roll(NOISE, 1) if high else 0.0)

    def ra_regime(c):
        stuck = stuck_at_high and c["delta_gamma"] > 0.01 and c["rms"] > 0.0
        return REGIMES.index("stuck" if stuck else "sustained_contact")

    files = {
        "roughness_adhesion": study("roughness_adhesion", {"rms": [0.0, 0.2e-9, 0.6e-9], "delta_gamma": [0.008, 0.08]},
                                    ra_sigma, lambda c: 1.0 + 1e3 * (c["delta_gamma"] > 0.01) + NOISE, ra_regime),
        "friction": study("friction", {"mu": [0.0, 0.3, 0.6], "delta_gamma": [0.008, 0.08]},
                          lambda c: base + 0.01 * c["mu"], lambda c: 1.0 + NOISE),
        "pad_width": study("pad_width", {"pad_width": [80e-6, 100e-6, 120e-6]},
                           lambda c: base - 2e3 * (120e-6 - c["pad_width"]),
                           lambda c: 10.0 + pad_force * (c["pad_width"] < 100e-6) + NOISE),
        "preload": study("preload", {"preload": [0.1 * GF, 0.8 * GF, 1.6 * GF]},
                         lambda c: base - 0.2 * c["preload"] / GF,
                         lambda c: preload_force * c["preload"] / (1.6 * GF) + NOISE),
    }  # fmt: skip
    for name, ds in files.items():
        ds.to_netcdf(folder / f"d_{name}.nc")
    return str(folder / "d_")


def verdicts(bench, prefix: str) -> dict[str, str]:
    return {row[0].split(".")[0]: row[3] for row in bench.findings(prefix) if row[0]}


def test_the_findings_follow_their_rules(tmp_path):
    bench = load_bench()
    # findings 1, 4, 5 agree: bouncing up with adhesion and no track stuck; the narrow pad touches less; the
    # preload adds 100 uN of contact force (below 10 % of 1.5 gf, 1 471 uN) while the bouncing falls
    agree = verdicts(bench, write_design(tmp_path, adhesion_sigma=0.3, stuck_at_high=False, pad_force=-5.0,
                                         preload_force=100.0))  # fmt: skip
    assert agree["1"] == "agree" and agree["2"].startswith("agree") and agree["3"].startswith("agree")
    assert agree["4"] == "agree" and agree["5"] == "agree"
    # the same with one track stuck at dgamma 0.08, a narrow pad that touches more, and a preload that adds
    # 2 mN of contact force: 1 and 4 disagree; 5 is not significant (its bouncing falls, its force rises too much)
    other = tmp_path / "other"
    other.mkdir()
    bad = verdicts(bench, write_design(other, adhesion_sigma=0.3, stuck_at_high=True, pad_force=+5.0,
                                       preload_force=2000.0))  # fmt: skip
    assert bad["1"] == f"disagree ({TRACKS} of {TRACKS} tracks stuck)" and bad["4"] == "disagree"
    assert bad["5"] == "not significant"


def test_a_change_within_the_track_scatter_is_not_significant(tmp_path):
    """A paired change is significant only when its t-interval excludes 0: a 0.005-nm rise with per-track wiggles
    of 0.01 nm is not; the interval is Student's t over the tracks."""
    bench = load_bench()
    change = 0.005 + NOISE
    mean, half = bench.interval(change)
    low, high = stats.t.interval(0.95, TRACKS - 1, loc=change.mean(), scale=stats.sem(change))
    assert mean == pytest.approx(change.mean(), abs=1e-15) and half == pytest.approx(0.5 * (high - low), rel=1e-12)
    assert bench.sign((mean, half)) == 0
    assert bench.sign(bench.interval(0.05 + NOISE)) == 1 and bench.sign(bench.interval(-0.05 + NOISE)) == -1
    flat = verdicts(bench, write_design(tmp_path, adhesion_sigma=0.005, stuck_at_high=False, pad_force=-5.0,
                                        preload_force=100.0))  # fmt: skip
    assert flat["1"] == "not significant"


def test_a_cell_missing_from_the_sweep_is_an_error_naming_it(tmp_path):
    bench = load_bench()
    prefix = write_design(tmp_path, adhesion_sigma=0.3, stuck_at_high=False, pad_force=-5.0, preload_force=100.0)
    study("pad_width", {"pad_width": [90e-6, 120e-6]}, lambda c: np.ones(TRACKS),
          lambda c: np.ones(TRACKS)).to_netcdf(tmp_path / "d_pad_width.nc")  # fmt: skip
    with pytest.raises(SystemExit, match=r"pad_width = 8e-05 is not on its axis \(9e-05, 0\.00012\)"):
        bench.findings(prefix)
