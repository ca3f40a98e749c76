"""Disk track profiles: synthetic statistics, window statistics, periodic sampling, files.

Sampling errors.  A generated profile is z = IDFT(sqrt(S_m) W_m) with white
noise W, so its periodogram is P_m = S_m E_m with E_m independent
exponential variables (mean 1, variance 1; chi-square with one degree of
freedom, variance 2, at the Nyquist frequency).  Any statistic of the form

    R = sum_m S_m E_m c_m / sum_m S_m E_m

(the circular sample autocorrelation at lag j: c_m = cos(2 pi m j / n); the
variance fraction resolved by a box filter: c_m = |H_m|^2) then has the
delta-method standard error sqrt(sum_m Var(E_m) (S_m (c_m - R))^2) / sum_m S_m
over the independent frequencies (both halves of the spectrum counted).
For the exponential ACF at lag l this is 0.0173 at L = 2000 l, the
continuous Bartlett value sqrt((1 - 3 e^-2) l / L) = 0.0172, and 400
realisations scatter by 0.0178 (Gaussian ACF: 0.0179 and 0.0185).
Statistical checks allow 4 standard errors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.data.profiles import read_profile, write_profile
from solver.disk import (
    ACF_SHAPES,
    DiskProfile,
    disk_surface,
    disk_tables,
    profile_from_arrays,
    synthetic_profile,
    window_samples,
    window_statistics,
)
from solver.kernels.disk import fill_disk_heights, sample_periodic

#: Fast enough to run a second time with the JIT off (HDI_DISABLE_JIT=1, .ci/run).
pytestmark = pytest.mark.jitless

L_CORR = 50e-9  # correlation length [m]
SPACING = L_CORR / 8
LENGTH = 2000 * L_CORR
RMS = 1.5e-9
LAG = 8  # samples per correlation length
N_SIGMA = 4.0


def circular_acf(z: np.ndarray, lag: int) -> float:
    return float(np.mean(z * np.roll(z, lag)) / np.mean(z * z))


def ratio_statistic(acf: str, n: int, spacing: float, weights: np.ndarray) -> tuple[float, float]:
    """Expected value and delta-method standard error of sum S E c / sum S E (module docstring)."""
    k = np.arange(n)
    power = np.maximum(np.fft.rfft(ACF_SHAPES[acf](np.minimum(k, n - k) * spacing / L_CORR)).real, 0.0)
    power[0] = 0.0
    pairs = np.full(power.size, 2.0)
    var_e = np.ones(power.size)
    if n % 2 == 0:
        pairs[-1], var_e[-1] = 1.0, 2.0
    total = np.sum(pairs * power)
    expected = np.sum(pairs * power * weights) / total
    se = math.sqrt(np.sum(var_e * (pairs * power * (weights - expected)) ** 2)) / total
    return expected, se


def acf_standard_error(acf: str, n: int, lag: int) -> float:
    return ratio_statistic(acf, n, SPACING, np.cos(2 * np.pi * np.arange(n // 2 + 1) * lag / n))[1]


@pytest.fixture(scope="module")
def exponential() -> DiskProfile:
    return synthetic_profile(RMS, L_CORR, LENGTH, SPACING, seed=1)


# --- synthetic profiles -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("acf", sorted(ACF_SHAPES))
def test_synthetic_rms_mean_and_acf(acf):
    profile = synthetic_profile(RMS, L_CORR, LENGTH, SPACING, seed=7, acf=acf)
    z = profile.heights
    assert z.size == 16000 and profile.length == pytest.approx(LENGTH, rel=1e-12)
    assert profile.rms == pytest.approx(RMS, rel=1e-13)
    assert np.sqrt(np.mean(z * z)) == pytest.approx(RMS, rel=1e-13)
    assert abs(z.mean()) < 1e-14 * RMS
    se = acf_standard_error(acf, z.size, LAG)
    assert 0.016 < se < 0.019  # the module docstring's value for L = 2000 l
    assert abs(circular_acf(z, LAG) - math.exp(-1)) < N_SIGMA * se
    # 16 independent tracks: the mean estimate is 4 times sharper (also catches a biased generator),
    # at l and, for the whole shape, at l/2 and 2 l.
    tracks = [synthetic_profile(RMS, L_CORR, LENGTH, SPACING, seed, acf).heights for seed in range(16)]
    for lag in (LAG, LAG // 2, 2 * LAG):
        mean_estimate = np.mean([circular_acf(track, lag) for track in tracks])
        expected = ACF_SHAPES[acf](lag / LAG)
        assert abs(mean_estimate - expected) < N_SIGMA * acf_standard_error(acf, z.size, lag) / 4


def test_seed_reproducibility():
    a = synthetic_profile(RMS, L_CORR, 20 * L_CORR, SPACING, seed=3)
    b = synthetic_profile(RMS, L_CORR, 20 * L_CORR, SPACING, seed=3)
    c = synthetic_profile(RMS, L_CORR, 20 * L_CORR, SPACING, seed=4)
    np.testing.assert_array_equal(a.heights, b.heights)
    assert np.sqrt(np.mean((a.heights - c.heights) ** 2)) > 0.5 * RMS
    assert "seed=3" in a.source and "rms=" in a.source


def test_zero_rms_is_smooth():
    profile = synthetic_profile(0.0, L_CORR, 20 * L_CORR, SPACING, seed=3)
    assert profile.heights.size == 160
    assert np.all(profile.heights == 0.0) and profile.rms == 0.0


def test_gaussian_spectrum_decays_faster():
    """Fraction of the power at wavelengths shorter than l: a few per cent (exponential) against ~erfc(pi) (Gaussian).

    The sampled exponential track is an AR(1) sequence, phi = exp(-ds/l),
    whose spectrum (1 - phi^2) / (1 - 2 phi cos(theta) + phi^2) puts the
    fraction 1 - (2/pi) atan((1 + phi)/(1 - phi) tan(theta_l / 2)) above
    theta_l = 2 pi ds / l (0.095 at ds = l/8; the continuous Lorentzian
    gives 0.075 below the Nyquist frequency, the rest is aliased).
    """
    fractions = {}
    for acf in ACF_SHAPES:
        z = synthetic_profile(RMS, L_CORR, LENGTH, SPACING, seed=11, acf=acf).heights
        power = np.abs(np.fft.rfft(z)) ** 2
        short = np.fft.rfftfreq(z.size, SPACING) > 1 / L_CORR
        fractions[acf] = power[short].sum() / power.sum()
        expected, se = ratio_statistic(acf, z.size, SPACING, short.astype(float))
        assert abs(fractions[acf] - expected) < N_SIGMA * se
    phi = math.exp(-SPACING / L_CORR)
    ar1 = 1 - (2 / math.pi) * math.atan((1 + phi) / (1 - phi) * math.tan(math.pi * SPACING / L_CORR))
    assert fractions["exponential"] == pytest.approx(ar1, rel=0.1)
    assert fractions["gaussian"] < 1e-4 < 1e-2 * fractions["exponential"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rms": -1e-9}, "rms = -1e-09 m must be finite and >= 0"),
        ({"correlation_length": 0.0}, "correlation_length = 0.0 m must be finite and > 0"),
        ({"spacing": 0.0}, "spacing = 0.0 m must be finite and > 0"),
        ({"spacing": L_CORR / 2}, "at most correlation_length / 4 .* not resolved"),
        ({"length": 10 * L_CORR}, "length = .* at least 16 correlation lengths"),
        ({"acf": "lorentzian"}, "acf = 'lorentzian' is not one of \\['exponential', 'gaussian'\\]"),
    ],
)
def test_synthetic_validation(kwargs, match):
    args = {"rms": RMS, "correlation_length": L_CORR, "length": LENGTH, "spacing": SPACING, "seed": 0, **kwargs}
    with pytest.raises(ValueError, match=match):
        synthetic_profile(**args)


# --- window statistics ----------------------------------------------------------------------------------------------


def test_window_split_is_exact(exponential):
    z = exponential.heights
    for m in (3, 17, 65, 1001):
        mean, residual = window_statistics(exponential, m * SPACING)
        window_square = np.convolve(np.concatenate((z[-(m // 2) :], z, z[: m // 2])) ** 2, np.ones(m) / m, "valid")
        np.testing.assert_allclose(mean**2 + residual**2, window_square, rtol=1e-10, atol=1e-12 * RMS**2)
        # The periodic filter keeps the track mean: the split of the variance is exact on average too.
        assert np.mean(mean**2) + np.mean(residual**2) == pytest.approx(RMS**2, rel=1e-12)


def test_window_limits(exponential):
    mean, residual = window_statistics(exponential, 0.5 * SPACING)
    np.testing.assert_array_equal(mean, exponential.heights)
    np.testing.assert_array_equal(residual, 0.0)
    mean, residual = window_statistics(exponential, exponential.length)
    np.testing.assert_allclose(mean, 0.0, atol=1e-14 * RMS)
    np.testing.assert_allclose(residual, RMS, rtol=1e-13)
    assert window_samples(SPACING, 2 * SPACING, 100) == 3 and window_samples(SPACING, 3 * SPACING, 100) == 3
    with pytest.raises(ValueError, match="window width = 0.0 m must be finite and > 0"):
        window_statistics(exponential, 0.0)


def test_window_variance_matches_box_average_of_exponential_acf(exponential):
    """Var(mean_w) = (2 l^2 / w^2)(w/l - 1 + exp(-w/l)) rms^2, within 4 standard errors of the ratio estimator.

    Widths of at least 2 l: there the m-sample average differs from the
    continuous one by at most 1.7e-3 rms^2 (w = 2.1 l), 0.15 standard errors.
    """
    n = exponential.heights.size
    frequency = np.arange(n // 2 + 1) / n
    resolved_rms = []
    residual_rms = []
    for m in (1, 3, 17, 65, 257, 1025, n):
        mean, residual = window_statistics(exponential, m * SPACING)
        resolved_rms.append(np.sqrt(np.mean(mean**2)))
        residual_rms.append(np.sqrt(np.mean(residual**2)))
        if m not in (17, 65, 257):
            continue
        x = m * SPACING / L_CORR
        analytic = 2 / x**2 * (x - 1 + math.exp(-x))
        with np.errstate(invalid="ignore", divide="ignore"):
            transfer = np.where(frequency == 0, 1.0, np.sin(np.pi * frequency * m) / (m * np.sin(np.pi * frequency)))
        _, se = ratio_statistic("exponential", n, SPACING, transfer**2)
        assert abs(np.mean(mean**2) / RMS**2 - analytic) < N_SIGMA * se
    assert np.all(np.diff(resolved_rms) < 0) and np.all(np.diff(residual_rms) > 0)
    assert resolved_rms[0] == pytest.approx(RMS) and residual_rms[-1] == pytest.approx(RMS)


def test_profile_from_arrays_uniform_and_resampled():
    s = 1e-6 + np.arange(64) * 1e-8
    z = 3e-9 + np.sin(2 * np.pi * np.arange(64) / 64) * 1e-9
    profile = profile_from_arrays(s, z, "probe")
    assert profile.spacing == pytest.approx(1e-8, rel=1e-12) and profile.source == "probe"
    assert abs(profile.heights.mean()) < 1e-24  # the mean plane is the reference
    s_bad = s.copy()
    s_bad[10:] += 0.3e-8
    resampled = profile_from_arrays(s_bad, 2.0 * s_bad, "probe")
    assert "resampled linearly from 64" in resampled.source
    assert resampled.spacing == pytest.approx(1e-8)
    np.testing.assert_allclose(np.diff(resampled.heights), 2e-8, rtol=1e-9)  # a linear profile stays linear
    with pytest.raises(ValueError, match=r"strictly increasing: position\[4\]"):
        profile_from_arrays(np.r_[s[:5], s[4], s[6:]], z)
    with pytest.raises(ValueError, match="at least 16 samples, got 8"):
        profile_from_arrays(s[:8], z[:8])


# --- periodic sampling ----------------------------------------------------------------------------------------------


def test_sample_periodic_linear_and_wrapping():
    n, spacing = 40, 0.25
    values = 3.0 + 0.5 * np.arange(n) * spacing  # linear within one period
    s = np.linspace(0.0, (n - 1) * spacing, 157)
    out = np.empty_like(s)
    sample_periodic(values, spacing, s, out)
    np.testing.assert_allclose(out, 3.0 + 0.5 * s, rtol=0, atol=1e-13)
    period = n * spacing
    for turns in (-3, -1, 1, 1000):
        shifted = np.empty_like(s)
        sample_periodic(values, spacing, s + turns * period, shifted)
        np.testing.assert_allclose(shifted, out, rtol=0, atol=1e-12 * max(1, abs(turns)))


def test_sample_periodic_agrees_with_numpy_interp():
    rng = np.random.default_rng(5)
    n, spacing = 37, 0.1
    values = rng.standard_normal(n)
    s = rng.uniform(-25.0, 25.0, 1000)
    out = np.empty_like(s)
    sample_periodic(values, spacing, s, out)
    grid = np.arange(n + 1) * spacing
    expected = np.interp(np.mod(s, n * spacing), grid, np.r_[values, values[0]])
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


def test_fill_disk_heights_moves_the_filtered_track(exponential):
    nx, ny = 12, 7
    x = np.linspace(0.0, 1e-6, nx)
    y = np.linspace(-2e-7, 2e-7, ny)
    skew = 0.2
    s_nodes = x[:, None] * math.cos(skew) + y[None, :] * math.sin(skew)
    widths = np.gradient(x) * math.cos(skew)
    tables = disk_tables(exponential, widths)
    assert tables.mean.shape[0] == np.unique(tables.window_samples).size <= nx
    shift = 7.3 * exponential.length + 0.37e-6  # several revolutions later
    zd, sd = disk_surface(tables, s_nodes, shift)
    for i in (0, nx // 2, nx - 1):
        mean, residual = window_statistics(exponential, widths[i])
        row = tables.table_of_column[i]
        np.testing.assert_array_equal(tables.mean[row], mean)
        position = s_nodes[i] - (shift % exponential.length)
        expected = np.interp(
            np.mod(position, exponential.length), np.r_[exponential.positions, exponential.length], np.r_[mean, mean[0]]
        )
        np.testing.assert_allclose(zd[i], expected, rtol=0, atol=1e-9 * RMS)
        expected = np.interp(
            np.mod(position, exponential.length),
            np.r_[exponential.positions, exponential.length],
            np.r_[residual, residual[0]],
        )
        np.testing.assert_allclose(sd[i], expected, rtol=0, atol=1e-9 * RMS)
    # The kernel itself, with the unreduced shift: the same surface.
    zd2, sd2 = np.empty_like(zd), np.empty_like(sd)
    per_node = np.ascontiguousarray(np.broadcast_to(tables.table_of_column[:, None], s_nodes.shape))
    fill_disk_heights(tables.mean, tables.residual_rms, per_node, SPACING, s_nodes, shift, zd2, sd2)
    np.testing.assert_allclose(zd2, zd, rtol=0, atol=1e-6 * RMS)


def test_fill_disk_heights_wraps_any_node_and_shift():
    rng = np.random.default_rng(8)
    n, spacing = 50, 0.2
    period = n * spacing
    tables = rng.standard_normal((3, n)), rng.uniform(0.0, 1.0, (3, n))
    table_of_column = np.array([2, 0, 1, 1, 0], dtype=np.int64)
    s_nodes = rng.uniform(-3 * period, 3 * period, (5, 9))
    grid = np.arange(n + 1) * spacing
    zd, sd = np.empty_like(s_nodes), np.empty_like(s_nodes)
    for shift in (0.0, 0.37, -4.1 * period, 123.4 * period):
        per_node = np.ascontiguousarray(np.broadcast_to(table_of_column[:, None], s_nodes.shape))
        fill_disk_heights(*tables, per_node, spacing, s_nodes, shift, zd, sd)
        for i, row in enumerate(table_of_column):
            position = np.mod(s_nodes[i] - shift, period)
            for out, table in zip((zd, sd), tables, strict=True):
                expected = np.interp(position, grid, np.r_[table[row], table[row, 0]])
                np.testing.assert_allclose(out[i], expected, rtol=0, atol=1e-11 * max(1.0, abs(shift)))


# --- files ----------------------------------------------------------------------------------------------------------


def test_netcdf_round_trip(tmp_path, exponential):
    path = write_profile(exponential, tmp_path / "track.nc")
    back = read_profile(path)
    assert back.spacing == exponential.spacing
    np.testing.assert_array_equal(back.heights, exponential.heights)
    assert exponential.source in back.source and str(path) in back.source


def test_csv_round_trip(tmp_path):
    profile = synthetic_profile(RMS, L_CORR, 20 * L_CORR, SPACING, seed=2)
    path = tmp_path / "track.csv"
    np.savetxt(
        path, np.c_[profile.positions, profile.heights], delimiter=",", header="position_m,height_m", comments=""
    )
    back = read_profile(path)
    assert back.spacing == pytest.approx(profile.spacing, rel=1e-12) and back.source == str(path)
    np.testing.assert_allclose(back.heights, profile.heights, rtol=0, atol=1e-15 * RMS * 1e3)
    single = tmp_path / "heights.txt"
    np.savetxt(single, profile.heights)
    back = read_profile(single, spacing=SPACING)
    np.testing.assert_allclose(back.heights, profile.heights, rtol=0, atol=1e-12 * RMS)
    with pytest.raises(ValueError, match="single column of heights has no positions; give the sample step as spacing="):
        read_profile(single)


def test_netcdf_units_are_converted(tmp_path):
    import xarray as xr

    s_um = np.arange(32) * 0.01
    z_nm = np.sin(2 * np.pi * np.arange(32) / 32)
    ds = xr.Dataset(
        {"height": ("position", z_nm, {"units": "nm"})}, coords={"position": ("position", s_um, {"units": "um"})}
    )
    ds.to_netcdf(tmp_path / "measured.nc")
    profile = read_profile(tmp_path / "measured.nc")
    assert profile.spacing == pytest.approx(1e-8, rel=1e-12)
    np.testing.assert_allclose(profile.heights, z_nm * 1e-9 - np.mean(z_nm * 1e-9), rtol=0, atol=1e-24)


def test_bad_files(tmp_path):
    import xarray as xr

    prose = tmp_path / "notes.txt"
    prose.write_text("Disk track notes\nthe head flew nicely today\n")
    with pytest.raises(ValueError, match=r"notes.txt: not a profile: line 2"):
        read_profile(prose)
    short = tmp_path / "short.csv"
    np.savetxt(short, np.c_[np.arange(5) * 1e-8, np.zeros(5)], delimiter=",")
    with pytest.raises(ValueError, match=r"short.csv: not a usable profile: 5 samples, at least 16"):
        read_profile(short)
    backwards = tmp_path / "backwards.csv"
    np.savetxt(backwards, np.c_[-np.arange(20) * 1e-8, np.zeros(20)], delimiter=",")
    with pytest.raises(ValueError, match=r"backwards.csv: .*strictly increasing"):
        read_profile(backwards)
    no_height = tmp_path / "pressure.nc"
    xr.Dataset({"pressure": ("s", np.zeros(20), {"units": "Pa"})}, coords={"s": np.arange(20.0)}).to_netcdf(no_height)
    with pytest.raises(ValueError, match=r"pressure.nc: not a profile: no variable 'height' .*'pressure'"):
        read_profile(no_height)
    no_units = tmp_path / "no_units.nc"
    xr.Dataset({"height": ("s", np.zeros(20))}, coords={"s": ("s", np.arange(20.0), {"units": "m"})}).to_netcdf(
        no_units
    )
    with pytest.raises(ValueError, match=r"no_units.nc: variable 'height' has no units attribute"):
        read_profile(no_units)
    with pytest.raises(FileNotFoundError, match="missing.nc: no such file"):
        read_profile(tmp_path / "missing.nc")
