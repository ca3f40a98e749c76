"""Numerical core: air-bearing film, slider rigid-body motion, contact.

Depends only on numpy, scipy and numba. Nothing here imports dask, xarray,
matplotlib or :mod:`pipeline`.
"""

__version__ = "0.1.0"
