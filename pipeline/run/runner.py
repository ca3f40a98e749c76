"""One case of a study: a pure, picklable call that returns plain data.

:func:`run_case` runs on a dask worker (or in the client for the synchronous path): it builds the scene from a
plain dict, takes its kind's steady flight (cached per process and shared by every case that differs only in
keys the kind declares free of it, e.g. all 462 runs of Figure 17), integrates the run and returns the kind's
record (its classification, work counters, and what a study keeps of the run) as a JSON-ready dict.  It never
raises for a failing run and never writes files: an exception becomes a record with status -1 and the message.
"""

from __future__ import annotations

import logging
import os
import socket
import time
import traceback
from typing import Any

log = logging.getLogger(__name__)

#: Steady flights kept per process (each a film solution: a few MB at most).
STEADY_CACHE_SIZE = 8
_steady_cache: dict[str, Any] = {}


def steady_flight(kind: Any, scene: Any) -> Any:
    """The steady flight a run of ``scene`` starts from, computed once per process for equal steady keys."""
    key = f"{kind.name}:{kind.steady_key(scene.to_dict())}"
    if key not in _steady_cache:
        if len(_steady_cache) >= STEADY_CACHE_SIZE:
            _steady_cache.clear()
        _steady_cache[key] = kind.start(scene)
    return _steady_cache[key]


def run_case(scene_dict: dict[str, Any], run_id: str, impacts_kept: int = 20) -> dict[str, Any]:
    """Fly and integrate one scene; a JSON-ready record (status -1 and the message if anything failed)."""
    wall0 = time.perf_counter()
    record: dict[str, Any] = {"run_id": run_id, "worker": f"{socket.gethostname()}:{os.getpid()}"}
    try:
        from solver.kinds import scene_from_dict

        from ..kinds import adapter_of

        scene = scene_from_dict(scene_dict, source=f"run {run_id}")
        adapter = adapter_of(scene)
        kind = adapter.solver
        result = kind.simulate(scene, steady=steady_flight(kind, scene), **adapter.run_inputs(scene))
        record.update(adapter.record(scene, result, impacts_kept))
    except Exception as err:  # a failing run is a result, never the end of the study
        log.warning("run %s failed: %s", run_id, err)
        record.update(status=-1, message=f"{type(err).__name__}: {err}", traceback=traceback.format_exc(limit=6))
    record["wall_time"] = time.perf_counter() - wall0
    return record


def warm_up(names: tuple[str, ...] | None = None) -> float:
    """Load the numba kernels of the kinds ``names`` (None: every kind) on one thread, compiled first in a child
    process if this version of them has not been (:func:`solver.jit.compile_apart`: a process that compiles its
    kernels itself differs from one that loads them in the last bits); returns the seconds it took."""
    from solver.kinds import get_kind, kinds

    os.environ["NUMBA_NUM_THREADS"] = "1"
    t0 = time.perf_counter()
    names = tuple(names or kinds())
    compile_kernels(names)
    for name in names:
        get_kind(name).warm_up()
    return time.perf_counter() - t0


def compile_kernels(names: tuple[str, ...] | None = None, quiet: bool = False) -> bool:
    """Compile the numba kernels of the kinds ``names`` (None: every kind) in a child process, once per version of
    them, without loading them here (:func:`solver.jit.compile_apart`); True when they are compiled.  Says so on
    stderr when it compiles, unless ``quiet``."""
    import sys

    from solver.jit import compile_apart
    from solver.kinds import kinds

    names = tuple(sorted(names or kinds()))

    def notify() -> None:
        if not quiet:
            print(f"compiling the numba kernels ({', '.join(names)}) once for this version of the code: about a "
                  "minute a kind", file=sys.stderr, flush=True)  # fmt: skip

    statement = f"from pipeline.run.runner import warm_up; warm_up({names!r})"
    return compile_apart(f"warm-up-{'-'.join(names)}", statement, notify=notify)
