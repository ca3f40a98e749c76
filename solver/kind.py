"""The type of a scene kind: what the rest of the code needs to know about a kind (see :mod:`solver.kinds`)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from .params import Section


@dataclass(frozen=True)
class SceneKind:
    """What a scene kind is: metadata and callables, no I/O.

    ``fly(scene)`` returns the steady flight; ``start(scene)`` the steady flight a run starts from (the same,
    or a documented fallback); ``simulate(scene, steady=None, **inputs)`` a flat result with ``t``, states,
    ``status``, ``message`` and ``work``.  ``seed_key`` names the parameter that seeds the scene's
    stochastic input (None: the kind is deterministic), so a study can run realisations of it.  ``tiny()`` is the
    cheapest scene of the kind that flies and runs (the
    kernels' warm-up, and the registry's tests).  ``steady_free`` names the keys a run may change and still reuse a
    steady flight: a section mapped to None is free as a whole, otherwise the listed keys of it are.
    """

    name: str
    title: str
    scene_type: type
    sections: dict[str, type[Section]]
    fly: Callable[..., Any]
    start: Callable[..., Any]
    simulate: Callable[..., Any]
    steady_free: Mapping[str, tuple[str, ...] | None]
    series: Mapping[str, tuple[str, str]]
    tiny: Callable[[], Any]
    seed_key: str | None
    warm_up: Callable[[], None]

    def steady_key(self, scene_dict: dict[str, Any]) -> str:
        """Hash of the parameters that decide the steady flight (two scenes with one key share it)."""
        data = {}
        for section, value in scene_dict.items():
            free = self.steady_free.get(section, ())
            if free is None:
                continue
            data[section] = {k: v for k, v in value.items() if k not in free} if isinstance(value, dict) else value
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
