"""``hdi query``: select cells of a study dataset and print them as a table.

``--where`` takes a scene key or a dimension name with a value on its axis
(``contact.mu=0.5`` or ``mu=0.5``; floats match to 1e-9 of the axis span);
``--var`` chooses the variables.  The same selection in plain xarray:

    ds = xarray.open_dataset("results/fig17.nc", decode_times=False)
    ds[["stable", "n_impacts"]].sel(mu=0.5, zdot0=-0.01).to_dataframe()
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.config import ConfigError, parse_override
from pipeline.data.netcdf import open_result
from pipeline.data.sampling import report_text
from pipeline.data.units import display_scale
from pipeline.kinds import adapter_of
from pipeline.study.spec import REALIZATION


class QueryError(ConfigError):
    """A selection that does not fit the dataset."""


def _dim_of(ds: xr.Dataset, key: str) -> str:
    if key in ds.dims:
        return key
    for dim in ds.dims:
        if ds[dim].attrs.get("scene_key") == key:
            return str(dim)
    axes = ", ".join(f"{d} ({ds[d].attrs.get('scene_key', '')})" for d in ds.dims if "scene_key" in ds[d].attrs)
    raise QueryError(f"--where {key}: not an axis of this study (axes: {axes})")


def select(ds: xr.Dataset, where: list[str]) -> xr.Dataset:
    """Cells of ``ds`` matching every KEY=VALUE of ``where``."""
    for item in where:
        key, value = parse_override(item)
        dim = _dim_of(ds, key)
        coord = ds[dim].values
        if coord.dtype.kind in "fiu":
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise QueryError(f"--where {item}: {dim} takes a number")
            span = float(np.ptp(coord)) or 1.0
            hit = np.flatnonzero(np.abs(coord - value) <= 1e-9 * span)
        else:
            hit = np.flatnonzero(coord == value)
        if hit.size == 0:
            raise QueryError(f"--where {item}: {value!r} is not on the {dim} axis (values: {coord.tolist()})")
        ds = ds.isel({dim: hit})
    return ds


def table(ds: xr.Dataset, where: list[str], variables: list[str] | None = None) -> str:
    """The selected cells as a text table, one row per cell."""
    cells = select(ds, where)
    names = variables or [v for v in adapter_of(ds).study_outputs if v in ds and v != "message"]
    for name in names:
        if name not in ds.data_vars:
            raise QueryError(f"--var {name}: no such variable (variables: {', '.join(map(str, ds.data_vars))})")
    stats = [n for n in names if f"{n}_mean" in cells]
    category = adapter_of(ds).category
    shares = category if category in names and f"{category}_fraction" in cells else None
    if REALIZATION in cells.dims and (stats or shares):
        return _mean_table(cells, stats, shares)
    frame = cells[names].to_dataframe()
    frame = frame[[n for n in names if n in frame.columns]]
    return frame.to_string()


def _mean_table(cells: xr.Dataset, names: list[str], category: str | None = None) -> str:
    """One row per cell of the other axes: each variable as mean +- 95 % half-width over the realisations, and
    the shares of the category's values among them (``regime_fraction``: "intermittent_contact 0.75, ...")."""
    n = cells.sizes[REALIZATION]
    columns = {}
    index = None
    if category is not None:
        fraction = cells[f"{category}_fraction"]
        labels = fraction[f"{category}s"].values
        cell_dims = [d for d in fraction.dims if d != f"{category}s"]
        flat = fraction.transpose(*cell_dims, f"{category}s").values.reshape(-1, labels.size)
        columns[f"{category} (fraction of realisations)"] = [
            ", ".join(f"{lab} {f:.2f}" for lab, f in zip(labels, row, strict=True) if f > 0) or "none classified"
            for row in flat
        ]
        index = cells[f"{category}_count"].to_series().index
    for name in names:
        mean = cells[f"{name}_mean"].to_series()
        half = cells[f"{name}_ci95"].to_series()
        scale, shown = display_scale(cells[name].attrs.get("units", ""), mean.values)
        columns[f"{name} [{shown}]"] = [
            f"{m * scale:.4g} +- {h * scale:.2g}" for m, h in zip(mean.values, half.values, strict=True)
        ]
        index = mean.index
    frame = pd.DataFrame(columns, index=_display_index(cells, index))
    return f"mean +- half-width of the 95 % confidence interval over {n} realisations\n" + frame.to_string()


def _display_index(ds: xr.Dataset, index: pd.Index) -> pd.Index:
    """The cells' coordinates in display units, to 4 significant digits, named "dim [unit]" (dt [us], rms [nm])."""
    names = list(index.names)
    levels = [index.get_level_values(k) for k in range(len(names))]
    shown_levels, shown_names = [], []
    for name, level in zip(names, levels, strict=True):
        coord = ds[name] if name in ds.coords else None
        if coord is None or coord.dtype.kind not in "fiu":
            shown_levels.append(list(level))
            shown_names.append(name)
            continue
        scale, unit = display_scale(coord.attrs.get("units", ""), coord.values)
        shown_levels.append([float(f"{v * scale:.4g}") for v in level])
        shown_names.append(f"{name} [{unit}]" if unit != "1" else name)
    if len(names) == 1:
        return pd.Index(shown_levels[0], name=shown_names[0])
    return pd.MultiIndex.from_arrays(shown_levels, names=shown_names)


def query(path: str | Path, where: list[str], variables: list[str] | None = None) -> str:
    ds = open_result(path)
    if "study" not in ds.attrs:
        raise QueryError(f"{path}: not a study dataset (written by 'hdi run')")
    text = table(ds, where, variables)
    if "se_slope_range" in ds and not where:
        text += "\n\n" + report_text(ds)
    return text


def _index(index) -> str:
    """A table row's coordinates, numbers to 4 significant digits."""
    values = index if isinstance(index, tuple) else (index,)
    return " ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in values)


def boundary_table(ds: xr.Dataset) -> str:
    """The bracket per line, floats to 4 significant digits (a corner radius in metres stays readable)."""
    names = [n for n in ("boundary_lower", "boundary_upper", "boundary_runs", "boundary_monotonic") if n in ds]
    text = ds[names].to_dataframe()[names].to_string(float_format=lambda x: f"{x:.4g}")
    if "boundary_mean" in ds:  # one line per track: the mean over the tracks with its 95 % half-width
        rows = ds[["boundary_mean", "boundary_ci95", "boundary_closed"]].to_dataframe()
        text += (
            f"\n\nover the {ds.sizes['realization']} tracks (mean +- 95 % half-width; NaN where a track's "
            "bracket is open)\n"
        )
        text += "\n".join(f"{_index(index):>24}  {row.boundary_mean:.4g} +- {row.boundary_ci95:.2g}   "
                          f"closed {int(row.boundary_closed)}" for index, row in rows.iterrows())  # fmt: skip
    return text
