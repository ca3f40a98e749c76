"""Trace a class boundary by bisection instead of computing the full grid.

The class is the kind's :class:`pipeline.kinds.Traced`: stable against unstable for kind "rails", a regime
below the study's ``threshold`` against at or above it for kind "abs" (flying against touching by default).
For every combination of the other axes (a *line*), the bisected axis
(restitution in Figure 17) is searched on a lattice of spacing ``tolerance``
over its range (or on the axis's own values, ``lattice = "axis"``, e.g. the
log-spaced corner radii of ``studies/fig17_thornton.toml``), assuming one crossing: the low class (stable) on
``stable_side`` of the boundary, the high class on the other.  A study with realisations of a stochastic input
has a line per realisation (the realisation is one of the other axes): each track's own boundary, whose mean and
interval over the realisations the dataset reports.  Lattice indices below the boundary are
called *low*.  With L the probed low indices and H the probed high ones,

    hi = min(H)   (n if none),    lo = max{i in L : i < hi}   (-1 if none),

and the line is done when hi - lo = 1: the bracket is one lattice step wide
(``lo = -1``: the whole range is on the high side; ``hi = n``: on the low side).
Otherwise the next probe is the midpoint of (lo, hi), or, while one end is
still open, a doubling step from the known end toward it (galloping).

Lines are chained along the first other axis (mu): a line starts from the
bracket of the line before it, probing both of its ends at once; since the
boundary moves little from one mu to the next, most lines need two or three
runs instead of the 2 + log2(n) of a cold start (first line of a chain) and
the n of the full grid.  Runs already in the ledger are reused, so a
boundary study after a grid study costs nothing, and the reverse.

A probe whose run failed is skipped (the nearest unprobed index in the
bracket is tried); a low index found above a high one marks the line
non-monotonic: bisection assumes a single crossing, the grid does not.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

from pipeline.kinds import adapter_of
from pipeline.study.spec import Case, Study, lattice, make_case


@dataclass
class Line:
    """Bisection state of one line (fixed values of the other axes)."""

    index: tuple[int, ...]  # indices on the other axes
    n: int  # lattice size
    guess: tuple[int, int] | None = None
    side: dict[int, bool | None] = field(default_factory=dict)  # lattice index -> low side? (None: failed)
    inflight: set[int] = field(default_factory=set)
    gallop: int = 0
    done: bool = False

    def bracket(self) -> tuple[int, int]:
        high = [i for i, low in self.side.items() if low is False]
        hi = min(high, default=self.n)
        lo = max((i for i, low in self.side.items() if low and i < hi), default=-1)
        return lo, hi

    @property
    def monotonic(self) -> bool:
        lo, hi = self.bracket()
        return not any(low and i > hi for i, low in self.side.items())

    def next_probes(self) -> list[int]:
        """Lattice indices to run next (empty when done or waiting for runs in flight)."""
        if self.done or self.inflight:
            return []
        if not self.side:
            if self.guess is not None:
                lo, hi = (min(max(i, 0), self.n - 1) for i in self.guess)
                return sorted({lo, hi})
            return sorted({0, self.n - 1})
        lo, hi = self.bracket()
        if hi - lo <= 1:
            self.done = True
            return []
        if lo == -1 and 0 not in self.side:
            self.gallop += 1
            return [max(0, hi - 2 ** (self.gallop - 1))]
        if hi == self.n and self.n - 1 not in self.side:
            self.gallop += 1
            return [min(self.n - 1, lo + 2 ** (self.gallop - 1))]
        mid = (lo + hi) // 2
        free = [i for i in range(lo + 1, hi) if i not in self.side]
        if not free:  # every index inside the bracket failed: stop with the wider bracket
            self.done = True
            return []
        return [min(free, key=lambda i: (abs(i - mid), i))]


class BisectionPlanner:
    """Planner for :func:`pipeline.run.fanout.execute`: bisect the boundary axis on every line."""

    def __init__(self, study: Study) -> None:
        if study.boundary is None:
            raise ValueError(f"{study.path}: no [boundary] table")
        self.study = study
        self.axis = study.axis(study.boundary.axis)
        self.values = lattice(study)
        self.below = study.boundary.stable_side == "below"
        self.traced = adapter_of(study.base).traced
        self.threshold = study.boundary.threshold
        self.others = [a for a in study.axes if a.key != self.axis.key]
        n = len(self.values)
        chain_axis, rest = (self.others[0], self.others[1:]) if self.others else (None, [])
        self.chains: list[list[Line]] = []
        for rest_ix in itertools.product(*(range(len(a.values)) for a in rest)):
            steps = range(len(chain_axis.values)) if chain_axis else [None]
            chain = [Line(((k,) if k is not None else ()) + rest_ix, n) for k in steps]
            self.chains.append(chain)
        self.lines = [line for chain in self.chains for line in chain]
        self._cases: dict[str, tuple[Line, int]] = {}

    def _case(self, line: Line, i: int) -> Case:
        coords: dict[str, Any] = {}
        overrides: dict[str, Any] = {}
        full_index: list[int] = []
        other = iter(zip(self.others, line.index, strict=True))
        for a in self.study.axes:
            if a.key == self.axis.key:
                value, ix = self.values[i], i
            else:
                axis, ix = next(other)
                value = axis.values[ix]
            coords[a.dim] = value
            overrides[a.key] = value
            full_index.append(ix)
        return make_case(self.study, tuple(full_index), coords, overrides)

    def propose(self) -> list[Case]:
        out: list[Case] = []
        for chain in self.chains:
            for k, line in enumerate(chain):
                if line.done:
                    continue
                if k > 0 and not chain[k - 1].done:
                    break  # wait for the neighbour's bracket
                if k > 0 and line.guess is None and not line.side:
                    lo, hi = chain[k - 1].bracket()
                    line.guess = (lo, hi)
                for i in line.next_probes():
                    case = self._case(line, i)
                    self._cases[case.run_id] = (line, i)
                    line.inflight.add(i)
                    out.append(case)
                if not line.done:
                    break
        return out

    def record(self, case: Case, record: dict[str, Any]) -> None:
        line, i = self._cases[case.run_id]
        line.inflight.discard(i)
        flag = record.get(self.traced.flag)
        low = -1 if flag is None else int(self.traced.classes(flag, self.threshold))
        if record.get("status", -1) == -1 or low == -1:
            line.side[i] = None
        else:
            line.side[i] = bool(low) == self.below

    def expected(self) -> int | None:
        return None

    def summary(self) -> list[dict[str, Any]]:
        """Per line: bracket values (NaN where open), probes used, whether it looked monotonic."""
        out = []
        for line in self.lines:
            lo, hi = line.bracket()
            out.append(
                {
                    "index": line.index,
                    "lower": self.values[lo] if lo >= 0 else float("nan"),
                    "upper": self.values[hi] if hi < line.n else float("nan"),
                    "runs": len(line.side),
                    "monotonic": line.monotonic,
                    "probed": sorted(line.side),
                }
            )
        return out
