"""A study's dataset: one cell per case, dimensions named after the axes.

Variables (each with ``units`` and ``long_name``):

- ``stable`` int8, flags -1 not_classified, 0 unstable, 1 stable;
- ``status`` int8, flags -2 not_run, -1 failed, 0 completed, 1 stopped (impact limit);
- ``message``: the run's status message (the error for a failed run);
- counts (int32, -1 where the run has none), impulses and times (NaN where none);
- ``impact_time``/``impact_corner``/``impact_impulse`` on an extra ``impact`` dimension;
- ``boundary_lower``/``boundary_upper`` over the other axes: the bracket of the
  stable/unstable boundary on the boundary axis, from the grid (first
  crossing from the stable side) or from bisection (``boundary_method``).

The dataset is a function of the ledger's records only, so a resumed study
gives the same dataset as an uninterrupted one.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import xarray as xr

from .provenance import base_attrs
from .store import STABLE_FLAGS, STATUS_FLAGS, var
from .study import Axis, Case, Study, study_attrs

NOT_RUN = -2
STUDY_STATUS_FLAGS = {
    "flag_values": np.array([NOT_RUN, *STATUS_FLAGS["flag_values"]], dtype=np.int8),
    "flag_meanings": "not_run " + STATUS_FLAGS["flag_meanings"],
}
STUDY_STABLE_FLAGS = {
    "flag_values": np.array([-1, *STABLE_FLAGS["flag_values"]], dtype=np.int8),
    "flag_meanings": "not_classified " + STABLE_FLAGS["flag_meanings"],
}
MISSING_COUNT = "-1 where the run failed or was not run"

# name -> (dtype, fill, units, long_name, extra attrs)
CELL_VARIABLES: dict[str, tuple[Any, Any, str, str, dict[str, Any]]] = {
    "stable": (np.int8, -1, "1", "impulse-growth classification (unstable if a later impulse exceeds the first)",
               STUDY_STABLE_FLAGS),
    "status": (np.int8, NOT_RUN, "1", "run status", STUDY_STATUS_FLAGS),
    "message": (object, "", "", "status message of the run (the error of a failed run)", {}),
    "n_impacts": (np.int32, -1, "1", "number of impacts", {"comment": MISSING_COUNT}),
    "n_larger_than_first": (np.int32, -1, "1", "impacts larger than the first", {"comment": MISSING_COUNT}),
    "n_front_corner_impacts": (np.int32, -1, "1", "impacts at the front corners A, C", {"comment": MISSING_COUNT}),
    "first_impulse": (np.float64, np.nan, "N s", "first impulse", {}),
    "max_impulse_ratio": (np.float64, np.nan, "1", "largest later impulse / first impulse", {}),
    "first_impact_time": (np.float64, np.nan, "s", "time of the first impact", {}),
    "steps": (np.int32, -1, "1", "time steps taken", {"comment": MISSING_COUNT}),
    "newton_iterations": (np.int32, -1, "1", "Newton iterations", {"comment": MISSING_COUNT}),
    "wall_time": (np.float64, np.nan, "s", "wall time of the run on its worker", {}),
    "bouncing_3sigma": (np.float64, np.nan, "m", "3 sigma of the flying height at the element after settling", {}),
    "mean_flying_height": (np.float64, np.nan, "m", "mean flying height at the element after settling", {}),
    "min_clearance": (np.float64, np.nan, "m", "smallest spacing of the face to the resolved disk", {}),
    "mean_contact_force": (np.float64, np.nan, "N", "mean normal contact force after settling", {}),
    "max_contact_force": (np.float64, np.nan, "N", "largest normal contact force after settling", {}),
    "contact_fraction": (np.float64, np.nan, "1", "fraction of samples with contact force above the threshold", {}),
    "mean_adhesion_force": (np.float64, np.nan, "N", "mean adhesion force (negative: towards the disk)", {}),
    "mean_friction_force": (np.float64, np.nan, "N", "mean friction force", {}),
    "fh_peak_frequency": (np.float64, np.nan, "Hz", "main peak of the flying-height spectrum", {}),
    "pitch_peak_frequency": (np.float64, np.nan, "Hz", "main peak of the pitch spectrum", {}),
    "roll_peak_frequency": (np.float64, np.nan, "Hz", "main peak of the roll spectrum", {}),
    "steady_flying_height": (np.float64, np.nan, "m", "steady flying height at the element (smooth mean disk)", {}),
    "steady_pitch": (np.float64, np.nan, "rad", "steady pitch", {}),
    "steady_roll": (np.float64, np.nan, "rad", "steady roll", {}),
    "steady_contact_force": (np.float64, np.nan, "N", "steady contact force (statistical roughness)", {}),
}  # fmt: skip

#: Time series an "abs" run returns in its record: (units, long_name).
SERIES_VARIABLES = {
    "flying_height": ("m", "flying height at the read/write element"),
    "contact_force": ("N", "normal contact force"),
}


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
    arrays = {name: np.full(shape, spec[1], dtype=spec[0]) for name, spec in CELL_VARIABLES.items()}
    k = study.impacts_kept
    imp_time = np.full((*shape, k), np.nan)
    imp_impulse = np.full((*shape, k), np.nan)
    imp_corner = np.full((*shape, k), "", dtype=object)
    run_ids = np.full(shape, "", dtype=object)
    for index, (case, record) in cells.items():
        run_ids[index] = case.run_id
        for name, (_dtype, fill, *_rest) in CELL_VARIABLES.items():
            value = record.get(name, fill)
            arrays[name][index] = fill if value is None else value
        if record.get("status", -1) == -1:
            arrays["stable"][index] = -1
        impacts = record.get("impacts") or {}
        n = min(len(impacts.get("time", [])), k)
        imp_time[index][:n] = impacts["time"][:n] if n else []
        imp_impulse[index][:n] = impacts["impulse"][:n] if n else []
        imp_corner[index][:n] = impacts["corner"][:n] if n else []

    data: dict[str, xr.Variable] = {}
    for name in study.variables:
        dtype, _fill, units, long_name, extra = CELL_VARIABLES[name]
        data[name] = var(arrays[name], dims, units, long_name, **extra)
    data["run_id"] = var(run_ids, dims, "", "ledger key of the run (hash of its scene and the package version)")
    if k:
        idims = (*dims, "impact")
        data["impact_time"] = var(imp_time, idims, "s", "time of impact")
        data["impact_corner"] = var(imp_corner, idims, "", "corner struck (A, B, C, D)")
        data["impact_impulse"] = var(imp_impulse, idims, "N s", "normal impulse q")

    series_time = next((r["series"]["time"] for _c, r in cells.values() if r.get("series")), None)
    if series_time is not None:
        nt = len(series_time)
        for name, (units, long_name) in SERIES_VARIABLES.items():
            arr = np.full((*shape, nt), np.nan)
            for index, (_case, record) in cells.items():
                values_t = (record.get("series") or {}).get(name)
                if values_t is not None:
                    arr[index][: min(nt, len(values_t))] = values_t[:nt]
            data[name] = var(arr, (*dims, "time"), units, long_name)

    coords: dict[str, Any] = {a.dim: _coord(a, v) for a, v in zip(study.axes, values, strict=True)}
    if series_time is not None:
        coords["time"] = ("time", np.asarray(series_time), {"units": "s", "long_name": "time since steady flight"})
    if k:
        coords["impact"] = ("impact", np.arange(1, k + 1), {"long_name": "impact number (first impacts of a run)"})
    ds = xr.Dataset(data, coords=coords)
    ran = int(np.count_nonzero(arrays["status"] != NOT_RUN))
    ds.attrs.update(base_attrs(study.title))
    ds.attrs.update(study_attrs(study))
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
    low_name, high_name = ("stable", "unstable") if side == "below" else ("unstable", "stable")
    ds["boundary_lower"] = var(lower, other, axis.units, f"largest {axis.dim} on the {low_name} side of the boundary")
    ds["boundary_upper"] = var(upper, other, axis.units, f"smallest {axis.dim} on the {high_name} side of the boundary")
    ds.attrs["boundary_axis"] = axis.dim
    ds.attrs["boundary_method"] = method
    ds.attrs["boundary_stable_side"] = side


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
    stable = ds["stable"].transpose(*other, axis.dim).values
    lo, hi, mono = grid_boundary(stable, study.boundary.stable_side)
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
    ds.attrs["boundary_tolerance"] = study.boundary.tolerance
