"""A study's dataset: one cell per case, dimensions named after the axes.

Variables (each with ``units`` and ``long_name``): the study's outputs, declared once per kind in
:mod:`pipeline.classify` (for kind "rails": ``stable`` int8, flags -1 not_classified, 0 unstable, 1 stable;
``status`` int8, flags -2 not_run, -1 failed, 0 completed, 1 stopped (impact limit); ``message``, the run's
status message (the error for a failed run); counts (int32, -1 where the run has none), impulses and times (NaN
where none)), and:

- ``impact_time``/``impact_corner``/``impact_impulse`` on an extra ``impact`` dimension;
- ``boundary_lower``/``boundary_upper`` over the other axes: the bracket of the
  class boundary on the boundary axis (the kind's :class:`pipeline.kinds.Traced`: stable/unstable, or a regime
  below/at or above the study's threshold), from the grid (first
  crossing from the low class's side) or from bisection (``boundary_method``); with a ``realization`` axis
  (one line per track) also ``boundary_mean``/``boundary_ci95``, the mean of the brackets' midpoints over the
  realisations and its 95 % half-width (NaN where a realisation's bracket is open: the boundary lies outside
  the axis's range on that track), and ``boundary_closed``, the realisations with a closed bracket.

With a ``realization`` axis (n > 1 seeds of the stochastic input per cell), over the other axes:

- ``<name>_mean`` and ``<name>_ci95``: each float output's mean over the realisations and the half-width of
  its 95 % interval (Student's t, :mod:`pipeline.data.sampling`);
- ``<category>_fraction`` (cells, ``<category>s``), for a kind with a category (kind "abs": ``regime_fraction``
  over ``regimes`` = flying, intermittent_contact, sustained_contact, stuck, a string coordinate, written as
  ``regimes_label`` in the file): the share of the cell's classified
  realisations in each category (sums to 1 over the categories; NaN where none is classified),
  ``<category>_count`` the classified realisations, and ``dominant_<category>`` the category with the largest
  share (the first of equal shares; -1 where none);
- for a study whose figure is "statistics": the refinement report along the first axis
  (:func:`pipeline.data.sampling.refinement_report`).

The dataset is a function of the ledger's records only, so a resumed study
gives the same dataset as an uninterrupted one.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import xarray as xr

from pipeline.classify import NOT_RUN
from pipeline.data.netcdf import var
from pipeline.data.sampling import category_fractions, mean_interval, refinement_report
from pipeline.kinds import adapter_of
from pipeline.provenance import base_attrs
from pipeline.study.spec import REALIZATION, Axis, Case, Study, study_attrs


def _coord(axis: Axis, values: tuple[Any, ...]) -> tuple[str, np.ndarray, dict[str, str]]:
    return (axis.dim, np.asarray(values), {"units": axis.units, "long_name": axis.long_name, "scene_key": axis.key})


def study_dataset(
    study: Study,
    cells: dict[tuple[int, ...], tuple[Case, dict[str, Any]]],
    axis_values: dict[str, tuple[Any, ...]] | None = None,
    bisection: list[dict[str, Any]] | None = None,
) -> xr.Dataset:
    """Assemble the records of ``cells`` (grid index -> (case, record)) into the study's dataset.

    ``axis_values`` replaces an axis's values by dim (the bisection lattice);
    ``bisection`` is :meth:`BisectionPlanner.summary` for a boundary study.
    """
    axis_values = axis_values or {}
    values = [axis_values.get(a.dim, a.values) for a in study.axes]
    shape = tuple(len(v) for v in values)
    dims = study.dims
    adapter = adapter_of(study.base)
    outputs = adapter.outputs
    arrays = {name: np.full(shape, out.fill, dtype=out.dtype) for name, out in outputs.items()}
    k = study.impacts_kept
    imp_time = np.full((*shape, k), np.nan)
    imp_impulse = np.full((*shape, k), np.nan)
    imp_corner = np.full((*shape, k), "", dtype=object)
    run_ids = np.full(shape, "", dtype=object)
    for index, (case, record) in cells.items():
        run_ids[index] = case.run_id
        for name, out in outputs.items():
            value = record.get(name, out.fill)
            arrays[name][index] = out.fill if value is None else value
        if record.get("status", -1) == -1 and adapter.class_flag:
            arrays[adapter.class_flag][index] = outputs[adapter.class_flag].fill
        impacts = record.get("impacts") or {}
        n = min(len(impacts.get("time", [])), k)
        imp_time[index][:n] = impacts["time"][:n] if n else []
        imp_impulse[index][:n] = impacts["impulse"][:n] if n else []
        imp_corner[index][:n] = impacts["corner"][:n] if n else []

    data: dict[str, xr.Variable] = {}
    for name in study.variables:
        out = outputs[name]
        data[name] = var(arrays[name], dims, out.units, out.long_name, **out.attrs)
    data["run_id"] = var(run_ids, dims, "", "ledger key of the run (hash of its scene and the package version)")
    if k:
        idims = (*dims, "impact")
        data["impact_time"] = var(imp_time, idims, "s", "time of impact")
        data["impact_corner"] = var(imp_corner, idims, "", "corner struck (A, B, C, D)")
        data["impact_impulse"] = var(imp_impulse, idims, "N s", "normal impulse q")

    series_time = next((r["series"]["time"] for _c, r in cells.values() if r.get("series")), None)
    if series_time is not None:
        nt = len(series_time)
        for name, (units, long_name) in adapter.series_kept.items():
            arr = np.full((*shape, nt), np.nan)
            for index, (_case, record) in cells.items():
                values_t = (record.get("series") or {}).get(name)
                if values_t is not None:
                    arr[index][: min(nt, len(values_t))] = values_t[:nt]
            data[name] = var(arr, (*dims, "time"), units, long_name)

    frequency = next((r["spectra"]["frequency"] for _c, r in cells.values() if r.get("spectra")), None)
    if frequency is not None and adapter.spectra_kept:
        nf = len(frequency)
        for name, (units, long_name) in adapter.spectra_kept.items():
            arr = np.full((*shape, nf), np.nan)
            for index, (_case, record) in cells.items():
                amp = (record.get("spectra") or {}).get(name)
                if amp is not None and len(amp) == nf:  # a run of another length (t_end) is left out
                    arr[index] = amp
            data[f"{name}_spectrum"] = var(arr, (*dims, "frequency"), units, long_name)

    coords: dict[str, Any] = {a.dim: _coord(a, v) for a, v in zip(study.axes, values, strict=True)}
    if frequency is not None and adapter.spectra_kept:
        coords["frequency"] = ("frequency", np.asarray(frequency), {"units": "Hz", "long_name": "frequency"})
    if series_time is not None:
        coords["time"] = ("time", np.asarray(series_time), {"units": "s", "long_name": "time since steady flight"})
    if k:
        coords["impact"] = ("impact", np.arange(1, k + 1), {"long_name": "impact number (first impacts of a run)"})
    ds = xr.Dataset(data, coords=coords)
    ran = int(np.count_nonzero(arrays["status"] != NOT_RUN))
    ds.attrs.update(base_attrs(study.title))
    ds.attrs.update(study_attrs(study))
    ds.attrs.update(scene_kind=adapter.name, product="study")
    if REALIZATION in ds.dims and ds.sizes[REALIZATION] > 1:
        floats = [n for n in study.variables if outputs[n].dtype is np.float64]
        ds = ds.merge(realization_statistics(ds, floats))
        if adapter.category is not None:
            ds = ds.merge(category_statistics(ds[adapter.category], adapter.category))
        if study.figure == "statistics":
            kept = [n for n in STATISTICS_VARIABLES if n in floats]
            report = refinement_report(ds, kept, study.axes[0].dim, REALIZATION)
            ds = ds.merge(report)
            ds.attrs.update(report.attrs)
    ds.attrs["runs"] = ran
    ds.attrs["failed_runs"] = int(np.count_nonzero(arrays["status"] == -1))
    if study.boundary is not None:
        if bisection is not None:
            _add_bisection(ds, study, bisection)
        elif ran == ds["status"].size:
            _add_grid_boundary(ds, study)
    return ds


def _boundary_vars(ds: xr.Dataset, study: Study, lower: np.ndarray, upper: np.ndarray, method: str) -> None:
    axis = study.axis(study.boundary.axis)
    other = tuple(a.dim for a in study.axes if a.dim != axis.dim)
    side = study.boundary.stable_side
    low, high = adapter_of(study.base).traced.names(study.boundary.threshold)
    below, above = (low, high) if side == "below" else (high, low)
    ds["boundary_lower"] = var(lower, other, axis.units, f"largest {axis.dim} on the {below} side of the boundary")
    ds["boundary_upper"] = var(upper, other, axis.units, f"smallest {axis.dim} on the {above} side of the boundary")
    ds.attrs["boundary_axis"] = axis.dim
    ds.attrs["boundary_method"] = method
    ds.attrs["boundary_stable_side"] = side
    ds.attrs["boundary_classes"] = f"{low} (low) / {high} (high)"
    if study.boundary.threshold is not None:
        ds.attrs["boundary_threshold"] = study.boundary.threshold
    if REALIZATION in other and ds.sizes[REALIZATION] > 1:
        rest = tuple(d for d in other if d != REALIZATION)
        last = other.index(REALIZATION)
        mid = 0.5 * (lower + upper)
        closed = np.isfinite(mid)
        mean, half, _n = mean_interval(np.moveaxis(mid, last, -1))
        every = np.all(closed, axis=last)
        ds["boundary_mean"] = var(
            np.where(every, mean, np.nan),
            rest,
            axis.units,
            f"mean over the realisations of the boundary's {axis.dim} (bracket midpoints)",
        )
        ds["boundary_ci95"] = var(
            np.where(every, half, np.nan),
            rest,
            axis.units,
            "half-width of the 95 % interval of boundary_mean (Student's t)",
        )
        ds["boundary_closed"] = var(
            np.count_nonzero(closed, axis=last).astype(np.int32), rest, "1",
            "realisations whose boundary bracket is closed (the others: outside the range)",
        )  # fmt: skip


def grid_boundary(stable: np.ndarray, side: str = "below") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bracket indices along the last axis of ``stable`` (1/0/-1): (lo, hi, monotonic).

    hi is the first index on the high side (unstable for side "below"), lo the
    last classified low-side index before it; -1 / n where there is none.
    """
    stable = np.asarray(stable)
    n = stable.shape[-1]
    high_class = 0 if side == "below" else 1
    lo = np.full(stable.shape[:-1], -1)
    hi = np.full(stable.shape[:-1], n)
    mono = np.ones(stable.shape[:-1], dtype=bool)
    for ix in itertools.product(*(range(s) for s in stable.shape[:-1])):
        line = stable[ix]
        high = np.flatnonzero(line == high_class)
        low = np.flatnonzero(line == 1 - high_class)
        hi[ix] = high[0] if high.size else n
        below = low[low < hi[ix]]
        lo[ix] = below[-1] if below.size else -1
        mono[ix] = not np.any(low > hi[ix])
    return lo, hi, mono


def _add_grid_boundary(ds: xr.Dataset, study: Study) -> None:
    axis = study.axis(study.boundary.axis)
    other = [a.dim for a in study.axes if a.dim != axis.dim]
    traced = adapter_of(study.base).traced
    classes = traced.classes(ds[traced.flag].transpose(*other, axis.dim).values, study.boundary.threshold)
    lo, hi, mono = grid_boundary(classes, study.boundary.stable_side)
    vals = np.asarray(ds[axis.dim].values, dtype=float)
    padded = np.concatenate([vals, [np.nan]])
    lower = np.where(lo >= 0, padded[lo], np.nan)
    upper = padded[hi]
    _boundary_vars(ds, study, lower, upper, "grid")
    ds["boundary_monotonic"] = var(
        mono.astype(np.int8), tuple(other), "1", "1 if the line crosses the boundary once",
        flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="several_crossings single_crossing",
    )  # fmt: skip


def _add_bisection(ds: xr.Dataset, study: Study, lines: list[dict[str, Any]]) -> None:
    axis = study.axis(study.boundary.axis)
    other_axes = [a for a in study.axes if a.dim != axis.dim]
    shape = tuple(len(a.values) for a in other_axes)
    lower = np.full(shape, np.nan)
    upper = np.full(shape, np.nan)
    runs = np.zeros(shape, dtype=np.int32)
    mono = np.ones(shape, dtype=np.int8)
    for line in lines:
        ix = tuple(line["index"])
        lower[ix], upper[ix], runs[ix], mono[ix] = line["lower"], line["upper"], line["runs"], line["monotonic"]
    _boundary_vars(ds, study, lower, upper, "bisection")
    other = tuple(a.dim for a in other_axes)
    ds["boundary_runs"] = var(runs, other, "1", "runs the bisection of this line used")
    ds["boundary_monotonic"] = var(
        mono, other, "1", "1 if the probes of the line are consistent with a single crossing",
        flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="several_crossings single_crossing",
    )  # fmt: skip
    if study.boundary.tolerance is None:
        ds.attrs["boundary_lattice"] = "the axis values"
    else:
        ds.attrs["boundary_tolerance"] = study.boundary.tolerance


#: Outputs a "statistics" study reports (interval shrinkage, refinement), where it keeps them.
STATISTICS_VARIABLES = ("bouncing_3sigma", "mean_flying_height", "mean_contact_force", "contact_fraction")


def realization_statistics(ds: xr.Dataset, names: list[str]) -> xr.Dataset:
    """Mean over the realisations of each cell and the half-width of its 95 % confidence interval.

    The half-width is t_{0.975, n-1} s / sqrt(n), with s the sample standard deviation of the n finite values
    (Student's t: the realisations are independent samples of the same run); NaN where fewer than two values
    are finite.  Variables ``<name>_mean`` and ``<name>_ci95``, on the study's other dimensions.
    """
    out = {}
    for name in names:
        values = ds[name].transpose(..., REALIZATION)
        mean, half, _n = mean_interval(values.values)
        dims = values.dims[:-1]
        units, long_name = values.attrs.get("units", ""), values.attrs.get("long_name", name)
        out[f"{name}_mean"] = var(mean, dims, units, f"mean over realisations of: {long_name}")
        out[f"{name}_ci95"] = var(
            half, dims, units, f"half-width of the 95 % confidence interval of the mean of: {long_name}"
        )
    return xr.Dataset(out)


def category_statistics(flags: xr.DataArray, name: str) -> xr.Dataset:
    """``<name>_fraction`` (cells, ``<name>s``), ``<name>_count`` and ``dominant_<name>`` of a flag output over
    the realisations; the categories are its non-negative ``flag_values``/``flag_meanings`` (the dimension is
    the plural, since ``<name>`` is the per-run variable)."""
    values = flags.attrs["flag_values"]
    meanings = flags.attrs["flag_meanings"].split()
    categories = [(int(v), m) for v, m in zip(values, meanings, strict=True) if v >= 0]
    assert [v for v, _ in categories] == list(range(len(categories))), "categories must be numbered 0, 1, ..."
    flags = flags.transpose(..., REALIZATION)
    fractions, count = category_fractions(flags.values, len(categories))
    dims = flags.dims[:-1]
    labels = np.array([m for _, m in categories], dtype=object)
    long_name = flags.attrs.get("long_name", name)
    dominant = np.where(count > 0, np.argmax(np.nan_to_num(fractions, nan=-1.0), axis=-1), -1).astype(np.int8)
    fraction = var(fractions, (*dims, f"{name}s"), "1",
                   f"fraction of the classified realisations in each category of: {long_name}",
                   comment="sums to 1 over the categories; NaN where no realisation is classified")  # fmt: skip
    flag_values = np.array([-1, *range(len(categories))], dtype=np.int8)
    return xr.Dataset(
        {
            f"{name}_fraction": fraction,
            f"{name}_count": var(count.astype(np.int32), dims, "1", f"realisations classified by: {long_name}"),
            f"dominant_{name}": var(
                dominant,
                dims,
                "1",
                f"category of most realisations (first of equal shares): {long_name}",
                flag_values=flag_values,
                flag_meanings="not_classified " + " ".join(labels),
            ),
        },  # fmt: skip
        coords={f"{name}s": (f"{name}s", labels, {"long_name": f"category of {long_name}"})},
    )
