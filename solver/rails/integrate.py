"""Time integration of the slider on its film with impacts at the rail corners.

Stepper (one step of size s from t_n):

    a_n       = M^-1 (f_film(P_n) + f_susp(q_n))
    v_half    = v_n + s/2 a_n
    q_{n+1}   = q_n + s v_half                 (exact quadratic in s)
    P_{n+1}   = film step over s, attitude moving linearly q_n -> q_{n+1}
    v_{n+1}   = v_half + s/2 a_{n+1}

i.e. velocity Verlet around the implicit-midpoint film step: second order,
and stable while s omega < 2 for the film's stiffness (omega ~ 2e5 rad/s for
scene 1, so s << 10 us).

Events: on a step, each corner spacing is the quadratic
h_k(s) = h_k(0) - U_k s + (n_k . a_n) s^2 / 2, so the first instant s* at
which a corner reaches the asperity height is its exact root on the
discrete trajectory.  The step is retaken with size s*, the impact map is
applied, and the next step returns to the uniform time grid t_k = k dt
(output samples stay on it).  The event tolerance is the spacing error of
the root, |h_k(s*) - h0| < 1e-9 h0 (checked), i.e. a time tolerance of
about 1e-9 h0 / U.

The driver returns a flat :class:`Result` (scipy's solve_ivp contract):
``t``, states, ``impacts``, ``status`` (0 reached t_end, 1 stopped on the
impact limit, -1 failed), ``message`` and work counters.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from solver.kernels import motion as km
from solver.rails.bearings import make_air_bearing
from solver.rails.contact import ContactError, Impact, SustainedContact, corner_normal, resolve_impacts
from solver.rails.dynamics import mass_matrix
from solver.rails.film import ReynoldsFilm
from solver.rails.geometry import corner_positions
from solver.rails.params import Scene
from solver.rails.steady import SteadyFlight, fly
from solver.store import ArrayStore

log = logging.getLogger(__name__)

#: A corner touches the asperities when its spacing is within this fraction of h0 of them (the event root's
#: spacing error, checked after every located event).
TOUCH_TOLERANCE = 1e-9
#: ... and h0 is taken as at least this [m] in that tolerance (a zero asperity height).
TOUCH_FLOOR = 1e-9
#: Relative slack in comparisons of times and step sizes (round-off of sums of steps).
TIME_ROUND_OFF = 1e-12
#: Contact events in a row that change nothing before the run is stopped (a grazing corner with the rule off).
MAX_STALLS = 100
#: Adaptive steps: safety factor on the optimal step, and the bounds of the step ratio.
STEP_SAFETY = 0.9
MAX_STEP_GROWTH = 2.0
MIN_STEP_SHRINK = 0.2


@dataclass
class Result:
    """Flat result of one run (SI units)."""

    t: np.ndarray
    q: np.ndarray  # (nt, 3) z [m], pitch, roll [rad]
    v: np.ndarray  # (nt, 3)
    corner_spacing: np.ndarray  # (nt, 4) [m], A..D
    air_force: np.ndarray  # (nt, 3) film generalized forces [N, N m, N m]
    impacts: list[Impact]
    status: int
    message: str
    steady: SteadyFlight
    work: dict[str, float] = field(default_factory=dict)
    sustained: list[tuple[float, float, int]] = field(default_factory=list)  # (start, end, corner)

    @property
    def min_spacing(self) -> np.ndarray:
        return self.corner_spacing.min(axis=1)

    @property
    def series(self) -> dict[str, np.ndarray]:
        """The time series of :data:`solver.rails.params.SERIES` by name."""
        return {
            "z": self.q[:, 0], "pitch": self.q[:, 1], "roll": self.q[:, 2],
            "zdot": self.v[:, 0], "pitch_rate": self.v[:, 1], "roll_rate": self.v[:, 2],
            "min_spacing": self.min_spacing, "corner_spacing": self.corner_spacing, "air_load": self.air_force[:, 0],
        }  # fmt: skip


def simulate(scene: Scene, steady: SteadyFlight | None = None, store: ArrayStore | None = None) -> Result:
    """Integrate one run of ``scene`` from steady flight plus the initial velocities.

    ``store`` keeps the tables of the reduced air-bearing models (:func:`solver.rails.bearings.make_air_bearing`;
    None: this process's memory).
    """
    wall0 = time.perf_counter()
    bearing = make_air_bearing(scene, store=store)
    if steady is None:
        steady = fly(scene, film=bearing.reynolds)
    bearing.start(steady)
    sus = steady.suspension
    suspension = np.array(
        [
            sus.preload,
            sus.static_pitch_moment,
            sus.static_roll_moment,
            sus.pitch_stiffness,
            sus.roll_stiffness,
        ]
    )
    q = steady.q.copy()
    init = scene.initial
    v = np.array([init.zdot, init.pitch_rate, init.roll_rate])
    num = scene.numerics
    minv = np.linalg.inv(mass_matrix(scene.slider))
    corners = corner_positions(scene.slider)
    normals = np.array([corner_normal(x1, x2) for x1, x2 in corners])
    h0 = scene.disk.asperity_height
    touch_tol = TOUCH_TOLERANCE * max(h0, TOUCH_FLOOR)
    f_air = np.empty(3)
    bearing.forces(q, v, f_air)
    acc = np.empty(3)
    km.accelerations(f_air, q, suspension, minv, acc)
    start_gaps = normals @ q - h0
    if np.any(start_gaps < -touch_tol):
        letters = ", ".join(f"{c} {(g + h0) * 1e9:.2f} nm" for c, g in zip("ABCD", start_gaps, strict=True))
        raise ContactError(
            f"a corner starts below the asperity height disk.asperity_height = {h0 * 1e9:.2f} nm ({letters})",
            hint="a starting attitude (calibration.*) that keeps every flat corner above the asperities",
        )
    contact = SustainedContact(scene, normals, minv, h0)
    out = _Samples(q, v, f_air, num)
    impacts: list[Impact] = []
    stepper = _Stepper(num)
    status, message = 0, "reached t_end"
    t = 0.0
    stalls = 0

    def impact_now() -> bool:
        """Resolve the contacts at t (impacts, holds); True when the impact limit is reached."""
        nonlocal v, stalls
        n_before, held_before = len(impacts), contact.held.copy()
        v = resolve_impacts(scene, q, v, t, contact, acc, impacts, touch_tol)
        stalls = _stalled(stalls, len(impacts) == n_before and (contact.held == held_before).all(), t)
        if contact.any_held:
            km.accelerations(f_air, q, suspension, minv, acc)
            contact.apply_forces(acc, t)
        out.after_impact(t, q, v, f_air)
        return len(impacts) >= scene.contact.max_impacts

    try:
        while not stepper.done(t):
            s_max = stepper.proposal(t)
            free = contact.free
            s_event, hit = km.first_event(normals[free], q, v, acc, h0, s_max)
            if hit >= 0 and s_event == 0.0:  # touching and approaching now: resolve before any step
                if impact_now():
                    status = 1
                    message = f"stopped after {len(impacts)} impacts (contact.max_impacts) at t = {t:.6g} s"
                    break
                continue
            event = hit >= 0 and s_event < s_max * (1.0 - TIME_ROUND_OFF)
            s = s_event if event else s_max
            q_prev, v_prev, acc_prev, f_prev = q.copy(), v.copy(), acc.copy(), f_air.copy()
            if stepper.adaptive:
                bearing.save()
                contact.save()
            stepper.newton += bearing.advance(s, q, v, acc, f_air, minv, suspension)
            stepper.steps += 1
            if contact.any_held:
                contact.constrain(s, t + s, q, v, acc)
            if not (np.isfinite(f_air).all() and np.isfinite(q).all()):
                raise FloatingPointError(f"the state became non-finite at t = {t + s:.6g} s")
            if stepper.adaptive and not stepper.accept(s, normals, free, acc - acc_prev):
                bearing.restore()
                contact.restore()
                q[:], v[:], acc[:], f_air[:] = q_prev, v_prev, acc_prev, f_prev
                continue
            t_new = stepper.advanced(t, s, event)
            out.record(t, t_new, q_prev, v_prev, f_prev, q, v, f_air, stepper)
            t = t_new
            if not event:
                continue
            c = int(np.flatnonzero(free)[hit])
            gap_hit = float(normals[c] @ q - h0)
            if abs(gap_hit) > touch_tol:
                raise ContactError(f"event location missed the asperity height by {gap_hit:.3g} m")
            if impact_now():
                status = 1
                message = f"stopped after {len(impacts)} impacts (contact.max_impacts) at t = {t:.6g} s"
                break
    except (ContactError, FloatingPointError, np.linalg.LinAlgError) as err:
        status, message = -1, f"{type(err).__name__}: {err}"
        log.warning("run failed: %s", message)
    contact.finish(t)
    if isinstance(bearing, ReynoldsFilm):
        bearing.work.reynolds_solves += stepper.steps
    bearing.work.newton_iterations += stepper.newton
    work = {
        "steps": stepper.steps,
        "reynolds_solves": bearing.work.reynolds_solves,
        "newton_iterations": stepper.newton,
        "rejected_steps": stepper.rejected,
        "smallest_step": stepper.smallest,
        "largest_step": stepper.largest,
        "impacts": len(impacts),
        "sustained_contacts": len(contact.intervals),
        "sustained_contact_time": sum(b - a for a, b, _ in contact.intervals),
        "table_outside_steps": getattr(bearing, "outside_steps", 0),
        "model_build_seconds": getattr(bearing, "build_seconds", 0.0),
        "wall_time": time.perf_counter() - wall0,
    }
    ts, qs_arr, vs, fs = out.arrays()
    return Result(
        t=ts,
        q=qs_arr,
        v=vs,
        corner_spacing=qs_arr @ normals.T,
        air_force=fs,
        impacts=impacts,
        status=status,
        message=message,
        steady=steady,
        work=work,
        sustained=contact.intervals,
    )


def _stalled(stalls: int, nothing_happened: bool, t: float) -> int:
    """Count contact events in a row that changed nothing; a grazing corner with the rule off would loop."""
    stalls = stalls + 1 if nothing_happened else 0
    if stalls > MAX_STALLS:
        raise ContactError(
            f"contact events stall at t = {t:.6g} s: a corner grazes the asperities without impact "
            "(contact.rest_velocity = 0 turns the chattering rule off)"
        )
    return stalls


class _Stepper:
    """Step sizes: the uniform grid t_k = k dt (fixed), or a local-error controller (adaptive).

    Adaptive: Verlet's local position error is s^3 q'''/6 ~ s^2 (a_{n+1} - a_n) / 6.
    Measured as corner spacing, err = max_c |n_c . (a_{n+1} - a_n)| s^2 / 6 must
    stay below ``step_tol`` [m]; a step above it is rejected and retaken.  The
    next step is s (tol / err)^(1/3) with safety 0.9, growth at most 2x, at most
    ``dt_max``.  Event-shortened steps are checked the same way; after one the
    controller resumes from the step it had proposed.
    """

    def __init__(self, num) -> None:
        self.num = num
        self.adaptive = num.time_step == "adaptive"
        self.dt, self.t_end = num.dt, num.t_end
        self.n_grid = int(round(num.t_end / num.dt))
        self.k = 0
        self.s_next = num.dt
        self.steps = self.newton = self.rejected = 0
        self.smallest, self.largest = np.inf, 0.0

    def done(self, t: float) -> bool:
        if self.adaptive:
            return t >= self.t_end * (1.0 - TIME_ROUND_OFF)
        return self.k >= self.n_grid

    def proposal(self, t: float) -> float:
        if self.adaptive:
            return min(self.s_next, self.num.dt_max, self.t_end - t)
        return (self.k + 1) * self.dt - t  # short after an impact: back onto the grid

    def accept(self, s: float, normals: np.ndarray, free: np.ndarray, dacc: np.ndarray) -> bool:
        err = km.spacing_error(normals, free, dacc, s) / self.num.step_tol
        growth = MAX_STEP_GROWTH if err == 0.0 else STEP_SAFETY * err ** (-1.0 / 3.0)
        factor = min(MAX_STEP_GROWTH, max(MIN_STEP_SHRINK, growth))
        if err > 1.0:
            self.rejected += 1
            self.s_next = s * factor
            return False
        shortened = s < self.s_next * (1.0 - TIME_ROUND_OFF)
        self.s_next = max(self.s_next, s * factor) if shortened else s * factor
        return True

    def advanced(self, t: float, s: float, event: bool) -> float:
        self.smallest = min(self.smallest, s)
        self.largest = max(self.largest, s)
        if self.adaptive or event:
            return t + s
        self.k += 1
        return self.k * self.dt


class _Samples:
    """Stored time series.

    Fixed steps: every ``output_interval`` on the uniform grid.  Adaptive:
    every accepted step is kept, and at the end the series is resampled at
    multiples of ``output_interval`` by cubic Hermite interpolation of
    (q, v) between steps (linear for the film forces); with 0, every step.
    """

    def __init__(self, q: np.ndarray, v: np.ndarray, f: np.ndarray, num) -> None:
        self.t, self.q, self.v, self.f = [0.0], [q.copy()], [v.copy()], [f.copy()]
        self.adaptive = num.time_step == "adaptive"
        self.interval = num.output_interval

    def record(self, t0, t1, q0, v0, f0, q1, v1, f1, stepper: _Stepper) -> None:
        num = stepper.num
        if stepper.adaptive:
            if t1 > self.t[-1]:
                self._append(t1, q1, v1, f1)
            return
        k = stepper.k
        if t1 == k * stepper.dt and (k % num.output_every == 0 or k == stepper.n_grid):
            self._append(t1, q1, v1, f1)

    def after_impact(self, t: float, q: np.ndarray, v: np.ndarray, f: np.ndarray) -> None:
        """Adaptive: the post-impact state at the impact instant, so that interpolation after it starts there."""
        if self.adaptive and self.t[-1] == t:
            self._append(t, q, v, f)

    def _append(self, t, q, v, f) -> None:
        self.t.append(float(t))
        self.q.append(q.copy())
        self.v.append(v.copy())
        self.f.append(f.copy())

    def arrays(self):
        t, q, v, f = np.array(self.t), np.array(self.q), np.array(self.v), np.array(self.f)
        if not self.adaptive or self.interval <= 0.0 or t.size < 2:
            return t, q, v, f
        n = int(np.floor(t[-1] / self.interval * (1.0 + TIME_ROUND_OFF)))
        ts = self.interval * np.arange(n + 1)
        if ts[-1] < t[-1] * (1.0 - TIME_ROUND_OFF):
            ts = np.append(ts, t[-1])
        i = np.clip(np.searchsorted(t, ts, side="right") - 1, 0, t.size - 2)
        h = (t[i + 1] - t[i])[:, None]
        h = np.where(h > 0.0, h, 1.0)  # an impact at the very end leaves a zero-length pair
        x = (ts - t[i])[:, None] / h
        h00, h10, h01, h11 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x, -2 * x**3 + 3 * x**2, x**3 - x**2
        d00, d10, d01, d11 = 6 * x**2 - 6 * x, 3 * x**2 - 4 * x + 1, -6 * x**2 + 6 * x, 3 * x**2 - 2 * x
        q0, q1, v0, v1 = q[i], q[i + 1], v[i], v[i + 1]
        qs = h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1
        vs = (d00 * q0 + d01 * q1) / h + d10 * v0 + d11 * v1
        fs = (1.0 - x) * f[i] + x * f[i + 1]
        return ts, qs, vs, fs
