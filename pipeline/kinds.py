"""One :class:`Adapter` per scene kind: everything about a kind that is records, datasets, text or figures.

This is the one pipeline module that names the kinds; every other module looks a kind's adapter up (by a
scene, a scene dict or a dataset's ``scene_kind`` attribute) instead of branching on it.  The solver's side of a
kind (parameters, fly, simulate, warm-up) is :class:`solver.kind.SceneKind` in :mod:`solver.kinds`.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import xarray as xr

from solver.kinds import DEFAULT_KIND, get_kind

from .classify import Output


@dataclass(frozen=True)
class Traced:
    """The two-valued class a boundary study traces, read from one flag output of a kind's runs.

    ``flag`` is an int8 output with ``flag_values`` 0, 1, ... (its names ``levels``) and -1 where a run is not
    classified.  A run is on the *low* side when its flag is below the threshold level (one of ``thresholds``,
    named in the study's ``[boundary] threshold``; ``default_threshold`` when the study names none), on the
    *high* side at or above it.  A two-valued flag has no choice: ``thresholds`` is empty and the low class is
    ``fixed_low`` (the flag value that counts as low).  A boundary study's ``stable_side`` says on which side of
    its axis the low class lies.
    """

    flag: str
    levels: tuple[str, ...]
    thresholds: tuple[str, ...] = ()
    default_threshold: str | None = None
    fixed_low: int = 1

    def classes(self, values: Any, threshold: str | None = None) -> Any:
        """1 (low class), 0 (high class) or -1 (not classified) for each flag value."""
        import numpy as np

        values = np.asarray(values)
        if self.thresholds:
            level = self.levels.index(threshold or self.default_threshold)
            low = (values >= 0) & (values < level)
        else:
            low = values == self.fixed_low
        return np.where(values < 0, -1, np.where(low, 1, 0)).astype(np.int8)

    def names(self, threshold: str | None = None) -> tuple[str, str]:
        """Names of the low and the high class, e.g. ("stable", "unstable") or ("flying", "intermittent_contact
        or above")."""
        if not self.thresholds:
            low = self.levels[self.fixed_low]
            return low, self.levels[1 - self.fixed_low]
        level = self.levels.index(threshold or self.default_threshold)
        low = self.levels[0] if level == 1 else f"below {self.levels[level]}"
        high = self.levels[level] if level == len(self.levels) - 1 else f"{self.levels[level]} or above"
        return low, high


@dataclass(frozen=True)
class Adapter:
    """The pipeline's side of a scene kind.

    ``record(scene, result, impacts_kept)`` is the run classifier: the JSON-ready fields a run returns to a
    study.  ``outputs`` declares every scalar of such a record once (units, long name, dtype and fill in a study
    dataset); ``study_outputs`` are kept by default, the others when a study lists them, ``required_outputs``
    always.  ``class_flag`` names the
    two-valued class a multi-fidelity study traces (None: that mode is refused); ``traced`` is the class a
    boundary study traces (:class:`Traced`; None: boundary mode is refused).
    ``category`` names the flag output whose share over a cell's realisations a study reports
    (``<category>_fraction``, e.g. ``regime_fraction``; None: no such output).
    ``run_inputs(scene)`` reads what a run needs from files (the solver reads none).
    ``check(scene)`` raises :class:`solver.params.ParameterError` for a scene whose parameters are valid one by
    one but that cannot run (a grid too coarse for a pad): studies call it on every cell before any run.
    ``stochastic(scene)`` is False where the kind's seed has no effect on the scene (a smooth disk): a study runs
    such a cell once and gives that record to every realisation (the interval of its mean is then 0).
    ``figures`` maps a product ("fly", "run", "study") or a study's ``figure`` name to its figure.
    ``spectra_kept`` names the amplitude spectra a run's record holds (``record["spectra"]``, with its
    ``frequency``), kept in a study as ``<name>_spectrum`` on a ``frequency`` dimension.
    ``modes(scene, steady)`` gives the modes of the slider on its air bearing about steady flight as report
    lines and dataset variables (None: the kind has no modal analysis; ``hdi fly --modes`` refuses it).
    """

    name: str
    record: Callable[[Any, Any, int], dict[str, Any]]
    outputs: Mapping[str, Output]
    study_outputs: tuple[str, ...]
    required_outputs: tuple[str, ...]
    impacts_kept: int
    class_flag: str | None
    category: str | None
    check: Callable[[Any], None]
    stochastic: Callable[[Any], bool]
    run_inputs: Callable[[Any], dict[str, Any]]
    fly_dataset: Callable[[Any, Any, float], xr.Dataset]
    run_dataset: Callable[[Any, Any], xr.Dataset]
    fly_report: Callable[[Any, Any, float], list[str]]
    run_report: Callable[[Any, xr.Dataset, Any], list[str]]
    progress: Callable[[dict[str, Any]], str]
    figures: Mapping[str, Callable[..., Any]]
    bench: Callable[[Any], int] | None
    series_kept: Mapping[str, tuple[str, str]]
    traced: Traced | None = None
    spectra_kept: Mapping[str, tuple[str, str]] = dataclasses.field(default_factory=dict)
    modes: Callable[[Any, Any], tuple[list[str], dict[str, xr.Variable]]] | None = None

    @property
    def solver(self):
        """The solver's :class:`solver.kind.SceneKind` of this kind."""
        return get_kind(self.name)


def _table_store(scene: Any) -> dict[str, Any]:
    """The reduced air-bearing levels' tables, kept on disk for every later process (the solver writes no files)."""
    from .run.cache import DiskStore

    return {"store": DiskStore()}


def _track_profile(scene: Any) -> dict[str, Any]:
    """The measured track profile of an "abs" scene, read here (the solver reads no files); none: synthetic."""
    if not scene.disk.profile_file:
        return {}
    from .data.profiles import read_profile

    return {"profile": read_profile(scene.disk.profile_file)}


def _no_check(scene: Any) -> None:
    """Scenes whose parameters are valid one by one can run."""


def _seed_free(scene: Any) -> bool:
    """A kind without a stochastic input."""
    return False


def _abs_grid_check(scene: Any) -> None:
    """The face's grid resolves every region (:func:`solver.abs.face.abs_grid`, a few ms)."""
    from solver.abs.face import abs_grid

    abs_grid(scene)


def _seeded(scene: Any) -> bool:
    """The seed draws the track (a synthetic profile of RMS > 0; a smooth disk or a measured profile ignore it)
    or the initial kick (``initial.zdot_spread`` > 0)."""
    return (scene.disk.rms > 0.0 and not scene.disk.profile_file) or scene.initial.zdot_spread > 0.0


def _adapters() -> dict[str, Adapter]:
    from solver.abs.params import SERIES as ABS_SERIES

    from . import reports
    from .bench import abs as bench_abs
    from .bench import rails as bench_rails
    from .classify import (
        ABS_OUTPUTS,
        ABS_SERIES_KEPT,
        ABS_SPECTRA_KEPT,
        RAILS_OUTPUTS,
        RAILS_RESTITUTION_OUTPUTS,
        REGIMES,
        abs_record,
        rails_record,
    )
    from .data import abs as data_abs
    from .data import rails as data_rails
    from .figures import abs as figures_abs
    from .figures import rails as figures_rails
    from .figures.bench import plot_scene2_bench, plot_work_precision

    rails = Adapter(
        name="rails",
        record=rails_record,
        outputs=RAILS_OUTPUTS,
        study_outputs=tuple(name for name in RAILS_OUTPUTS if name not in RAILS_RESTITUTION_OUTPUTS),
        required_outputs=("stable", "status"),
        impacts_kept=20,
        class_flag="stable",
        category=None,
        check=_no_check,
        stochastic=_seed_free,
        run_inputs=_table_store,
        fly_dataset=data_rails.fly_dataset,
        run_dataset=data_rails.run_dataset,
        fly_report=reports.rails_fly,
        run_report=reports.rails_run,
        progress=reports.rails_progress,
        figures={
            "fly": figures_rails.plot_fly,
            "run": figures_rails.plot_run,
            "study": figures_rails.plot_stability_map,
            "bench": plot_work_precision,
        },  # fmt: skip
        bench=bench_rails.run_bench,
        series_kept={},
        traced=Traced("stable", ("unstable", "stable")),
    )
    abs_ = Adapter(
        name="abs",
        record=abs_record,
        outputs=ABS_OUTPUTS,
        study_outputs=tuple(ABS_OUTPUTS),
        required_outputs=("status", "regime"),
        impacts_kept=0,
        class_flag=None,
        category="regime",
        check=_abs_grid_check,
        stochastic=_seeded,
        run_inputs=_track_profile,
        fly_dataset=lambda steady, scene, wall_time: data_abs.fly_dataset(steady, scene),
        run_dataset=data_abs.run_dataset,
        fly_report=reports.abs_fly,
        run_report=reports.abs_run,
        progress=reports.abs_progress,
        figures={
            "fly": figures_abs.plot_fly,
            "run": figures_abs.plot_run,
            "study": figures_abs.plot_study,
            "regime_map": figures_abs.plot_regime_map,
            "statistics": figures_abs.plot_statistics,
            "bench": plot_scene2_bench,
            "ladder": figures_abs.plot_ladder,
        },  # fmt: skip
        bench=bench_abs.run_bench,
        series_kept={name: ABS_SERIES[name] for name in ABS_SERIES_KEPT},
        traced=Traced("regime", REGIMES, REGIMES[1:], "intermittent_contact"),
        spectra_kept=ABS_SPECTRA_KEPT,
        modes=data_abs.modes,
    )
    return {a.name: a for a in (rails, abs_)}


def adapters() -> dict[str, Adapter]:
    """Every kind's adapter by name (imported on first use)."""
    return _adapters()


def adapter_of(thing: Any) -> Adapter:
    """The adapter of a scene, a scene dict, a kind name or a dataset written by this project."""
    if isinstance(thing, xr.Dataset):
        if "scene_kind" not in thing.attrs:
            raise ValueError("this file has no scene_kind attribute: it was not written by this version of hdi "
                             "(regenerate it)")  # fmt: skip
        name = thing.attrs["scene_kind"]
    elif isinstance(thing, str):
        name = thing
    elif isinstance(thing, dict):
        name = thing.get("kind", DEFAULT_KIND)
    else:
        name = thing.kind
    get_kind(name)  # an unknown kind is an error that lists the kinds
    return adapters()[name]


def plot_dataset(ds: xr.Dataset, overlay: xr.Dataset | None = None) -> Any:
    """The figure of a file written by this project: looked up by its ``scene_kind`` and ``product`` attributes.

    ``overlay`` (a boundary study of the same axes) is drawn over a map (scene 1's stability map, scene 2's regime
    map); other figures refuse it.  A study
    whose file names a ``figure`` (``attrs["figure"]``) gets that figure of its kind.
    """
    adapter = adapter_of(ds)
    product = ds.attrs.get("product", "")
    figure = adapter.figures.get(ds.attrs.get("figure") or product)
    if figure is None:
        raise ValueError(
            f"no figure for a {product or 'file without a product attribute'} of kind {adapter.name!r} "
            f"(figures of this kind: {', '.join(adapter.figures) or 'none'})"
        )
    if overlay is None:
        return figure(ds)
    if "overlay" not in inspect.signature(figure).parameters:
        raise ValueError(f"the {ds.attrs.get('figure') or product} figure of kind {adapter.name!r} draws no overlay "
                         "(a boundary study is drawn over a stability or regime map)")  # fmt: skip
    return figure(ds, overlay)
