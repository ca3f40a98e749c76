"""Classification of a contact sequence by impulse growth (Benson, Chiang & Talke 1989).

A sequence is UNSTABLE if any later impulse exceeds the first one and
STABLE if all later impulses are smaller.  A run with no impact, or a
single one, is stable (nothing grows).  Corners struck at the same instant
share one impact and count as one event (their impulses summed).  ``max_impulse_ratio`` is the largest
later impulse over the first (NaN with fewer than two impacts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FRONT_CORNERS = (0, 2)  # A, C


@dataclass(frozen=True)
class ImpulseGrowth:
    stable: int
    n_impacts: int
    n_larger_than_first: int
    n_front_corner_impacts: int
    first_impulse: float
    max_impulse_ratio: float

    def as_dict(self) -> dict[str, float | int]:
        return dict(self.__dict__)


def impact_events(impulses: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Total impulse of each impact instant: corners struck together (one shared impact) are one event."""
    impulses = np.asarray(impulses, dtype=float)
    times = np.asarray(times, dtype=float)
    if impulses.size == 0:
        return impulses
    starts = np.flatnonzero(np.r_[True, times[1:] != times[:-1]])
    return np.add.reduceat(impulses, starts)


def classify_impulses(impulses: np.ndarray, corners: np.ndarray, times: np.ndarray | None = None) -> ImpulseGrowth:
    """impulses : (n,) [N s] in time order; corners : (n,) corner indices 0..3 (A..D).

    With ``times``, records of the same instant (corners sharing one impact)
    are summed into one event before the growth test, so that how a shared
    impact is split between corners cannot decide the class.
    ``n_impacts`` counts the records (corner strikes).
    """
    corners = np.asarray(corners, dtype=int)
    n_records = len(corners)
    impulses = np.asarray(impulses, dtype=float)
    if times is not None:
        impulses = impact_events(impulses, times)
    n = impulses.size
    first = float(impulses[0]) if n else float("nan")
    later = impulses[1:]
    n_larger = int(np.count_nonzero(later > first)) if n else 0
    return ImpulseGrowth(
        stable=int(n_larger == 0),
        n_impacts=int(n_records),
        n_larger_than_first=n_larger,
        n_front_corner_impacts=int(np.count_nonzero(np.isin(corners, FRONT_CORNERS))),
        first_impulse=first,
        max_impulse_ratio=float(later.max() / first) if n > 1 else float("nan"),
    )
