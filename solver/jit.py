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
reproducible across processes that load the kernels from the cache, at no
measured cost; a process that compiled them itself still differs in the last
bits, so the pipeline compiles them in a child process first
(:func:`compile_apart`).
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
    numba.config.CACHE_DIR = str(cache_folder())


def cache_folder() -> Path:
    """The folder numba's cache of this version of the kernels lives in (:func:`_use_fingerprinted_cache`)."""
    base = os.environ.get("NUMBA_CACHE_DIR") or str(Path.home() / ".cache" / "hdi" / "numba")
    return Path(base) / kernels_fingerprint()


#: Set in the child interpreter of :func:`compile_apart` (which then compiles in place).
COMPILING_APART = "HDI_COMPILING_APART"


def compile_apart(name: str, statement: str, timeout: float = 3600.0, notify: Callable[[], None] | None = None) -> bool:
    """Have a child interpreter run ``statement`` (Python that calls kernels) once per version of the kernel
    sources, so that the kernels are compiled there and this process loads them from numba's cache; True when
    they were (now or before), False with the JIT off, inside the child, or when the child failed (a warning:
    this process then compiles them itself, as before).

    Why: the machine code of a kernel compiled in this process and that of the same kernel loaded from the cache
    differ in the last bits of some results (numba 0.68: the film's cut-link fluxes; after 30 us of the default
    scene-2 run the attitude differs by 2e-19 m, on a stuck pad by 2e-17 m, measured), so a study's records
    depended on whether the worker that ran them had compiled its kernels or loaded them, and a chaotic run
    taken again could part from its first record.  Processes that load from the cache run the same code: a
    marker ``<name>.apart`` in :func:`cache_folder` says that the child finished.  ``notify`` is called before a
    child starts (the command line says that it compiles).
    """
    if JIT_DISABLED or os.environ.get(COMPILING_APART):
        return False
    marker = cache_folder() / f"{name}.apart"
    if marker.exists():
        return True
    if notify is not None:
        notify()
    import subprocess
    import sys

    env = {**os.environ, COMPILING_APART: "1", "NUMBA_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", statement], env=env, capture_output=True, text=True, timeout=timeout)
    if done.returncode != 0:
        import warnings

        tail = (done.stderr or done.stdout).strip().splitlines()[-3:]
        warnings.warn(f"compiling the kernels apart ({name}) failed: {' | '.join(tail)}", RuntimeWarning, stacklevel=2)
        return False
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.write_text(statement + "\n")
    return True


def njit(func: Callable[..., Any] | None = None, *, inline: bool = False) -> Callable[..., Any]:
    """Compile ``func`` in nopython mode with an on-disk cache and IEEE division (identity if JIT is off).

    ``inline=True`` (as ``@njit(inline=True)``) has numba inline the function into its callers before LLVM
    sees them.  LLVM inlines small kernels on its own, but not a face flux with its slip law and Bernoulli
    function; a call left in a loop body keeps the loop from being vectorized
    (:mod:`solver.kernels.elementary`).
    """
    if func is None:
        return functools.partial(njit, inline=inline)
    if JIT_DISABLED:
        return func
    import numba

    _use_fingerprinted_cache(numba)
    options = {"inline": "always"} if inline else {}
    return numba.njit(cache=True, nogil=True, fastmath=FASTMATH, error_model="numpy", **options)(func)


def _bit_casts() -> tuple[Callable[[int], float], Callable[[float], int]]:
    """(float_from_bits, bits_of_float): the IEEE 754 binary64 reinterpretation of an int64 and back.

    In compiled kernels they are LLVM bitcasts (numba intrinsics), which vectorize; with the JIT off,
    ``struct`` does the same on Python numbers.
    """
    if JIT_DISABLED:
        import struct

        def float_from_bits(bits: int) -> float:
            return struct.unpack("<d", struct.pack("<q", int(bits)))[0]

        def bits_of_float(x: float) -> int:
            return struct.unpack("<q", struct.pack("<d", float(x)))[0]

        return float_from_bits, bits_of_float

    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def float_from_bits(typingctx, bits):  # noqa: ARG001 (numba's intrinsic signature)
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(types.float64))

        return types.float64(types.int64), codegen

    @intrinsic
    def bits_of_float(typingctx, x):  # noqa: ARG001
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(types.int64))

        return types.int64(types.float64), codegen

    return float_from_bits, bits_of_float


float_from_bits, bits_of_float = _bit_casts()
