"""Multi-fidelity maps: the whole grid with a cheap model, the full model only next to the boundary.

Study mode ``multifidelity`` with a ``[multifidelity.cheap]`` table of scene
keys for the cheap pass (an air-bearing level, a coarser grid, a longer
step ...).  Waves:

1. every cell with the cheap scene;
2. every cell that differs in class from a neighbour (one step along any
   axis listed in ``[multifidelity] axes``, default all) in the current
   map, and every failed cell, is re-run with the study's own (full) scene;
3. the map is updated with the full results; if that creates new class
   changes next to cells not yet re-run, they are re-run too, until no
   wave is left.

The dataset holds the final map (full results where re-run) and, per cell,
``stable_cheap`` and ``refined``; its attributes count the re-run cells and
those whose class changed.  Cheap and full runs have different run ids, so
both kinds sit in the same ledger and an interrupted study resumes either.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import numpy as np

from pipeline.config import apply_overrides
from pipeline.study.spec import Case, Study


def cheap_study(study: Study) -> Study:
    """The study with the cheap pass's scene keys applied to its base scene."""
    assert study.multifidelity is not None
    base = apply_overrides(study.base, study.multifidelity, source=f"{study.path} [multifidelity.cheap]")
    return dataclasses.replace(study, base=base, mode="grid")


def _flag(record: dict[str, Any]) -> int:
    if record.get("status", -1) == -1:
        return -1
    return 1 if record.get("stable") else 0


class MultiFidelityPlanner:
    """Proposes the cheap grid, then waves of full-model runs along the class boundaries."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self.cheap = cheap_study(study)
        self.cheap_cases = self.cheap.cases()
        self.cheap_ids = {c.run_id for c in self.cheap_cases}
        full_ids = {study.case(c.index).run_id for c in self.cheap_cases[:1]}
        if full_ids & self.cheap_ids:
            raise ValueError(f"{study.path}: [multifidelity.cheap] does not change the scene; nothing would be cheaper")
        self.shape = study.shape
        keys = [a.key for a in study.axes]
        self.neighbour_axes = [keys.index(k) for k in (study.multifidelity_axes or keys)]
        self.cheap_flags = np.full(self.shape, -2, dtype=np.int8)
        self.full_flags = np.full(self.shape, -2, dtype=np.int8)
        self.refined: set[tuple[int, ...]] = set()
        self.full_ids: set[str] = set()
        self.outstanding = 0
        self.started = False
        self.waves: list[int] = []

    def expected(self) -> int | None:
        return None

    def propose(self) -> list[Case]:
        if not self.started:
            self.started = True
            self.outstanding = len(self.cheap_cases)
            return list(self.cheap_cases)
        if self.outstanding > 0:
            return []
        wave = sorted(self._next_wave())
        if not wave:
            return []
        self.waves.append(len(wave))
        cases = [self.study.case(ix) for ix in wave]
        self.refined.update(wave)
        self.full_ids.update(c.run_id for c in cases)
        self.outstanding = len(cases)
        return cases

    def record(self, case: Case, record: dict[str, Any]) -> None:
        self.outstanding -= 1
        target = self.full_flags if case.run_id in self.full_ids else self.cheap_flags
        target[case.index] = _flag(record)

    def current(self) -> np.ndarray:
        """The map now: full results where re-run, cheap ones elsewhere."""
        return np.where(self.full_flags != -2, self.full_flags, self.cheap_flags)

    def _next_wave(self) -> set[tuple[int, ...]]:
        flags = self.current()
        wave: set[tuple[int, ...]] = set()
        for ix in itertools.product(*(range(n) for n in self.shape)):
            if flags[ix] == -1:
                wave.add(ix)
            for axis in self.neighbour_axes:
                if ix[axis] + 1 < self.shape[axis]:
                    nb = ix[:axis] + (ix[axis] + 1,) + ix[axis + 1 :]
                    if flags[ix] != flags[nb]:
                        wave.update((ix, nb))
        return wave - self.refined

    def summary(self) -> dict[str, Any]:
        refined = np.zeros(self.shape, dtype=np.int8)
        for ix in self.refined:
            refined[ix] = 1
        changed = (refined == 1) & (self.full_flags != self.cheap_flags)
        return {
            "stable_cheap": self.cheap_flags.copy(),
            "refined": refined,
            "cells": int(np.prod(self.shape)),
            "cells_refined": int(refined.sum()),
            "cells_changed": int(changed.sum()),
            "waves": list(self.waves),
        }


def add_multifidelity(ds, study: Study, summary: dict[str, Any]) -> None:
    """The cheap map, the re-run cells and their counts, into a study dataset (in place)."""
    import json

    from pipeline.data.netcdf import var

    dims = study.dims
    ds["stable_cheap"] = var(
        summary["stable_cheap"], dims, "1", "class with the cheap scene (1 stable, 0 unstable, -1 failed)"
    )
    ds["refined"] = var(summary["refined"], dims, "1", "1 where the cell was re-run with the full scene")
    ds.attrs["multifidelity_cheap"] = json.dumps(study.multifidelity, sort_keys=True)
    ds.attrs["cells_refined"] = summary["cells_refined"]
    ds.attrs["cells_changed"] = summary["cells_changed"]
    ds.attrs["refinement_waves"] = ", ".join(str(w) for w in summary["waves"])
