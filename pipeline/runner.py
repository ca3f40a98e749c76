"""One case of a study: a pure, picklable call that returns plain data.

:func:`run_case` runs on a dask worker (or in the client for the synchronous
path): it builds the scene from a plain dict, flies it (the steady flight is
cached per process and shared by every case that differs only in contact
and initial values, e.g. all 462 runs of Figure 17), integrates the run and
returns the classification, work counters and the first impacts as a
JSON-ready dict.  It never raises for a failing run and never writes files:
an exception becomes a record with status -1 and the message.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import socket
import time
import traceback
from typing import Any

log = logging.getLogger(__name__)

# Keys that do not change the steady flight (the run's disturbance, contact law and stepping).
_NOT_STEADY = {
    "contact": None,
    "initial": None,
    "numerics": ("dt", "t_end", "output_interval", "newton_max_iter", "newton_tol"),
}
_steady_cache: dict[str, Any] = {}


def steady_key(scene_dict: dict[str, Any]) -> str:
    data = {}
    for section, value in scene_dict.items():
        drop = _NOT_STEADY.get(section, ())
        if drop is None:
            continue
        data[section] = {k: v for k, v in value.items() if k not in drop} if isinstance(value, dict) else value
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


def _steady(scene):
    from solver.rails.steady import fly

    key = steady_key(scene.to_dict())
    if key not in _steady_cache:
        if len(_steady_cache) > 8:
            _steady_cache.clear()
        _steady_cache[key] = fly(scene)
    return _steady_cache[key]


def run_case(scene_dict: dict[str, Any], run_id: str, impacts_kept: int = 20) -> dict[str, Any]:
    """Fly and integrate one scene; a JSON-ready record (status -1 and the message if anything failed)."""
    from solver.kinds import scene_from_dict

    wall0 = time.perf_counter()
    record: dict[str, Any] = {"run_id": run_id, "worker": f"{socket.gethostname()}:{os.getpid()}"}
    if scene_dict.get("kind") == "abs":
        return _run_abs_case(scene_dict, run_id, record, wall0)
    try:
        from solver.rails.integrate import simulate

        from .classify import classify_impulses

        scene = scene_from_dict(scene_dict, source=f"run {run_id}")
        result = simulate(scene, steady=_steady(scene))
        impacts = result.impacts
        growth = classify_impulses(
            [i.impulse for i in impacts],
            [i.corner for i in impacts],
            [i.time for i in impacts],
        )
        record.update(growth.as_dict())
        record.update(
            status=int(result.status),
            message=result.message,
            first_impact_time=impacts[0].time if impacts else float("nan"),
            steps=int(result.work["steps"]),
            newton_iterations=int(result.work["newton_iterations"]),
            impacts={
                "time": [i.time for i in impacts[:impacts_kept]],
                "corner": [i.corner_letter for i in impacts[:impacts_kept]],
                "impulse": [i.impulse for i in impacts[:impacts_kept]],
            },
        )
    except Exception as err:  # a failing run is a result, never the end of the study
        log.warning("run %s failed: %s", run_id, err)
        record.update(
            status=-1,
            message=f"{type(err).__name__}: {err}",
            traceback=traceback.format_exc(limit=6),
        )
    record["wall_time"] = time.perf_counter() - wall0
    return record


#: Keys of an "abs" scene that do not change its steady flight.
_ABS_NOT_STEADY = {
    "initial": None,
    "numerics": ("dt", "t_end", "settle_time", "output_interval", "rho_infinity",
                 "newton_tol", "newton_max_iter", "contact_threshold"),
    "disk": ("correlation_length", "acf", "seed", "profile_file", "profile_spacing"),
}  # fmt: skip
_abs_steady_cache: dict[str, Any] = {}

#: Time series of an "abs" run kept in a study's record (and so in its dataset), every SERIES_EVERY samples.
ABS_SERIES = ("flying_height", "contact_force")


def abs_steady_key(scene_dict: dict[str, Any]) -> str:
    data = {}
    for section, value in scene_dict.items():
        drop = _ABS_NOT_STEADY.get(section, ())
        if drop is None:
            continue
        data[section] = {k: v for k, v in value.items() if k not in drop} if isinstance(value, dict) else value
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


def abs_profile(scene):
    """The measured track profile of a scene (None for a synthetic one): read in the pipeline, not the solver."""
    if not scene.disk.profile_file:
        return None
    from .profiles import read_profile

    return read_profile(scene.disk.profile_file)


def _run_abs_case(scene_dict: dict[str, Any], run_id: str, record: dict[str, Any], wall0: float) -> dict[str, Any]:
    from solver.kinds import scene_from_dict

    try:
        from solver.abs.integrate import simulate_abs, summarize
        from solver.abs.steady import fly_start

        scene = scene_from_dict(scene_dict, source=f"run {run_id}")
        key = abs_steady_key(scene.to_dict())
        if key not in _abs_steady_cache:
            if len(_abs_steady_cache) > 8:
                _abs_steady_cache.clear()
            _abs_steady_cache[key] = fly_start(scene)
        steady = _abs_steady_cache[key]
        result = simulate_abs(scene, steady=steady, profile=abs_profile(scene))
        record.update(summarize(result, scene))
        record.update(
            status=int(result.status),
            message=result.message,
            steps=int(result.work["steps"]),
            newton_iterations=int(result.work["newton_iterations"]),
            steady_flying_height=steady.element_spacing,
            steady_pitch=float(steady.q[1]),
            steady_roll=float(steady.q[2]),
            steady_contact_force=steady.surface.contact,
            steady_note=steady.note,
            series={"time": result.t.tolist(), **{k: result.series[k].tolist() for k in ABS_SERIES}},
        )
    except Exception as err:  # a failing run is a result, never the end of the study
        log.warning("run %s failed: %s", run_id, err)
        record.update(status=-1, message=f"{type(err).__name__}: {err}", traceback=traceback.format_exc(limit=6))
    record["wall_time"] = time.perf_counter() - wall0
    return record


def warm_up() -> float:
    """Load (or compile) every numba kernel a run uses, on a tiny scene; returns the seconds it took."""
    os.environ["NUMBA_NUM_THREADS"] = "1"
    t0 = time.perf_counter()
    from solver.kinds import scene_from_dict
    from solver.rails.integrate import simulate

    scene = scene_from_dict(
        {"numerics": {"nx": 21, "nx_taper": 5, "ny": 5, "dt": 1e-7, "t_end": 3e-7, "output_interval": 1e-7}},
        source="warm-up",
    )
    simulate(scene)
    _warm_force_models()
    return time.perf_counter() - t0


def _warm_force_models() -> None:
    """Load the reduced air-bearing levels' kernels (quasi_static, linearized) on dummy arrays."""
    import numpy as np

    from solver.kernels import forcemodels as kf
    from solver.kernels import motion as km

    axis = np.linspace(0.0, 1.0, 4)
    q, v, acc, f = np.full(3, 0.5), np.zeros(3), np.zeros(3), np.zeros(3)
    eye, sus = np.eye(3), np.zeros(5)
    kf.verlet_step_table(1e-9, q, v, acc, f, eye, sus, np.zeros((4, 4, 4, 3)), axis, axis, axis)
    kf.verlet_step_linear(1e-9, q, v, acc, f, eye, sus, np.zeros(3), np.zeros(3), eye, eye)
    km.spacing_error(np.ones((4, 3)), np.ones(4, dtype=np.bool_), np.zeros(3), 1e-9)
