"""Disk track profiles from and to files: CSV text and netCDF.

Readers return the solver's :class:`~solver.disk.DiskProfile` (positions
start at zero, the mean height is subtracted, non-uniform samples are
resampled: see :func:`solver.disk.profile_from_arrays`).

CSV (any file that is not netCDF): comma- or whitespace-separated numbers,
``#`` comments and blank lines ignored, the first line may be a header.
Either two columns, position [m] and height [m], or one column of heights
[m] with the sample step given as ``spacing=`` [m].

netCDF: a one-dimensional variable ``height`` whose dimension is a
coordinate named ``s`` or ``position`` (or, without coordinate values,
``spacing=``); ``units`` attributes "m", "mm", "um" (also "µm", "micron")
or "nm" are converted to metres and are required.  :func:`write_profile`
writes such a file with the profile's spacing and source as attributes;
reading it back gives the same spacing and heights, bit for bit.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import xarray as xr

from pipeline.data.netcdf import var, write_netcdf
from pipeline.provenance import base_attrs
from solver.disk import MIN_SAMPLES, DiskProfile, profile_from_arrays

#: Length units accepted in netCDF ``units`` attributes, in metres.
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "micron": 1e-6, "microns": 1e-6, "nm": 1e-9}

#: Names of the along-track coordinate, in order of preference.
POSITION_NAMES = ("s", "position")

NETCDF_MAGIC = (b"CDF\x01", b"CDF\x02", b"CDF\x05", b"\x89HDF\r\n\x1a\n")


def read_profile(path: str | Path, *, spacing: float | None = None) -> DiskProfile:
    """Read a track profile from a CSV or netCDF file (the format is recognised from the file's first bytes).

    spacing : float [m], optional
        Sample step for a single column of heights (CSV) or a ``height``
        variable without coordinate values (netCDF); an error otherwise.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    with path.open("rb") as f:
        head = f.read(8)
    if head.startswith(NETCDF_MAGIC):
        return _read_netcdf(path, spacing)
    return _read_csv(path, spacing)


def write_profile(profile: DiskProfile, path: str | Path) -> Path:
    """Write a profile to netCDF (atomically): ``height(s)`` [m], spacing and source in attributes."""
    ds = xr.Dataset(
        {"height": var(profile.heights, ("s",), "m", "disk height above the profile's mean plane")},
        coords={"s": ("s", profile.positions, {"units": "m", "long_name": "position along the track"})},
    )
    ds.attrs.update(base_attrs("Disk track profile"))
    ds.attrs.update(
        {
            "source": profile.source,
            "profile_spacing": profile.spacing,
            "profile_length": profile.length,
            "profile_rms": profile.rms,
            "comment": "periodic: the track closes after the last sample (period n * profile_spacing)",
        }
    )
    return write_netcdf(ds, path)


def _from_arrays(path: Path, positions: np.ndarray, heights: np.ndarray) -> DiskProfile:
    try:
        return profile_from_arrays(positions, heights, str(path))
    except ValueError as err:
        raise ValueError(f"{path}: not a usable profile: {err}") from None


def _uniform_positions(path: Path, n: int, spacing: float | None, what: str) -> np.ndarray:
    if spacing is None:
        raise ValueError(f"{path}: {what}; give the sample step as spacing= [m]")
    if not (np.isfinite(spacing) and spacing > 0.0):
        raise ValueError(f"{path}: spacing = {spacing!r} m must be finite and > 0")
    return np.arange(n) * float(spacing)


def _read_csv(path: Path, spacing: float | None) -> DiskProfile:
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a profile (neither a netCDF file nor a text CSV file)") from None
    rows: list[list[float]] = []
    header_seen = False
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = [f for f in re.split(r"[,;\s]+", line) if f]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows and not header_seen:
                header_seen = True  # one header line is allowed before the data
                continue
            raise ValueError(
                f"{path}: not a profile: line {number} ({line[:60]!r}) is not numbers "
                "(expected position [m], height [m] or a single height column)"
            ) from None
        if rows and len(values) != len(rows[0]):
            raise ValueError(f"{path}: line {number} has {len(values)} columns, the first data line {len(rows[0])}")
        rows.append(values)
    if not rows:
        raise ValueError(f"{path}: not a profile: no numeric data lines")
    data = np.array(rows)
    if data.shape[0] < MIN_SAMPLES:
        raise ValueError(f"{path}: not a usable profile: {data.shape[0]} samples, at least {MIN_SAMPLES} are needed")
    columns = data.shape[1]
    if columns == 1:
        positions = _uniform_positions(path, data.shape[0], spacing, "a single column of heights has no positions")
        return _from_arrays(path, positions, data[:, 0])
    if columns != 2:
        raise ValueError(f"{path}: not a profile: {columns} columns (expected position [m], height [m])")
    if spacing is not None:
        raise ValueError(f"{path}: spacing= is only for a single column of heights; this file has positions")
    return _from_arrays(path, data[:, 0], data[:, 1])


def _length_scale(path: Path, name: str, attrs: dict) -> float:
    units = attrs.get("units")
    if units is None:
        raise ValueError(f"{path}: variable {name!r} has no units attribute (one of {sorted(LENGTH_UNITS)})")
    key = str(units).strip()
    scale = LENGTH_UNITS.get(key, LENGTH_UNITS.get(key.lower()))
    if scale is None:
        raise ValueError(f"{path}: variable {name!r} has units {units!r}; expected one of {sorted(LENGTH_UNITS)}")
    return scale


def _read_netcdf(path: Path, spacing: float | None) -> DiskProfile:
    try:
        with xr.open_dataset(path, engine="netcdf4", decode_times=False) as opened:
            ds = opened.load()
    except (OSError, ValueError) as err:
        raise ValueError(f"{path}: not a readable netCDF file ({err})") from None
    if "height" not in ds.variables:
        raise ValueError(
            f"{path}: not a profile: no variable 'height' (the file has {sorted(map(str, ds.variables)) or 'none'})"
        )
    height = ds["height"]
    if height.ndim != 1:
        raise ValueError(f"{path}: variable 'height' has dimensions {height.dims}; expected one (s or position)")
    dim = str(height.dims[0])
    heights = height.values.astype(float) * _length_scale(path, "height", height.attrs)
    coordinate = next((name for name in POSITION_NAMES if name in ds.coords and ds[name].dims == (dim,)), None)
    if coordinate is None:
        positions = _uniform_positions(
            path, heights.size, spacing, f"variable 'height' has no coordinate named {' or '.join(POSITION_NAMES)}"
        )
    else:
        if spacing is not None:
            raise ValueError(f"{path}: spacing= is only for a 'height' without positions; this file has {coordinate!r}")
        positions = ds[coordinate].values.astype(float) * _length_scale(path, coordinate, ds[coordinate].attrs)
    stored_spacing = ds.attrs.get("profile_spacing")
    if stored_spacing is not None and coordinate is not None:
        # Written by write_profile: keep the exact spacing and heights (no resampling, no second mean removal).
        expected = np.arange(heights.size) * float(stored_spacing)
        if heights.size >= MIN_SAMPLES and np.allclose(
            positions, expected, rtol=1e-9, atol=1e-9 * float(stored_spacing)
        ):
            return DiskProfile(float(stored_spacing), heights, f"{path}: {ds.attrs.get('source', '')}")
    return _from_arrays(path, positions, heights)
