"""All numba settings in one place.

Every kernel is compiled with ``nopython=True, cache=True`` and no parallel
threads (studies parallelise over runs, one thread per dask worker).  Setting
the environment variable ``HDI_DISABLE_JIT=1`` before import runs the very
same kernels as plain Python, so the test-suite can check both paths.

Division follows IEEE 754 (``error_model="numpy"``: x / 0 gives inf or nan
instead of raising ZeroDivisionError).  Without the per-division check the
inner loops vectorize; a film that goes non-finite is caught by the time
stepper, which checks the forces after every step.

Fast-math allows fused multiply-adds, reciprocal multiplication and ignores
the sign of zero, but not reassociation: with ``reassoc`` a kernel compiled
in this process and the same kernel loaded from numba's cache gave results
differing in the last bits (measured), so a study's dataset would depend on
which worker had compiled its kernels.  Without it, runs are bitwise
reproducible across processes, at no measured cost.
"""

from __future__ import annotations

import functools
import hashlib
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

FASTMATH = {"contract", "arcp", "nsz"}
JIT_DISABLED = os.environ.get("HDI_DISABLE_JIT", "0") not in ("", "0", "false", "False")


def source_fingerprint(paths: Iterable[str | Path]) -> str:
    """SHA-256 (hex) of the names and contents of source files, in the order given.

    The one fingerprint of code the solver uses: numba's cache folder (:func:`kernels_fingerprint`) and the
    keys of the tables the air-bearing models store (:mod:`solver.rails.bearings`), so that an edit to any
    file behind a cached result invalidates it.
    """
    digest = hashlib.sha256()
    for path in map(Path, paths):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


@functools.cache
def kernels_fingerprint() -> str:
    """Hash of every kernel module (and this one): the name of the on-disk cache the kernels compile into."""
    here = Path(__file__).resolve().parent
    return source_fingerprint([here / "jit.py", *sorted((here / "kernels").glob("*.py"))])[:16]


def _use_fingerprinted_cache(numba: Any) -> None:
    """Point numba's cache at a folder named after :func:`kernels_fingerprint`.

    numba checks only a kernel's own source file before reusing its cached
    machine code, not the kernels it calls and inlines: after an edit to
    ``kernels/slip.py`` the film kernels kept running the old flow factor
    (found by tests/test_abs.py).  A cache folder per version of the kernel
    sources makes any edit recompile everything.  NUMBA_CACHE_DIR, when set,
    is the parent folder.
    """
    base = os.environ.get("NUMBA_CACHE_DIR") or str(Path.home() / ".cache" / "hdi" / "numba")
    numba.config.CACHE_DIR = str(Path(base) / kernels_fingerprint())


def njit(func: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``func`` in nopython mode with an on-disk cache and IEEE division (identity if JIT is off)."""
    if JIT_DISABLED:
        return func
    import numba

    _use_fingerprinted_cache(numba)
    return numba.njit(cache=True, nogil=True, fastmath=FASTMATH, error_model="numpy")(func)
