"""Configuration flows one way: dataclass defaults -> TOML scene file -> ``--set`` overrides.

Unknown keys are errors that name the key and the file; values are checked
by the parameter dataclasses (:mod:`solver.params`) before any work starts.
"""

from __future__ import annotations

import copy
import hashlib
import json
import tomllib
from pathlib import Path
from typing import Any

from solver.kinds import DEFAULT_KIND, field_metadata, scene_from_dict, sections_of
from solver.params import ParameterError


class ConfigError(ParameterError):
    """A configuration file or override that cannot be used."""


def parse_override(text: str) -> tuple[str, Any]:
    """'contact.mu=0.5' -> ('contact.mu', 0.5).  Values are TOML; bare words are strings."""
    if "=" not in text:
        raise ConfigError(f"--set {text!r}: expected KEY=VALUE, e.g. --set contact.mu=0.5")
    key, _, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def apply_overrides(data: dict[str, Any], overrides: list[str] | dict[str, Any], *, source: str) -> dict[str, Any]:
    """Set dotted keys in a nested scene dict; an unknown key is an error naming it."""
    out = copy.deepcopy(data)
    kind = data.get("kind", DEFAULT_KIND)
    try:
        sections = sections_of(kind)
    except ParameterError as err:
        raise ConfigError(f"{source}: {err}") from None
    items = overrides.items() if isinstance(overrides, dict) else (parse_override(o) for o in overrides)
    for key, value in items:
        section, _, name = key.partition(".")
        if not name:
            raise ConfigError(f"{source}: key {key!r} must be SECTION.NAME (sections: {', '.join(sections)})")
        try:
            field_metadata(key, kind)
        except ParameterError as err:
            raise ConfigError(f"{source}: {err}") from None
        if isinstance(value, int) and not isinstance(value, bool):
            meta_default = type(_default_of(key, kind))
            if meta_default is float:
                value = float(value)
        out.setdefault(section, {})[name] = value
    return out


def _default_of(key: str, kind: str = DEFAULT_KIND) -> Any:
    section, _, name = key.partition(".")
    return getattr(sections_of(kind)[section](), name)


def read_toml(path: str | Path) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{path}: not valid TOML ({err})") from None


def load_scene(path: str | Path, overrides: list[str] | dict[str, Any] | None = None) -> Any:
    """Read a scene file, apply ``--set`` overrides, validate."""
    data = read_toml(path)
    if "study" in data or "axes" in data:
        raise ConfigError(f"{path}: this is a study file, not a scene (use 'hdi run')")
    check_scene_file(data, path)
    data = apply_overrides(data, overrides or [], source=f"--set (scene {path})")
    return scene_from_dict(data, source=str(path))


def check_scene_file(data: dict[str, Any], path: str | Path) -> None:
    """A scene file names its scene and sets at least one section: an empty file is not a scene.

    Without this an empty (or section-less) file would silently run the built-in defaults.
    """
    kind = data.get("kind", DEFAULT_KIND)
    try:
        sections = sections_of(kind)
    except ParameterError as err:
        raise ConfigError(f"{path}: {err}") from None
    missing = [] if "name" in data else ['a name (name = "...")']
    if not any(isinstance(data.get(s), dict) for s in sections):
        missing.append("at least one section ([" + "], [".join(sections) + "])")
    if missing:
        what = "empty" if not data else "incomplete"
        raise ConfigError(f"{path}: {what} scene file: it needs {' and '.join(missing)}; "
                          "see studies/scenes/ for complete scenes")  # fmt: skip


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {value!r} as TOML")


def dump_toml(data: dict[str, Any]) -> str:
    """Nested dict of scalars (one level of tables) -> TOML text."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for key, table in data.items():
        if isinstance(table, dict):
            lines.append(f"\n[{key}]")
            lines.extend(f"{k} = {_toml_value(v)}" for k, v in table.items())
    return "\n".join(lines) + "\n"


def scene_toml(scene: Any) -> str:
    """The complete scene (every parameter) as TOML text."""
    return dump_toml(scene.to_dict())


def scene_hash(scene: Any) -> str:
    """Stable short hash of every parameter of a scene."""
    return hashlib.sha256(json.dumps(scene.to_dict(), sort_keys=True).encode()).hexdigest()[:16]


DEFAULT_SCENE = Path(__file__).resolve().parent.parent / "studies" / "scenes" / "benson1989.toml"


RESULTS = Path(__file__).resolve().parent.parent / "results"
