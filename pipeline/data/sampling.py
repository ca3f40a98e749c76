"""Statistics over a study's realisations: intervals of the mean, category fractions, and whether the
intervals behave as samples should (shrink as 1/sqrt(n); overlap under time-step or grid refinement).

Interval of the mean of n independent samples x_1..x_n (Student's t, level CONFIDENCE):

    x_bar +- h_n,   h_n = t_{(1 + CONFIDENCE)/2, n-1} s_n / sqrt(n),   s_n^2 = sum (x_i - x_bar)^2 / (n - 1).

Shrinking as 1/sqrt(n)
----------------------
``nested_half_widths`` gives h_n from the first n realisations (n = 2..N, in seed order): what a study of n
realisations would have reported.  The law to check is that the standard error se_n = s_n / sqrt(n) falls as
n^(-1/2) (h_n falls faster at small n, since t_{n-1} drops from 12.7 at n = 2 to 2.13 at n = 16).  The slope of
log se_n against log n is fitted by least squares over n = FIT_FROM..N after removing the known small-sample
bias of log s_n: for k = n - 1 degrees of freedom and normal samples, E[log s_n] = log sigma + b(k) with

    b(k) = (digamma(k/2) + ln 2 - ln k) / 2      (b(2) = -0.29, b(15) = -0.03),

so that independent normal samples give -1/2 in expectation (without the correction the fit over n = 3..16
gives -0.38 on average, and -0.27 over 3..8).  The fit of one set of N samples scatters (its successive se_n
share samples): the report gives the central 95 % range of the same fit over SLOPE_DRAWS synthetic sets of N
independent normal samples, the range within which an observed slope is consistent with -1/2 ([-0.97, 0.25]
for N = 16, [-0.72, -0.21] for N = 64: one cell of 16 realisations checks the law only loosely).

Refinement (time step, grid)
----------------------------
``refinement_report`` compares each cell with the reference cell along one axis (its last value: the smallest
dt, or the finest grid).  The intervals overlap if |mean - mean_ref| <= h + h_ref.  Because the same seed
gives the same track profile at any dt (the profile depends on the seed, the RMS, the correlation length and
the run's length only), the realisations are paired: the difference d_i = x_i - x_ref,i of each seed has its
own interval, far narrower than either cell's when the track dominates the scatter, and the discretisation
error is resolved when that interval contains 0.
"""

from __future__ import annotations

import warnings

import numpy as np
import xarray as xr
from scipy import special
from scipy.stats import t as student

from pipeline.data.netcdf import var
from pipeline.data.units import display_scale

#: Confidence level of every interval of a mean over realisations.
CONFIDENCE = 0.95
#: Smallest n of the 1/sqrt(n) fit (n = 2 has one degree of freedom: log s_2 is the log of one |difference|,
#: whose spread would dominate the fit).
FIT_FROM = 3
#: Synthetic sets of N independent normal samples that give the 95 % range of the fitted slope.
SLOPE_DRAWS = 4000
#: Seed of those synthetic sets (the range is a reproducible number).
SLOPE_SEED = 20260101
#: The slope of the standard error against n for independent samples.
INDEPENDENT_SLOPE = -0.5


def t_factor(n: np.ndarray) -> np.ndarray:
    """t_{(1 + CONFIDENCE)/2, n-1}: the half-width of the interval in standard errors (NaN for n < 2)."""
    n = np.asarray(n, dtype=float)
    return np.where(n > 1, student.ppf(0.5 + CONFIDENCE / 2, np.maximum(n - 1, 1)), np.nan)


def mean_interval(values: np.ndarray, axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean, half-width h_n, n) of the finite values along ``axis``; h is NaN where n < 2.

    Equal samples (a deterministic cell's shared run) get h = 0 exactly, not the round-off of their mean.
    """
    values = np.asarray(values, dtype=float)
    n = np.count_nonzero(np.isfinite(values), axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # cells without finite samples (a bisection's unprobed)
        mean = np.nanmean(values, axis=axis) if values.size else np.full(n.shape, np.nan)
        equal = (np.nanmax(values, axis=axis) == np.nanmin(values, axis=axis)) if values.size else n < 0
        sd = np.where(equal, 0.0, np.nanstd(values, axis=axis, ddof=1))
        half = t_factor(n) * sd / np.sqrt(np.where(n > 0, n, np.nan))
    return mean, half, n


def nested_half_widths(values: np.ndarray) -> np.ndarray:
    """h_n of the first n samples along the last axis, n = 2..N: shape (..., N - 1) (NaN where a sample is not
    finite among the first n)."""
    values = np.asarray(values, dtype=float)
    out = [mean_interval(values[..., :n])[1] for n in range(2, values.shape[-1] + 1)]
    halves = np.stack(out, axis=-1) if out else np.empty((*values.shape[:-1], 0))
    complete = np.cumsum(~np.isfinite(values), axis=-1)[..., 1:] == 0
    return np.where(complete, halves, np.nan)


def log_sd_bias(dof: np.ndarray) -> np.ndarray:
    """b(k) = E[log s] - log sigma for k degrees of freedom of normal samples: (digamma(k/2) + ln 2 - ln k) / 2."""
    k = np.asarray(dof, dtype=float)
    return 0.5 * (special.digamma(0.5 * k) + np.log(2.0) - np.log(k))


def standard_error_fit(halves: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit log se_n - b(n - 1) = a + slope log n over n = FIT_FROM..N, from nested half-widths
    ``halves`` (..., N - 1) for n = 2..N (se_n = h_n / t_{n-1}): (slope, a); NaN with fewer than two points, or
    where an interval is 0 (a deterministic cell)."""
    halves = np.asarray(halves, dtype=float)
    n = np.arange(2, halves.shape[-1] + 2, dtype=float)
    keep = n >= FIT_FROM
    n = n[keep]
    if n.size < 2:
        nan = np.full(halves.shape[:-1], np.nan)
        return nan, nan
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(halves[..., keep] / t_factor(n)) - log_sd_bias(n - 1)
    x = np.log(n) - np.log(n).mean()
    slope = (y * x).sum(axis=-1) / (x * x).sum()
    intercept = y.mean(axis=-1) - slope * np.log(n).mean()
    ok = np.isfinite(y).all(axis=-1)
    return np.where(ok, slope, np.nan), np.where(ok, intercept, np.nan)


def standard_error_slope(halves: np.ndarray) -> np.ndarray:
    """The slope of :func:`standard_error_fit`."""
    return standard_error_fit(halves)[0]


def fitted_half_widths(slope: np.ndarray, intercept: np.ndarray, n: np.ndarray) -> np.ndarray:
    """h_n = t_{n-1} exp(a + slope log n + b(n - 1)): the half-widths of the fit (..., len(n))."""
    n = np.asarray(n, dtype=float)
    log_se = intercept[..., None] + slope[..., None] * np.log(n) + log_sd_bias(n - 1)
    return t_factor(n) * np.exp(log_se)


def independent_slope_range(n_samples: int) -> tuple[float, float]:
    """Central 95 % range of :func:`standard_error_slope` over SLOPE_DRAWS sets of ``n_samples`` independent
    normal samples (NaN, NaN where no slope can be fitted)."""
    if n_samples - FIT_FROM + 1 < 2:
        return float("nan"), float("nan")
    rng = np.random.default_rng(SLOPE_SEED)
    slopes = standard_error_slope(nested_half_widths(rng.standard_normal((SLOPE_DRAWS, n_samples))))
    low, high = np.quantile(slopes, [(1 - CONFIDENCE) / 2, (1 + CONFIDENCE) / 2])
    return float(low), float(high)


def category_fractions(flags: np.ndarray, n_categories: int) -> tuple[np.ndarray, np.ndarray]:
    """Share of each category 0..n_categories-1 among the classified samples (flag >= 0) along the last axis:
    (fractions (..., n_categories), classified count (...)); fractions NaN where no sample is classified, and
    summing to 1 otherwise."""
    flags = np.asarray(flags)
    counts = np.stack([np.count_nonzero(flags == c, axis=-1) for c in range(n_categories)], axis=-1)
    total = counts.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        fractions = counts / np.where(total > 0, total, np.nan)[..., None]
    return fractions, total


def refinement_report(ds: xr.Dataset, names: list[str], dim: str, realization: str) -> xr.Dataset:
    """Each cell against the reference cell (the last value of ``dim``), for each variable ``<name>``:

    - ``<name>_overlap``: 1 if the cell's and the reference's 95 % intervals of the mean overlap, else 0;
    - ``<name>_paired_difference`` and ``<name>_paired_difference_ci95``: mean over the seeds of
      x(cell, seed) - x(reference, seed) and the half-width of its 95 % interval;
    - ``<name>_ci95_nested`` (cells, ``samples``): the half-width from the first n realisations, n = 2..N;
    - ``<name>_se_slope``: the fitted slope of the standard error against n (see the module docstring), and
      ``<name>_ci95_fitted`` (cells, ``samples``) the half-widths of that fit;
    - ``<name>_ci95_independent`` (cells, ``samples``): the half-widths of independent samples with the cell's
      spread, slope -1/2 through the cell's h_N (the same bias and t factor as the fit);

    and ``se_slope_range`` (``bound``): the 95 % range of that slope for independent normal samples.
    """
    n_total = ds.sizes[realization]
    samples = np.arange(2, n_total + 1)
    out: dict[str, xr.Variable] = {}
    for name in names:
        x = ds[name].transpose(..., realization)
        units, long_name = x.attrs.get("units", ""), x.attrs.get("long_name", name)
        cells, by_n = x.dims[:-1], (*x.dims[:-1], "samples")
        reference = x.isel({dim: -1})
        mean, half, _ = mean_interval(x.values)
        ref_mean, ref_half, _ = mean_interval(reference.values)
        axis = x.dims.index(dim)
        gap = np.abs(mean - np.expand_dims(ref_mean, axis))
        overlap = np.where(np.isfinite(gap), gap <= half + np.expand_dims(ref_half, axis), -1).astype(np.int8)
        flags = {"flag_values": np.array([-1, 0, 1], dtype=np.int8), "flag_meanings": "undefined disjoint overlapping"}
        out[f"{name}_overlap"] = var(
            overlap,
            cells,
            "1",
            f"95 % interval of the mean overlaps the one at the reference {dim}: {long_name}",
            **flags,
        )
        diff_mean, diff_half, _ = mean_interval((x - reference).values)
        out[f"{name}_paired_difference"] = var(
            diff_mean, cells, units, f"mean over the seeds of the difference to the reference {dim}: {long_name}"
        )
        out[f"{name}_paired_difference_ci95"] = var(
            diff_half, cells, units, f"half-width of the 95 % interval of the paired difference: {long_name}"
        )
        halves = nested_half_widths(x.values)
        out[f"{name}_ci95_nested"] = var(
            halves, by_n, units, f"half-width of the 95 % interval from the first n realisations: {long_name}"
        )
        slope, intercept = standard_error_fit(halves)
        out[f"{name}_se_slope"] = var(
            slope, cells, "1", f"fitted slope of log standard error against log n (-1/2 expected): {long_name}"
        )
        fitted = fitted_half_widths(slope, intercept, samples)
        out[f"{name}_ci95_fitted"] = var(
            fitted, by_n, units, f"half-width of the fit of the standard error against n: {long_name}"
        )
        with np.errstate(divide="ignore"):  # a zero interval (a deterministic cell) has no line
            last = np.log(halves[..., -1] / t_factor(n_total))
        through_last = last - log_sd_bias(n_total - 1) + 0.5 * np.log(n_total)
        independent = fitted_half_widths(np.full(slope.shape, INDEPENDENT_SLOPE), through_last, samples)
        out[f"{name}_ci95_independent"] = var(
            independent, by_n, units, f"half-width of independent samples (slope -1/2 through n = N): {long_name}"
        )
    low, high = independent_slope_range(n_total)
    out["se_slope_range"] = var(
        [low, high], ("bound",), "1", f"95 % range of the fitted slope for {n_total} independent normal samples"
    )
    coords = {
        "samples": ("samples", samples, {"units": "1", "long_name": "realisations n (the first n seeds)"}),
        "bound": ("bound", np.array([0, 1], dtype=np.int8), {"long_name": "bound of the range",
                  "flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "low high"}),
    }  # fmt: skip
    report = xr.Dataset(out, coords=coords)
    report.attrs.update(refinement_axis=dim, refinement_reference=float(ds[dim].values[-1]))
    return report


def report_text(ds: xr.Dataset) -> str:
    """The refinement report of a "statistics" study as text: per variable and cell, the interval of the mean,
    whether it overlaps the reference's, the paired difference, and the fitted 1/sqrt(n) slope."""
    dim = ds.attrs["refinement_axis"]
    low, high = (float(v) for v in ds["se_slope_range"].values)
    names = [str(v)[: -len("_se_slope")] for v in ds.data_vars if str(v).endswith("_se_slope")]
    dscale, dunit = display_scale(ds[dim].attrs.get("units", ""), ds[dim].values)
    at = f"{ds.attrs['refinement_reference'] * dscale:g} {dunit}".removesuffix(" 1")
    lines = [
        f"intervals of the mean against {dim} (reference: the last value, {at}); "
        f"slope of the standard error against n: -1/2 expected, 95 % range for independent normal samples "
        f"[{low:.3f}, {high:.3f}]"
    ]
    for name in names:
        units = ds[name].attrs.get("units", "")
        scale, shown = display_scale(units)
        rows = []
        stacked = ds[[f"{name}_mean", f"{name}_ci95", f"{name}_overlap", f"{name}_paired_difference",
                      f"{name}_paired_difference_ci95", f"{name}_se_slope"]].to_dataframe()  # fmt: skip
        levels = list(stacked.index.names)
        for index, r in stacked.iterrows():
            overlap = {1: "yes", 0: "NO", -1: "-"}[int(r[f"{name}_overlap"])]
            slope = r[f"{name}_se_slope"]
            inside = "" if not np.isfinite(slope) else (" (in range)" if low <= slope <= high else " (OUT of range)")
            rows.append(
                f"  {_shown(index, levels, dim, dscale):<28} {r[f'{name}_mean'] * scale:10.4g} "
                f"+- {r[f'{name}_ci95'] * scale:<9.2g} "
                f"overlap {overlap:<4} paired diff {r[f'{name}_paired_difference'] * scale:+10.3g} "
                f"+- {r[f'{name}_paired_difference_ci95'] * scale:<9.2g} slope {slope:+.3f}{inside}"
            )
        lines += [f"{name} [{shown}]", *rows]
    return "\n".join(lines)


def _shown(index: object, names: list[str], dim: str, scale: float) -> str:
    """A report row's cell: its coordinates, the refinement axis ``dim`` in display units (``scale``)."""
    values = index if isinstance(index, tuple) else (index,)
    return " ".join(f"{v * scale:.4g}" if name == dim else str(v) for name, v in zip(names, values, strict=True))
