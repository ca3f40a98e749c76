"""All numba settings in one place.

Every kernel is compiled with ``nopython=True, cache=True`` and no parallel
threads (studies parallelise over runs, one thread per dask worker).  Setting
the environment variable ``HDI_DISABLE_JIT=1`` before import runs the very
same kernels as plain Python, so the test-suite can check both paths.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

FASTMATH = {"contract", "arcp", "reassoc", "nsz"}
JIT_DISABLED = os.environ.get("HDI_DISABLE_JIT", "0") not in ("", "0", "false", "False")


def njit(func: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``func`` in nopython mode with an on-disk cache (identity if JIT is off)."""
    if JIT_DISABLED:
        return func
    import numba

    return numba.njit(cache=True, nogil=True, fastmath=FASTMATH)(func)
