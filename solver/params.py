"""Parameters: frozen dataclasses in SI units, each field documented once.

Every field carries metadata (``units``, ``long_name``, ``symbol`` and the
allowed range).  The same metadata produces the validation messages and the
``units``/``long_name`` attributes of every stored variable, so a unit is
written in exactly one place.

The sections of each scene kind live in its sub-package (:mod:`solver.rails.params`,
:mod:`solver.abs.params`); :mod:`solver.kinds` builds a scene of any kind from a dict.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any


class ParameterError(ValueError):
    """A parameter value, key or type that is not allowed."""


def quantity(
    default: Any,
    units: str,
    long_name: str,
    *,
    symbol: str = "",
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    choices: tuple[str, ...] | None = None,
) -> Any:
    """A dataclass field with physical metadata and an allowed range."""
    return field(
        default=default,
        metadata={
            "units": units,
            "long_name": long_name,
            "symbol": symbol,
            "lo": lo,
            "hi": hi,
            "lo_open": lo_open,
            "hi_open": hi_open,
            "choices": choices,
        },
    )


def _allowed_text(meta: dict[str, Any]) -> str:
    if meta["choices"] is not None:
        return "one of " + ", ".join(repr(c) for c in meta["choices"])
    lo, hi = meta["lo"], meta["hi"]
    parts = []
    if lo is not None:
        parts.append(f"{'>' if meta['lo_open'] else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"{'<' if meta['hi_open'] else '<='} {hi:g}")
    text = " and ".join(parts) if parts else "any value"
    if lo is not None and hi is not None and not meta["lo_open"] and not meta["hi_open"]:
        text = f"in [{lo:g}, {hi:g}]"
    return text


def check_field(section: str, f: dataclasses.Field, value: Any) -> None:
    """Check ``value`` against the type, range and choices declared by :func:`quantity` on field ``f``.

    Raises :class:`ParameterError` naming the dotted key ``section.name``, the allowed values and the units.
    """
    meta = f.metadata
    key = f"{section}.{f.name}"
    units = f" [{meta['units']}]" if meta.get("units") not in (None, "", "1") else ""
    what = f"({meta['long_name']})"
    expected = type(f.default)
    if expected is bool:
        if not isinstance(value, bool):
            raise ParameterError(f"{key} = {value!r} has the wrong type: expected true or false {what}")
        return
    if expected is str:
        if not isinstance(value, str):
            raise ParameterError(f"{key} = {value!r} has the wrong type: expected a string {what}")
        if meta["choices"] is not None and value not in meta["choices"]:
            raise ParameterError(f"{key} = {value!r} is not allowed: must be {_allowed_text(meta)} {what}")
        return
    if expected is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ParameterError(f"{key} = {value!r} has the wrong type: expected an integer {what}")
    elif expected is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ParameterError(f"{key} = {value!r} has the wrong type: expected a number{units} {what}")
        if not math.isfinite(value):
            raise ParameterError(f"{key} = {value!r} is not allowed: must be finite {what}")
    lo, hi = meta["lo"], meta["hi"]
    bad = False
    if lo is not None and (value < lo or (meta["lo_open"] and value == lo)):
        bad = True
    if hi is not None and (value > hi or (meta["hi_open"] and value == hi)):
        bad = True
    if bad:
        raise ParameterError(f"{key} = {value!r} is not allowed: must be {_allowed_text(meta)}{units} {what}")


class Section:
    """Mixin: validation and plain-dict conversion for a parameter section."""

    section: str = ""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if type(f.default) is float and isinstance(value, int) and not isinstance(value, bool):
                object.__setattr__(self, f.name, float(value))
                value = float(value)
            check_field(self.section, f, value)

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


@dataclass(frozen=True)
class Air(Section):
    section = "air"
    ambient_pressure: float = quantity(101.0e3, "Pa", "ambient pressure", symbol="p0", lo=0.0, lo_open=True)
    viscosity: float = quantity(18.1e-6, "Pa s", "air viscosity", symbol="eta", lo=0.0, lo_open=True)
    mean_free_path: float = quantity(0.06e-6, "m", "mean free path of air at p0", symbol="lambda", lo=0.0)
