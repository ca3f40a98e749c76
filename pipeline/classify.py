"""Run classifiers of every kind, and the table of what each one outputs (names, units, long names: once).

Kind "rails", impulse growth (Benson, Chiang & Talke 1989): a sequence is UNSTABLE if any later impulse
exceeds the first one and STABLE if all later impulses are smaller.  A run with no impact, or a single one, is
stable (nothing grows).  Corners struck at the same instant share one impact and count as one event (their
impulses summed).  ``max_impulse_ratio`` is the largest later impulse over the first (NaN with fewer than two
impacts).

Kind "abs", bouncing and contact measures: the 3-sigma of the flying height at the element and the contact,
adhesion and friction forces after the settling time, and the main peaks of the flying-height, pitch and roll
spectra (:func:`solver.abs.integrate.summarize`).

A record is the JSON-ready dict a run returns to a study (:func:`pipeline.run.runner.run_case`); its scalar
fields are the outputs below, which become the study dataset's cell variables.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

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


@dataclass(frozen=True)
class Output:
    """One per-run output: its dtype and fill in a study dataset (where a run has none), units, long name."""

    dtype: Any
    fill: Any
    units: str
    long_name: str
    attrs: Mapping[str, Any] = field(default_factory=dict)


#: Meaning of a count of -1 in a study dataset.
MISSING_COUNT = {"comment": "-1 where the run failed or was not run"}
#: Flags of a run's status (runs, and study cells with the extra "not_run").
STATUS_FLAGS = {"flag_values": np.array([-1, 0, 1], dtype=np.int8), "flag_meanings": "failed completed stopped"}
#: Flags of the impulse-growth class.
STABLE_FLAGS = {"flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "unstable stable"}
#: Status of a study cell that no run has filled.
NOT_RUN = -2

#: Regimes of an "abs" run (flag values), and the contact fraction at or above which contact is sustained.
REGIMES = ("flying", "intermittent_contact", "sustained_contact", "stuck")
SUSTAINED_FRACTION = 0.5
REGIME_FLAGS = {"flag_values": np.arange(len(REGIMES), dtype=np.int8), "flag_meanings": " ".join(REGIMES)}


def abs_regime(contact_fraction: float, flies: bool) -> int:
    """The regime of an "abs" run, from its contact fraction after settling and whether the scene flies.

    stuck: the scene has no equilibrium at all, neither flying nor held up by contact beyond the flying
    branch's fold (the run started from the flight without adhesion), or the pad is in contact at every
    sample; sustained contact: in contact at SUSTAINED_FRACTION of the samples or more;
    intermittent contact: in contact at some samples; flying: at none.  A sample is in contact when its
    contact force exceeds ``numerics.contact_threshold``.  -1: no samples (a failed run).
    """
    if contact_fraction != contact_fraction:
        return -1
    if not flies or contact_fraction >= 1.0:
        return REGIMES.index("stuck")
    if contact_fraction >= SUSTAINED_FRACTION:
        return REGIMES.index("sustained_contact")
    return REGIMES.index("intermittent_contact") if contact_fraction > 0.0 else REGIMES.index("flying")


#: Outputs every kind has.
COMMON_OUTPUTS: dict[str, Output] = {
    "status": Output(np.int8, NOT_RUN, "1", "run status", {
        "flag_values": np.array([NOT_RUN, *STATUS_FLAGS["flag_values"]], dtype=np.int8),
        "flag_meanings": "not_run " + STATUS_FLAGS["flag_meanings"]}),
    "message": Output(object, "", "", "status message of the run (the error of a failed run)"),
    "steps": Output(np.int32, -1, "1", "time steps taken", MISSING_COUNT),
    "newton_iterations": Output(np.int32, -1, "1", "Newton iterations", MISSING_COUNT),
    "wall_time": Output(np.float64, np.nan, "s", "wall time of the run on its worker"),
}  # fmt: skip

#: Outputs of a "rails" run (impulse growth), in the order a study keeps them by default.
RAILS_OUTPUTS: dict[str, Output] = {
    "stable": Output(np.int8, -1, "1", "impulse-growth classification (unstable if a later impulse exceeds the first)",
                     {"flag_values": np.array([-1, *STABLE_FLAGS["flag_values"]], dtype=np.int8),
                      "flag_meanings": "not_classified " + STABLE_FLAGS["flag_meanings"]}),
    "status": COMMON_OUTPUTS["status"],
    "message": COMMON_OUTPUTS["message"],
    "n_impacts": Output(np.int32, -1, "1", "number of impacts", MISSING_COUNT),
    "n_larger_than_first": Output(np.int32, -1, "1", "impacts larger than the first", MISSING_COUNT),
    "n_front_corner_impacts": Output(np.int32, -1, "1", "impacts at the front corners A, C", MISSING_COUNT),
    "first_impulse": Output(np.float64, np.nan, "N s", "first impulse"),
    "max_impulse_ratio": Output(np.float64, np.nan, "1", "largest later impulse / first impulse"),
    "first_impact_time": Output(np.float64, np.nan, "s", "time of the first impact"),
    "steps": COMMON_OUTPUTS["steps"],
    "newton_iterations": COMMON_OUTPUTS["newton_iterations"],
    "wall_time": COMMON_OUTPUTS["wall_time"],
    "first_impact_velocity": Output(np.float64, np.nan, "m s-1",
                                    "normal approach speed U + eps V of the first impact (wedging included)"),
    "first_impact_alpha": Output(np.float64, np.nan, "1", "coefficient of restitution applied at the first impact"),
    "first_yield_velocity": Output(np.float64, np.nan, "m s-1",
                                   "Thornton's yield velocity at the first impact (NaN under the constant law)"),
}  # fmt: skip

#: Outputs of a "rails" run about its restitution law: kept by a study that lists them in [outputs] variables
#: (the other studies' datasets stay as they were before the law could be chosen).
RAILS_RESTITUTION_OUTPUTS = ("first_impact_velocity", "first_impact_alpha", "first_yield_velocity")

#: Outputs of an "abs" run (bouncing and contact measures), in the order a study keeps them by default.
ABS_OUTPUTS: dict[str, Output] = {
    "status": COMMON_OUTPUTS["status"],
    "message": COMMON_OUTPUTS["message"],
    "regime": Output(np.int8, -1, "1", "regime of the run (rule: pipeline.classify.abs_regime)",
                     {"flag_values": np.array([-1, *REGIME_FLAGS["flag_values"]], dtype=np.int8),
                      "flag_meanings": "not_classified " + REGIME_FLAGS["flag_meanings"]}),
    "bouncing_3sigma": Output(np.float64, np.nan, "m", "3 sigma of the flying height at the element after settling"),
    "mean_flying_height": Output(np.float64, np.nan, "m", "mean flying height at the element after settling"),
    "min_clearance": Output(np.float64, np.nan, "m",
                            "smallest spacing of the face to the resolved disk surface after settling"),
    "mean_contact_force": Output(np.float64, np.nan, "N", "mean normal contact force after settling"),
    "max_contact_force": Output(np.float64, np.nan, "N", "largest normal contact force after settling"),
    "contact_fraction": Output(np.float64, np.nan, "1",
                               "fraction of samples with contact force above numerics.contact_threshold"),
    "mean_adhesion_force": Output(np.float64, np.nan, "N", "mean adhesion force (negative: towards the disk)"),
    "mean_friction_force": Output(np.float64, np.nan, "N", "mean friction force"),
    "fh_peak_frequency": Output(np.float64, np.nan, "Hz", "main peak of the flying-height spectrum"),
    "pitch_peak_frequency": Output(np.float64, np.nan, "Hz", "main peak of the pitch spectrum"),
    "roll_peak_frequency": Output(np.float64, np.nan, "Hz", "main peak of the roll spectrum"),
    "steady_flying_height": Output(np.float64, np.nan, "m", "steady flying height at the element (smooth mean disk)"),
    "steady_pitch": Output(np.float64, np.nan, "rad", "steady pitch"),
    "steady_roll": Output(np.float64, np.nan, "rad", "steady roll"),
    "steady_contact_force": Output(np.float64, np.nan, "N", "steady contact force (statistical roughness)"),
    "steps": COMMON_OUTPUTS["steps"],
    "newton_iterations": COMMON_OUTPUTS["newton_iterations"],
    "substeps": Output(np.int32, -1, "1",
                       "accepted steps and substeps (a step split for contact counts each of its substeps)",
                       MISSING_COUNT),
    "contact_damped": Output(np.int32, -1, "1",
                             "contact substeps taken with numerics.rho_infinity_contact (contact too stiff even "
                             "for the finest substep)", MISSING_COUNT),
    "reynolds_solves": Output(np.int32, -1, "1", "Reynolds solves of the film (its steps and derivative refreshes)",
                              MISSING_COUNT),
    "wall_time": COMMON_OUTPUTS["wall_time"],
}  # fmt: skip

#: Summary values of an "abs" run that only its own dataset keeps (not a study's cells).
ABS_RUN_ONLY_OUTPUTS: dict[str, Output] = {
    "fh_peak_amplitude": Output(np.float64, np.nan, "m", "amplitude of the flying-height spectrum's main peak"),
    "pitch_peak_amplitude": Output(np.float64, np.nan, "rad", "amplitude of the pitch spectrum's main peak"),
    "roll_peak_amplitude": Output(np.float64, np.nan, "rad", "amplitude of the roll spectrum's main peak"),
}

#: Time series of an "abs" run that a study keeps (as histories on a ``time`` dimension).
ABS_SERIES_KEPT = ("flying_height", "contact_force")
#: Amplitude spectra of an "abs" run after settling that a study keeps (on a ``frequency`` dimension):
#: name -> (units, long name).  :func:`solver.abs.integrate.spectrum` of the signal, as in a run's file.
ABS_SPECTRA_KEPT = {
    "flying_height": ("m", "amplitude spectrum of the flying height after settling"),
    "pitch": ("rad", "amplitude spectrum of the pitch after settling"),
    "roll": ("rad", "amplitude spectrum of the roll after settling"),
}


def rails_record(scene: Any, result: Any, impacts_kept: int) -> dict[str, Any]:
    """The study record of a "rails" run: impulse growth, status, work, the first impacts."""
    impacts = result.impacts
    growth = classify_impulses([i.impulse for i in impacts], [i.corner for i in impacts], [i.time for i in impacts])
    return {
        **growth.as_dict(),
        "status": int(result.status),
        "message": result.message,
        "first_impact_time": impacts[0].time if impacts else float("nan"),
        "first_impact_velocity": impacts[0].approach_before if impacts else float("nan"),
        "first_impact_alpha": impacts[0].alpha if impacts else float("nan"),
        "first_yield_velocity": impacts[0].yield_velocity if impacts else float("nan"),
        "steps": int(result.work["steps"]),
        "newton_iterations": int(result.work["newton_iterations"]),
        "impacts": {
            "time": [i.time for i in impacts[:impacts_kept]],
            "corner": [i.corner_letter for i in impacts[:impacts_kept]],
            "impulse": [i.impulse for i in impacts[:impacts_kept]],
        },
    }


def abs_record(scene: Any, result: Any, impacts_kept: int) -> dict[str, Any]:
    """The study record of an "abs" run: bouncing and contact measures, the steady flight, the kept histories."""
    from solver.abs.integrate import summarize

    steady = result.steady
    summary = summarize(result, scene)
    return {
        **summary,
        "regime": abs_regime(summary["contact_fraction"], not steady.note),
        "status": int(result.status),
        "message": result.message,
        "steps": int(result.work["steps"]),
        "newton_iterations": int(result.work["newton_iterations"]),
        "substeps": int(result.work["substeps"]),
        "contact_damped": int(result.work["contact_damped"]),
        "reynolds_solves": int(result.work["reynolds_solves"]),
        "steady_flying_height": steady.element_spacing,
        "steady_pitch": float(steady.q[1]),
        "steady_roll": float(steady.q[2]),
        "steady_contact_force": steady.surface.contact,
        "steady_note": steady.note,
        "steady_branch": steady.branch,
        "series": {"time": result.t.tolist(), **{k: result.series[k].tolist() for k in ABS_SERIES_KEPT}},
        "spectra": _abs_spectra(scene, result),
    }


def _abs_spectra(scene: Any, result: Any) -> dict[str, list[float]]:
    """The kept spectra of a run after settling, with their ``frequency`` [Hz] (as in its run file)."""
    from solver.abs.integrate import settled_spectra

    freq, spectra = settled_spectra(result, scene)
    return {"frequency": freq.tolist(), **{name: spectra[name].tolist() for name in ABS_SPECTRA_KEPT}}
