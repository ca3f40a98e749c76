"""Scene kinds: one :class:`SceneKind` per kind, looked up by the scene file's top-level ``kind`` key.

A kind bundles what the rest of the code needs to know about it: its parameter sections and scene type, how
to fly it (the steady flight) and simulate it (a run from that flight), which scene keys a run may change and
still reuse a steady flight, the units of its time series, and how to load its numba kernels on a worker.
Adding a kind is a sub-package of :mod:`solver` with a ``kind.py`` that defines ``KIND`` (a
:class:`solver.kind.SceneKind`), and one line in :func:`kinds` below (plus its adapter in :mod:`pipeline.kinds`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from .kind import SceneKind
from .params import ParameterError, Section

#: The kind of a scene file that does not say.
DEFAULT_KIND = "rails"


def kinds() -> dict[str, SceneKind]:
    """Every scene kind by name (imported on first use: a kind's module loads its solver)."""
    from .abs.kind import KIND as ABS
    from .rails.kind import KIND as RAILS

    return {k.name: k for k in (RAILS, ABS)}


def get_kind(name: str, source: str = "") -> SceneKind:
    """The kind called ``name``; an unknown name is an error that lists the kinds."""
    registry = kinds()
    if name not in registry:
        where = f" in {source}" if source else ""
        raise ParameterError(f"kind = {name!r}{where} is not allowed: must be one of {', '.join(map(repr, registry))}")
    return registry[name]


def kind_of(scene_or_dict: Any) -> SceneKind:
    """The kind of a scene object or of a scene dict (its ``kind`` key, default "rails")."""
    if isinstance(scene_or_dict, dict):
        return get_kind(scene_or_dict.get("kind", DEFAULT_KIND))
    return get_kind(scene_or_dict.kind)


def sections_of(kind: str = DEFAULT_KIND) -> dict[str, type[Section]]:
    """The parameter sections of a scene kind."""
    return get_kind(kind).sections


def field_metadata(dotted_key: str, kind: str = DEFAULT_KIND) -> dict[str, Any]:
    """units / long_name / symbol of a dotted scene key such as 'contact.mu'."""
    sections = sections_of(kind)
    section, _, name = dotted_key.partition(".")
    if section not in sections:
        raise ParameterError(f"unknown section {section!r} in key {dotted_key!r}: allowed {', '.join(sections)}")
    for f in dataclasses.fields(sections[section]):
        if f.name == name:
            return dict(f.metadata)
    allowed = ", ".join(f.name for f in dataclasses.fields(sections[section]))
    raise ParameterError(f"unknown key {dotted_key!r}: section [{section}] has {allowed}")


def scene_from_dict(data: dict[str, Any], *, source: str = "<dict>") -> Any:
    """Build a validated scene of the kind that ``data["kind"]`` names; unknown keys are errors naming ``source``."""
    kind = get_kind(data.get("kind", DEFAULT_KIND), source)
    known_top = {"kind", "name", "description", *kind.sections}
    for key in data:
        if key not in known_top:
            raise ParameterError(
                f"unknown key {key!r} in {source}: allowed top-level keys are {', '.join(sorted(known_top))}"
            )
    kwargs: dict[str, Any] = {}
    for key in ("name", "description"):
        if key in data:
            if not isinstance(data[key], str):
                raise ParameterError(f"{key} = {data[key]!r} in {source} has the wrong type: expected a string")
            kwargs[key] = data[key]
    for name, cls in kind.sections.items():
        values = data.get(name, {})
        if not isinstance(values, dict):
            raise ParameterError(f"[{name}] in {source} must be a table, got {values!r}")
        names = {f.name for f in dataclasses.fields(cls)}
        for key in values:
            if key not in names:
                raise ParameterError(
                    f"unknown key '{name}.{key}' in {source}: section [{name}] has {', '.join(sorted(names))}"
                )
        try:
            kwargs[name] = cls(**values)
        except ParameterError as err:
            raise ParameterError(f"{err} (in {source})") from None
    try:
        return kind.scene_type(**kwargs)
    except ParameterError as err:
        raise ParameterError(f"{err} (in {source})") from None
