"""Results as self-describing xarray Datasets, written atomically to netCDF.

Every variable carries ``units`` and ``long_name``; categories are integer
flags with ``flag_values``/``flag_meanings``; global attributes hold the
CF conventions, provenance and the complete scene as TOML text.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from solver.rails.geometry import CORNERS
from solver.rails.integrate import Result
from solver.rails.params import Scene
from solver.rails.steady import SteadyFlight

from .classify import classify_impulses
from .config import scene_hash, scene_toml
from .provenance import base_attrs

STATUS_FLAGS = {"flag_values": np.array([-1, 0, 1], dtype=np.int8), "flag_meanings": "failed completed stopped"}
STABLE_FLAGS = {"flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "unstable stable"}


def var(data: Any, dims: tuple[str, ...], units: str, long_name: str, **attrs: Any) -> xr.Variable:
    return xr.Variable(dims, np.asarray(data), attrs={"units": units, "long_name": long_name, **attrs})


def steady_variables(steady: SteadyFlight, prefix: str = "") -> dict[str, xr.Variable]:
    """Scalars of a steady flight (prefix '' for fly files, 'steady_' inside run files)."""
    p = prefix
    sus = steady.suspension
    return {
        f"{p}z": var(steady.z, (), "m", "gimbal height above the asperity base plane"),
        f"{p}pitch": var(steady.pitch, (), "rad", "pitch (positive: leading edge up)"),
        f"{p}roll": var(steady.roll, (), "rad", "roll (positive: x2 < 0 side up)"),
        f"{p}min_spacing": var(steady.min_spacing, (), "m", "minimum spacing over the rails"),
        f"{p}min_spacing_x1": var(steady.min_spacing_x1, (), "m", "x1 of the minimum spacing"),
        f"{p}min_spacing_x2": var(steady.min_spacing_x2, (), "m", "x2 of the minimum spacing"),
        f"{p}load": var(steady.load, (), "N", "air-bearing load Q"),
        f"{p}centre_of_pressure_x1": var(steady.centre_of_pressure[0], (), "m", "centre of pressure x1 (S1)"),
        f"{p}bearing_number": var(
            steady.bearing_number, (), "1", "bearing number 6 eta V L / (p0 h_min^2), L = rail length"
        ),
        f"{p}preload": var(sus.preload, (), "N", "preload in force (after calibration)"),
        f"{p}static_pitch_moment": var(
            sus.static_pitch_moment, (), "N m", "static suspension pitch moment in force (after calibration)"
        ),
        f"{p}static_roll_moment": var(sus.static_roll_moment, (), "N m", "static suspension roll moment in force"),
    }


def scene_attrs(scene: Scene) -> dict[str, str]:
    return {"scene": scene.name, "scene_toml": scene_toml(scene), "scene_hash": scene_hash(scene)}


def fly_dataset(steady: SteadyFlight, scene: Scene, work: dict[str, float] | None = None) -> xr.Dataset:
    """Steady flight: attitude, minimum spacing, loads and the pressure field."""
    data = steady_variables(steady)
    data["corner_spacing"] = var(steady.corner_spacings, ("corner",), "m", "spacing at the flat corners")
    nr = steady.pressure.shape[0]
    data["pressure"] = var(steady.pressure, ("rail", "x1", "x2_local"), "Pa", "air-bearing pressure")
    coords = {
        "corner": ("corner", np.array(CORNERS), {"long_name": "flat corner (A front-left .. D rear-right)"}),
        "rail": ("rail", np.arange(nr), {"long_name": "rail (0: x2 < 0, 1: x2 > 0)"}),
        "x1": ("x1", steady.x1, {"units": "m", "long_name": "position along the slider (disk motion direction)"}),
        "x2_local": (
            "x2_local",
            steady.x2[0] - steady.x2[0].mean() if nr else np.zeros(0),
            {"units": "m", "long_name": "position across a rail from its centre line"},
        ),
        "x2": (("rail", "x2_local"), steady.x2, {"units": "m", "long_name": "position across the slider"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds["newton_iterations"] = var(steady.newton_iterations, (), "1", "Newton iterations (steady Reynolds)")
    ds["reynolds_solves"] = var(steady.reynolds_solves, (), "1", "steady Reynolds solves")
    if work:
        ds["wall_time"] = var(work.get("wall_time", np.nan), (), "s", "wall time of the steady solve")
    ds.attrs.update(base_attrs(f"Steady flight of scene {scene.name}"))
    ds.attrs.update(scene_attrs(scene))
    return ds


def run_summary(result: Result) -> dict[str, Any]:
    """Plain scalars of one run: classification, status and work (picklable, for studies)."""
    impulses = np.array([i.impulse for i in result.impacts])
    corners = np.array([i.corner for i in result.impacts], dtype=int)
    growth = classify_impulses(impulses, corners, [i.time for i in result.impacts])
    return {**growth.as_dict(), "status": result.status, "message": result.message, **result.work}


def run_dataset(result: Result, scene: Scene) -> xr.Dataset:
    """One run: time series, impacts on their own dimension, classification, provenance."""
    summary = run_summary(result)
    imp = result.impacts
    data: dict[str, xr.Variable] = {
        "z": var(result.q[:, 0], ("time",), "m", "gimbal height above the asperity base plane"),
        "pitch": var(result.q[:, 1], ("time",), "rad", "pitch (positive: leading edge up)"),
        "roll": var(result.q[:, 2], ("time",), "rad", "roll (positive: x2 < 0 side up)"),
        "zdot": var(result.v[:, 0], ("time",), "m s-1", "vertical velocity of the gimbal"),
        "pitch_rate": var(result.v[:, 1], ("time",), "rad s-1", "pitch rate"),
        "roll_rate": var(result.v[:, 2], ("time",), "rad s-1", "roll rate"),
        "min_spacing": var(result.min_spacing, ("time",), "m", "minimum spacing (lowest flat corner)"),
        "corner_spacing": var(result.corner_spacing, ("time", "corner"), "m", "spacing at the flat corners"),
        "air_load": var(result.air_force[:, 0], ("time",), "N", "air-bearing load Q"),
        "impact_time": var([i.time for i in imp], ("impact",), "s", "time of impact"),
        "impact_corner": var(
            np.array([i.corner_letter for i in imp], dtype="U1"), ("impact",), "", "corner struck (A, B, C, D)"
        ),
        "impact_impulse": var([i.impulse for i in imp], ("impact",), "N s", "normal impulse q"),
        "impact_approach_before": var(
            [i.approach_before for i in imp], ("impact",), "m s-1", "relative normal approach velocity U + eps V before"
        ),
        "impact_approach_after": var(
            [i.approach_after for i in imp], ("impact",), "m s-1", "relative normal approach velocity U + eps V after"
        ),
        "stable": var(np.int8(summary["stable"]), (), "1", "impulse-growth classification", **STABLE_FLAGS),
        "n_impacts": var(summary["n_impacts"], (), "1", "number of impacts"),
        "n_larger_than_first": var(summary["n_larger_than_first"], (), "1", "impacts larger than the first"),
        "n_front_corner_impacts": var(summary["n_front_corner_impacts"], (), "1", "impacts at the front corners A, C"),
        "first_impulse": var(summary["first_impulse"], (), "N s", "first impulse"),
        "max_impulse_ratio": var(summary["max_impulse_ratio"], (), "1", "largest later impulse / first impulse"),
        "status": var(np.int8(result.status), (), "1", "run status", **STATUS_FLAGS),
        "steps": var(result.work["steps"], (), "1", "time steps taken"),
        "reynolds_solves": var(result.work["reynolds_solves"], (), "1", "time-dependent Reynolds solves"),
        "newton_iterations": var(result.work["newton_iterations"], (), "1", "Newton iterations"),
        "wall_time": var(result.work["wall_time"], (), "s", "wall time of the run"),
    }
    data.update(steady_variables(result.steady, prefix="steady_"))
    coords = {
        "time": ("time", result.t, {"units": "s", "long_name": "time since the disturbance"}),
        "corner": ("corner", np.array(CORNERS), {"long_name": "flat corner (A front-left .. D rear-right)"}),
        "impact": ("impact", np.arange(len(imp)), {"long_name": "impact number"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(base_attrs(f"Contact dynamics of scene {scene.name}"))
    ds.attrs.update(scene_attrs(scene))
    ds.attrs["status_message"] = result.message
    return ds


#: Names CF-1.8 allows for variables and attributes (section 2.3).
CF_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: CF time units need an epoch (section 4.4); times here are relative to the start of a run or of the
#: steady flight, and this epoch stands for that instant (said in each time coordinate's comment).
TIME_UNITS = "seconds since 1970-01-01 00:00:00"
#: Suffix of the auxiliary coordinate that carries a string-valued dimension's labels on disk: CF coordinate
#: variables must be numeric and monotonic (section 5), labels are auxiliary coordinates (section 6.1).
LABEL_SUFFIX = "_label"
_INT32 = np.iinfo(np.int32)


def cf_encode(ds: xr.Dataset) -> tuple[xr.Dataset, dict[str, dict[str, Any]]]:
    """The dataset as CF-1.8 wants it on disk, and its netCDF encoding.

    - 64-bit integers become int32 (CF-1.8 section 2.2 data types), booleans int8; a value outside int32 is an
      error rather than a silent wrap;
    - coordinate variables carry no ``_FillValue`` (section 2.5.1);
    - a ``time`` coordinate gets ``standard_name``, ``axis`` and units with an epoch (section 4.4);
    - a string-valued dimension coordinate is written as the auxiliary coordinate ``<dim>_label``
      (``open_result`` restores it as the index);
    - a global attribute whose name CF does not allow is an error: such data belongs in a variable.
    """
    bad = [k for k in ds.attrs if not CF_NAME.match(k)]
    if bad:
        raise ValueError(f"global attribute names {bad} are not allowed in CF-1.8: letters, digits and '_' only")
    ds = ds.copy()
    labels = [d for d in ds.dims if d in ds.coords and ds[d].dtype.kind in "OUS"]
    for dim in labels:
        ds = ds.rename_vars({dim: f"{dim}{LABEL_SUFFIX}"}).drop_indexes(f"{dim}{LABEL_SUFFIX}", errors="ignore")
    for name, v in ds.variables.items():
        if v.dtype.kind == "b":
            ds[name] = v.astype(np.int8)
        elif v.dtype.kind in "iu" and v.dtype.itemsize == 8:
            if v.size and (int(v.min()) < _INT32.min or int(v.max()) > _INT32.max):
                raise ValueError(f"variable {name} has values outside int32, which CF-1.8 files here use")
            ds[name] = v.astype(np.int32)
    if "time" in ds.coords and ds["time"].dtype.kind == "f":
        attrs = dict(ds["time"].attrs)
        if attrs.get("units") in ("s", TIME_UNITS):
            attrs.update(
                units=TIME_UNITS,
                standard_name="time",
                axis="T",
                calendar="standard",
                comment="seconds from the start of the record; the epoch of the units stands for that instant",
            )
            ds["time"].attrs = attrs
    encoding: dict[str, dict[str, Any]] = {}
    for name, v in ds.variables.items():
        enc: dict[str, Any] = {}
        if name in ds.coords:
            enc["_FillValue"] = None
        elif v.dtype.kind in "fiu" and v.ndim > 0:
            enc.update(zlib=True, complevel=4)
        if enc:
            encoding[name] = enc
    return ds, encoding


def write_netcdf(ds: xr.Dataset, path: str | Path) -> Path:
    """Write atomically (a temporary file in the same folder, then os.replace), encoded by ``cf_encode``."""
    path = Path(path)
    ds, encoding = cf_encode(ds)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; results are for sharing
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def open_result(path: str | Path) -> xr.Dataset:
    """Open a file written by this project (loaded into memory, file closed)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
            loaded = ds.load()
    except (OSError, ValueError) as err:
        raise ValueError(f"{path}: not a netCDF file written by hdi ({err})") from None
    if "package_version" not in loaded.attrs:
        raise ValueError(f"{path}: not a netCDF file written by hdi (no package_version attribute)")
    for name in [n for n in loaded.coords if str(n).endswith(LABEL_SUFFIX)]:
        dim = str(name)[: -len(LABEL_SUFFIX)]
        if loaded[name].dims == (dim,) and dim not in loaded.coords:
            attrs = loaded[name].attrs
            loaded = loaded.drop_vars(name).assign_coords({dim: (dim, loaded[name].values.astype(str), attrs)})
    return loaded
