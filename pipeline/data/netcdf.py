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

from pipeline.config import scene_hash, scene_toml
from pipeline.provenance import base_attrs


def var(data: Any, dims: tuple[str, ...], units: str, long_name: str, **attrs: Any) -> xr.Variable:
    return xr.Variable(dims, np.asarray(data), attrs={"units": units, "long_name": long_name, **attrs})


def scene_attrs(scene: Any) -> dict[str, str]:
    """The scene's name, every parameter as TOML text and its hash."""
    return {"scene": scene.name, "scene_toml": scene_toml(scene), "scene_hash": scene_hash(scene)}


#: What a file holds (``attrs["product"]``): a figure or a reader looks it up, it never guesses.
PRODUCTS = ("fly", "run", "study", "bench", "ladder")


def product_attrs(title: str, scene: Any, product: str) -> dict[str, str]:
    """Global attributes of a file about one scene: provenance, the scene, its kind and the product."""
    if product not in PRODUCTS:
        raise ValueError(f"product = {product!r}: must be one of {', '.join(PRODUCTS)}")
    return {**base_attrs(title), **scene_attrs(scene), "scene_kind": scene.kind, "product": product}


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
