"""Study files: a scene, axes over its keys, the outputs to keep, grid or boundary mode.

A study file (TOML) holds

    [study]    name, title, scene (path relative to the study file), mode = "grid" | "boundary",
               realizations = n (a last axis ``realization`` over the kind's seed: n samples per cell;
               default DEFAULT_REALIZATIONS = 8 for a kind with a stochastic input, 1 for a deterministic one;
               realizations = 1 runs the scene's own seed only and has to be written explicitly),
               figure (a figure of the kind other than the default one, e.g. "regime_map", "statistics")
    [set]      scene values applied to every run (same keys as ``--set``)
    [[axes]]   key (a scene key such as "contact.mu"), dim (dataset dimension name),
               values = [...]  or  start, stop, step  (stop included)
    [outputs]  variables (a subset of the kind's outputs, pipeline.classify), impacts (first impacts kept per run)
    [boundary] axis (one of the axes' keys), tolerance, stable_side = "below" | "above" (the side of the axis
               where the low class lies: stable for kind "rails", a regime below ``threshold`` for kind "abs"),
               lattice = "uniform" (the axis's range at spacing ``tolerance``, the default) | "axis" (the axis's
               own values, increasing, e.g. log-spaced; no tolerance),
               threshold (kinds with a multi-level class, :class:`pipeline.kinds.Traced`: the level where the
               high class starts, e.g. "intermittent_contact" for kind "abs": flying against touching)

Everything is checked when the file is loaded, before any run: unknown
sections or keys, an axis over a key the scene does not have, an empty or
repeated axis, and every expanded scene's values (through the parameter
dataclasses).  Each case of the grid is one complete, validated scene with a
run id: a hash of all its parameters and the package version, which keys the
ledger so that an interrupted study resumes where it stopped.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pipeline import __version__
from pipeline.config import ConfigError, apply_overrides, dump_toml, parse_override, read_toml
from pipeline.kinds import adapter_of
from solver.kinds import DEFAULT_KIND, field_metadata, get_kind, scene_from_dict
from solver.params import ParameterError

MODES = ("grid", "boundary", "multifidelity")

ALLOWED = {
    "study": {"name", "title", "scene", "mode", "description", "realizations", "figure"},
    "multifidelity": {"cheap", "axes"},
    "set": None,  # any scene key, checked by apply_overrides
    "axes": {"key", "dim", "values", "start", "stop", "step"},
    "outputs": {"variables", "impacts"},
    "boundary": {"axis", "tolerance", "stable_side", "lattice", "threshold"},
}
ROUND = 12  # decimals: axis values are rounded so that the same value always hashes the same
#: Dimension of a study's realisations of a stochastic input (one seed each, see SceneKind.seed_key).
REALIZATION = "realization"
#: Realisations per cell of a study of a kind with a stochastic input whose file does not say how many:
#: enough for a 95 % interval of the mean (t_{0.975, 7} = 2.36, 0.84 standard deviations half-width).
DEFAULT_REALIZATIONS = 8
#: Figures a study file may name (besides its kind's default study figure).
STUDY_FIGURES = ("regime_map", "statistics")


@dataclass(frozen=True)
class Axis:
    key: str  # scene key, e.g. "contact.mu"
    dim: str  # dataset dimension, e.g. "mu"
    values: tuple[Any, ...]
    units: str = ""
    long_name: str = ""


#: Lattices a boundary may be bisected on: the axis's range at spacing ``tolerance``, or the axis's own values.
BOUNDARY_LATTICES = ("uniform", "axis")


@dataclass(frozen=True)
class Boundary:
    axis: str  # scene key of the bisected axis
    tolerance: float | None  # lattice spacing (None: the lattice is the axis's own values)
    stable_side: str = "below"
    lattice: str = "uniform"
    threshold: str | None = None  # level where the high class starts (a kind with a multi-level class)


@dataclass(frozen=True)
class Case:
    """One run of a study: its place on the grid and its complete scene."""

    index: tuple[int, ...]
    coords: dict[str, Any]  # dim -> value
    overrides: dict[str, Any]  # scene key -> value
    scene: Any  # a scene of any kind
    run_id: str

    @property
    def scene_dict(self) -> dict[str, Any]:
        return self.scene.to_dict()

    def label(self) -> str:
        return " ".join(f"{k}={_fmt(v)}" for k, v in self.coords.items())


@dataclass(frozen=True)
class Study:
    name: str
    title: str
    path: Path
    text: str  # the study file as written
    scene_path: Path
    scene_text: str
    base: dict[str, Any]  # scene dict after the study's [set] and the command line's --set
    axes: tuple[Axis, ...]
    mode: str
    variables: tuple[str, ...]
    impacts_kept: int
    boundary: Boundary | None
    overrides: tuple[str, ...] = field(default=())
    multifidelity: dict[str, Any] | None = None  # scene keys of the cheap pass (mode multifidelity)
    multifidelity_axes: tuple[str, ...] = ()  # axes along which cells are neighbours (default: all)
    figure: str = ""  # a figure of the kind other than its default study figure

    @property
    def dims(self) -> tuple[str, ...]:
        return tuple(a.dim for a in self.axes)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.values) for a in self.axes)

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def axis(self, key_or_dim: str) -> Axis:
        for a in self.axes:
            if key_or_dim in (a.key, a.dim):
                return a
        raise KeyError(key_or_dim)

    def config_hash(self) -> str:
        """Hash of everything that defines the study's runs (base scene, axes, outputs)."""
        payload = {
            "base": self.base,
            "axes": [(a.key, a.dim, list(a.values)) for a in self.axes],
            "variables": list(self.variables),
            "impacts": self.impacts_kept,
            "version": __version__,
            "code": code_fingerprint(),
        }
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]

    def case(self, index: tuple[int, ...]) -> Case:
        coords = {a.dim: a.values[i] for a, i in zip(self.axes, index, strict=True)}
        overrides = {a.key: a.values[i] for a, i in zip(self.axes, index, strict=True)}
        return make_case(self, index, coords, overrides)

    def cases(self) -> list[Case]:
        """Every case of the full grid, in C order of the axes (validated)."""
        return [self.case(ix) for ix in itertools.product(*(range(n) for n in self.shape))]


def make_case(study: Study, index: tuple[int, ...], coords: dict[str, Any], overrides: dict[str, Any]) -> Case:
    """The case at ``index``; a realisation of a cell whose input is not stochastic gets the first seed (one run)."""
    data = apply_overrides(study.base, overrides, source=f"study {study.path}")
    label = ", ".join(f"{k} = {v!r}" for k, v in overrides.items())
    scene = scene_from_dict(data, source=f"{study.path} (case {label})")
    if REALIZATION in coords and not adapter_of(scene).stochastic(scene):
        seeds = study.axis(REALIZATION)
        if overrides[seeds.key] != seeds.values[0]:
            scene = scene_from_dict(apply_overrides(data, {seeds.key: seeds.values[0]}, source=str(study.path)),
                                    source=f"{study.path} (case {label})")  # fmt: skip
    return Case(index, coords, overrides, scene, run_id(scene))


@functools.cache
def code_fingerprint() -> str:
    """Hash of the code a run executes (solver/ and the worker-side pipeline modules).

    Part of every run id, so that a ledger never hands back a result computed
    by other code: after any change to the numerics, every run is computed anew.
    """
    root = Path(__file__).resolve().parents[2]
    files = sorted((root / "solver").rglob("*.py")) + [
        root / "pipeline" / n for n in ("run/runner.py", "classify.py", "kinds.py", "data/profiles.py")
    ]
    digest = hashlib.sha256()
    for f in files:
        digest.update(f.relative_to(root).as_posix().encode())
        digest.update(f.read_bytes())
    return digest.hexdigest()[:16]


def run_id(scene: Any) -> str:
    """Hash of every scene parameter, the package version and the code: the ledger key of a run."""
    payload = json.dumps({"scene": scene.to_dict(), "version": __version__, "code": code_fingerprint()}, sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()[:20]


def _fmt(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def axis_range(start: float, stop: float, step: float) -> tuple[float, ...]:
    """start, start + step, ... up to stop included (within step/1000), rounded."""
    n = int(math.floor((stop - start) / step * (1.0 + 1e-12) + 1e-3)) + 1
    return tuple(float(round(start + i * step, ROUND)) for i in range(max(n, 0)))


def _study_error(path: Path, where: str, reason: str) -> ConfigError:
    return ConfigError(f"{path}: {where}: {reason}")


def _check_keys(path: Path, where: str, table: dict[str, Any], allowed: set[str]) -> None:
    for key in table:
        if key not in allowed:
            raise _study_error(path, where, f"unknown key {key!r} (allowed: {', '.join(sorted(allowed))})")


def _parse_axis(path: Path, n: int, raw: Any, kind: str = DEFAULT_KIND) -> Axis:
    where = f"[[axes]] #{n + 1}"
    if not isinstance(raw, dict):
        raise _study_error(path, where, "must be a table")
    _check_keys(path, where, raw, ALLOWED["axes"])
    key = raw.get("key")
    if not isinstance(key, str):
        raise _study_error(path, where, "needs key = 'SECTION.NAME' (a scene key such as 'contact.mu')")
    where = f"axis {key!r}"
    try:
        meta = field_metadata(key, kind)
    except ParameterError as err:
        raise _study_error(path, where, f"the scene has no such key ({err})") from None
    dim = raw.get("dim", key.partition(".")[2])
    if not isinstance(dim, str) or not dim.isidentifier():
        raise _study_error(path, where, f"dim = {dim!r} must be a name such as 'mu'")
    has_range = any(k in raw for k in ("start", "stop", "step"))
    if "values" in raw and has_range:
        raise _study_error(path, where, "give either values = [...] or start/stop/step, not both")
    if "values" in raw:
        values = raw["values"]
        if not isinstance(values, list):
            raise _study_error(path, where, f"values = {values!r} must be a list")
        values = [float(round(v, ROUND)) if isinstance(v, float) else v for v in values]
    elif has_range:
        missing = [k for k in ("start", "stop", "step") if k not in raw]
        if missing:
            raise _study_error(path, where, f"a range needs start, stop and step (missing {', '.join(missing)})")
        start, stop, step = (raw[k] for k in ("start", "stop", "step"))
        if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (start, stop, step)):
            raise _study_error(path, where, "start, stop and step must be numbers")
        if step <= 0:
            raise _study_error(path, where, f"step = {step!r} must be > 0")
        values = list(axis_range(float(start), float(stop), float(step)))
    else:
        raise _study_error(path, where, "needs values = [...] or start/stop/step")
    if not values:
        raise _study_error(path, where, "is empty (no values): an axis needs at least one value")
    if len(set(values)) != len(values):
        raise _study_error(path, where, f"repeats a value ({values})")
    return Axis(key, dim, tuple(values), meta.get("units", ""), meta.get("long_name", ""))


def load_study(
    path: str | Path,
    overrides: list[str] | None = None,
    mode: str | None = None,
    realizations: int | None = None,
) -> Study:
    """Read and check a study file; ``overrides`` are ``--set KEY=VALUE`` for the base scene, ``realizations``
    replaces the file's (or the default) number of realisations per cell."""
    path = Path(path)
    data = read_toml(path)
    if "study" not in data:
        raise ConfigError(f"{path}: not a study file (no [study] table; a scene file is run with 'hdi simulate')")
    for section in data:
        if section not in ALLOWED:
            raise _study_error(path, f"[{section}]", f"unknown section (allowed: {', '.join(ALLOWED)})")
    head = data["study"]
    _check_keys(path, "[study]", head, ALLOWED["study"])
    name = head.get("name", path.stem)
    if not isinstance(name, str) or not name or "/" in name:
        raise _study_error(path, "[study] name", f"{name!r} must be a non-empty name without '/'")
    if "scene" not in head:
        raise _study_error(path, "[study]", "needs scene = 'path/to/scene.toml' (relative to the study file)")
    scene_path = (path.parent / head["scene"]).resolve()
    if not scene_path.is_file():
        raise _study_error(path, "[study] scene", f"{head['scene']!r}: no such file ({scene_path})")
    mode = mode or head.get("mode", "grid")
    if mode not in MODES:
        raise _study_error(path, "[study] mode", f"{mode!r} is not allowed (allowed: {', '.join(MODES)})")

    scene_text = scene_path.read_text()
    try:
        scene_data = tomllib.loads(scene_text)
    except tomllib.TOMLDecodeError as err:
        raise _study_error(path, "scene", f"{scene_path} is not valid TOML ({err})") from None
    fixed = data.get("set", {})
    if not isinstance(fixed, dict):
        raise _study_error(path, "[set]", "must be a table of scene keys")
    base = apply_overrides(scene_data, _flatten(fixed), source=f"{path} [set]")
    cli = list(overrides or [])
    base = apply_overrides(base, cli, source="--set")
    raw_axes = data.get("axes", [])
    if not isinstance(raw_axes, list) or not raw_axes:
        raise _study_error(path, "[[axes]]", "a study needs at least one axis")
    axes = tuple(_parse_axis(path, n, raw, base.get("kind", DEFAULT_KIND)) for n, raw in enumerate(raw_axes))
    valid = base  # the scene the axes' values are checked against, one axis at a time
    try:
        scene_from_dict(base, source=f"{scene_path} with the study's [set] and --set")
    except ParameterError:
        # A base that holds only with its axes' values (an output interval that is a whole multiple of every dt on
        # a dt axis, but not of the scene's own dt) is a study: every case is checked below.  Else the base's error.
        first = apply_overrides(base, {a.key: a.values[0] for a in axes}, source=str(path))
        try:
            scene_from_dict(first, source=str(path))
        except ParameterError:
            scene_from_dict(base, source=f"{scene_path} with the study's [set] and --set")
            raise
        valid = first
    for attr in ("key", "dim"):
        seen = [getattr(a, attr) for a in axes]
        dup = {s for s in seen if seen.count(s) > 1}
        if dup:
            raise _study_error(path, "[[axes]]", f"{attr} {sorted(dup)} used by more than one axis")
    kind = get_kind(base.get("kind", DEFAULT_KIND))
    n_real = head.get("realizations", DEFAULT_REALIZATIONS if kind.seed_key else 1)
    axes += _realization_axis(path, n_real if realizations is None else realizations, base, axes)
    for key in _flatten(fixed):
        if key in {a.key for a in axes} and key != get_kind(base.get("kind", DEFAULT_KIND)).seed_key:
            raise _study_error(path, "[set]", f"{key!r} is also an axis")
    for text in cli:
        key = parse_override(text)[0]
        if key in {a.key for a in axes}:
            raise ConfigError(f"--set {text!r}: {key!r} is an axis of {path}; change the axis in the study file")

    adapter = adapter_of(base)
    variables, impacts = _parse_outputs(path, data.get("outputs", {}), adapter)
    for traced, has in (("boundary", adapter.traced), ("multifidelity", adapter.class_flag)):
        if (traced in data or mode == traced) and has is None:
            raise _study_error(
                path,
                f"[{traced}]" if traced in data else f"mode = {mode!r}",
                f"needs runs with a class to trace, and scene kind {adapter.name!r} has none for this mode: use "
                "mode = 'grid'" + (" or 'boundary'" if adapter.traced is not None else ""),
            )
    boundary = _parse_boundary(path, data["boundary"], axes, adapter.traced) if "boundary" in data else None
    if mode == "boundary" and boundary is None:
        raise _study_error(path, "mode = 'boundary'", "needs a [boundary] table (axis, tolerance)")
    cheap, cheap_axes = _parse_multifidelity(path, data["multifidelity"], axes, base) if "multifidelity" in data else (
        None, ())  # fmt: skip
    if mode == "multifidelity" and cheap is None:
        raise _study_error(path, "mode = 'multifidelity'", "needs a [multifidelity.cheap] table of scene keys")
    figure = head.get("figure", "")
    if figure and (figure not in STUDY_FIGURES or figure not in adapter.figures):
        allowed = [f for f in STUDY_FIGURES if f in adapter.figures]
        raise _study_error(path, "[study] figure", f"{figure!r} is not a study figure of kind {adapter.name!r} "
                           f"(allowed: {', '.join(allowed) or 'none'})")  # fmt: skip
    if figure == "statistics" and not all(isinstance(v, int | float) and not isinstance(v, bool)
                                          for v in axes[0].values):  # fmt: skip
        raise _study_error(path, "[study] figure", f"'statistics' compares each value of the first axis with its "
                           f"last, a refinement (numerics.dt, a grid size): axis {axes[0].key!r} has the values "
                           f"{list(axes[0].values)!r} (allowed: numbers)")  # fmt: skip

    study = Study(
        name=name,
        # a study run with --set is not the study its file describes: its title says so (figures, netCDF)
        title=head.get("title", name) + (f" [--set {' '.join(cli)}]" if cli else ""),
        path=path.resolve(),
        text=path.read_text(),
        scene_path=scene_path,
        scene_text=scene_text,
        base=base,
        axes=axes,
        mode=mode,
        variables=tuple(variables),
        impacts_kept=impacts,
        boundary=boundary,
        overrides=tuple(cli),
        multifidelity=cheap,
        multifidelity_axes=cheap_axes,
        figure=figure,
    )
    # Every value of every axis must make a valid scene on its own: check each axis value against the base scene
    # (or the base at the axes' first values, where it holds only with them) now, so that a bad value fails before
    # any run.
    for a in axes:
        for v in a.values:
            try:
                scene_from_dict(apply_overrides(valid, {a.key: v}, source=str(path)), source=str(path))
            except ParameterError as err:
                raise _study_error(path, f"axis {a.key!r}", f"value {v!r} is not allowed: {err}") from None
    if mode == "grid":
        _check_cells(study, adapter)
    return study


def _check_cells(study: Study, adapter: Any) -> None:
    """Every cell's scene (the realisations of a cell share it, but for the seed) passes the kind's check."""
    cell_axes = [a for a in study.axes if a.dim != REALIZATION]
    for index in itertools.product(*(range(len(a.values)) for a in cell_axes)):
        overrides = {a.key: a.values[i] for a, i in zip(cell_axes, index, strict=True)}
        label = ", ".join(f"{k} = {v!r}" for k, v in overrides.items())
        scene = scene_from_dict(apply_overrides(study.base, overrides, source=str(study.path)),
                                source=f"{study.path} (cell {label})")  # fmt: skip
        try:
            adapter.check(scene)
        except ParameterError as err:
            raise _study_error(study.path, f"cell {label}", f"cannot run: {err}") from None


def _realization_axis(path: Path, n: Any, base: dict[str, Any], axes: tuple[Axis, ...]) -> tuple[Axis, ...]:
    """``realizations = n``: a last axis over the kind's seed, n seeds from the scene's own (none for n = 1).

    Each realisation is one reproducible sample of the stochastic input (a rough track): study datasets then
    give each cell's mean over the realisations with its 95 % confidence interval.  A kind with a seed gets
    DEFAULT_REALIZATIONS where the file does not say; a single sample (n = 1, no interval) must be asked for.
    """
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise _study_error(path, "[study] realizations", f"{n!r} must be an integer >= 1 (default "
                           f"{DEFAULT_REALIZATIONS} for a scene with a stochastic input; 1 for one sample without "
                           "an interval)")  # fmt: skip
    if n == 1:
        return ()
    kind = get_kind(base.get("kind", DEFAULT_KIND))
    if kind.seed_key is None:
        raise _study_error(path, "[study] realizations", f"= {n}: scene kind {kind.name!r} is deterministic (no "
                           "stochastic input to sample): use 1")  # fmt: skip
    if kind.seed_key in {a.key for a in axes}:
        raise _study_error(path, "[study] realizations", f"{kind.seed_key!r} is already an axis")
    section, _, name = kind.seed_key.partition(".")
    first = int(base.get(section, {}).get(name, getattr(kind.sections[section](), name)))
    meta = field_metadata(kind.seed_key, kind.name)
    return (Axis(kind.seed_key, REALIZATION, tuple(range(first, first + n)), meta.get("units", "1"),
                 f"realisation of the stochastic input ({kind.seed_key})"),)  # fmt: skip


def _parse_outputs(path: Path, outputs: Any, adapter: Any) -> tuple[list[str], int]:
    """[outputs]: the kind's outputs a study keeps (by default its ``study_outputs``; its required ones always)
    and the first impacts kept."""
    _check_keys(path, "[outputs]", outputs, ALLOWED["outputs"])
    variables = outputs.get("variables", list(adapter.study_outputs))
    if not isinstance(variables, list):
        raise _study_error(path, "[outputs] variables", "must be a list")
    for v in variables:
        if v not in adapter.outputs:
            allowed = ", ".join(adapter.outputs)
            raise _study_error(path, "[outputs] variables", f"unknown variable {v!r} (allowed: {allowed})")
    for needed in reversed(adapter.required_outputs):
        if needed not in variables:
            variables = [needed, *variables]
    impacts = outputs.get("impacts", adapter.impacts_kept)
    if not isinstance(impacts, int) or isinstance(impacts, bool) or impacts < 0:
        raise _study_error(path, "[outputs] impacts", f"{impacts!r} must be an integer >= 0")
    return variables, impacts


def _parse_boundary(path: Path, b: Any, axes: tuple[Axis, ...], traced: Any) -> Boundary:
    """[boundary]: the axis to bisect, its lattice (tolerance, or the axis's own values), the stable side and the
    class's threshold (``traced``: the kind's :class:`pipeline.kinds.Traced`)."""
    _check_keys(path, "[boundary]", b, ALLOWED["boundary"])
    threshold = b.get("threshold")
    if threshold is not None and not traced.thresholds:
        raise _study_error(path, "[boundary] threshold", f"{threshold!r}: the class of this kind ({traced.flag}) "
                           "has two values, there is no threshold to choose: remove it")  # fmt: skip
    if traced.thresholds:
        threshold = traced.default_threshold if threshold is None else threshold
        if threshold not in traced.thresholds:
            allowed = ", ".join(traced.thresholds)
            raise _study_error(path, "[boundary] threshold", f"{threshold!r} is not allowed (allowed: {allowed}: "
                               f"the {traced.flag} where the high class starts)")  # fmt: skip
    axis_key = b.get("axis")
    if axis_key not in {a.key for a in axes}:
        raise _study_error(
            path, "[boundary] axis", f"{axis_key!r} is not one of the axes ({', '.join(a.key for a in axes)})"
        )
    values = next(a.values for a in axes if a.key == axis_key)
    if not all(isinstance(v, int | float) for v in values) or len(values) < 2:
        raise _study_error(path, "[boundary] axis", f"{axis_key!r} needs at least two numeric values")
    side = b.get("stable_side", "below")
    if side not in ("below", "above"):
        raise _study_error(path, "[boundary] stable_side", f"{side!r} is not allowed (allowed: below, above)")
    kind = b.get("lattice", "uniform")
    if kind not in BOUNDARY_LATTICES:
        raise _study_error(path, "[boundary] lattice", f"{kind!r} is not allowed (allowed: "
                           f"{', '.join(BOUNDARY_LATTICES)})")  # fmt: skip
    if kind == "axis":
        if "tolerance" in b:
            raise _study_error(path, "[boundary] tolerance", "is not used with lattice = 'axis' (the bisection "
                               "runs on the axis's own values): remove it")  # fmt: skip
        if any(upper <= lower for lower, upper in itertools.pairwise(values)):
            raise _study_error(path, "[boundary] lattice", f"= 'axis' needs the values of {axis_key!r} in "
                               f"increasing order ({list(values)})")  # fmt: skip
        return Boundary(axis_key, None, side, kind, threshold)
    tol = b.get("tolerance")
    if not isinstance(tol, int | float) or isinstance(tol, bool) or not 0 < tol <= max(values) - min(values):
        raise _study_error(
            path, "[boundary] tolerance", f"{tol!r} must be a number in (0, {max(values) - min(values):g}]"
        )
    return Boundary(axis_key, float(tol), side, threshold=threshold)


def _parse_multifidelity(
    path: Path, mf: Any, axes: tuple[Axis, ...], base: dict[str, Any]
) -> tuple[dict[str, Any], tuple[str, ...]]:
    """[multifidelity]: the scene keys of the cheap pass and the axes along which cells are neighbours."""
    _check_keys(path, "[multifidelity]", mf, ALLOWED["multifidelity"])
    cheap = _flatten(mf.get("cheap", {}))
    if not cheap:
        raise _study_error(path, "[multifidelity] cheap", "needs scene keys for the cheap pass")
    for key in cheap:
        if key in {a.key for a in axes}:
            raise _study_error(path, "[multifidelity.cheap]", f"{key!r} is also an axis")
    try:
        scene_from_dict(apply_overrides(base, cheap, source=f"{path} [multifidelity.cheap]"), source=str(path))
    except ParameterError as err:
        raise _study_error(path, "[multifidelity.cheap]", str(err)) from None
    if apply_overrides(base, cheap, source=str(path)) == base:
        raise _study_error(path, "[multifidelity.cheap]", "does not change the scene")
    neighbour_axes = mf.get("axes", [a.key for a in axes])
    unknown = [k for k in neighbour_axes if k not in {a.key for a in axes}] if isinstance(neighbour_axes, list) else 1
    if unknown or not neighbour_axes:
        raise _study_error(
            path, "[multifidelity] axes", f"{neighbour_axes!r} must list axes of the study ({[a.key for a in axes]})"
        )
    return cheap, tuple(neighbour_axes)


def _flatten(table: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """{'contact': {'mu': 0.5}} or {'contact.mu': 0.5} -> {'contact.mu': 0.5}."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        full = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_flatten(value, prefix=f"{full}."))
        else:
            out[full] = value
    return out


def lattice(study: Study) -> tuple[float, ...]:
    """Values of the bisected axis: its range at the boundary tolerance (rounded like the grid's values), or the
    axis's own values (``lattice = "axis"``)."""
    assert study.boundary is not None
    values = study.axis(study.boundary.axis).values
    if study.boundary.tolerance is None:
        return tuple(float(v) for v in values)
    lo, hi = min(values), max(values)
    return axis_range(float(lo), float(hi), study.boundary.tolerance)


def study_attrs(study: Study) -> dict[str, str]:
    """Provenance of a study: its file, the scene file, the command-line overrides, the config hash."""
    return {
        "study": study.name,
        "study_file": str(study.path),
        "study_toml": study.text,
        "scene_file": str(study.scene_path),
        "scene_toml": dump_toml(study.base),
        "overrides": " ".join(study.overrides),
        "config_hash": study.config_hash(),
        "mode": study.mode,
        "figure": study.figure,
    }
