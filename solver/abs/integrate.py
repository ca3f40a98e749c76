"""Partial-contact dynamics of an ABS slider over a moving rough track (scene kind "abs").

State q = (z, pitch, roll) about the pivot (:mod:`solver.abs.params`).
Equations of motion

    M q'' + C q' + K (q - q_s) = f_s + f_air(q, t) + f_surface(q, t),

with the suspension's springs K and dampers C acting about the steady
attitude q_s, its preload and static moments f_s = (-F, M_p, M_r), the
film's generalized forces f_air and the surface forces on every cell of
the face: asperity (Greenwood-Williamson) or elastic (influence-coefficient)
contact pressure p_c, adhesion p_a and Coulomb friction mu p_c along the
disk's motion.  With the cell's spacing derivative b = (1, -(x - xp),
-(y - yp)) and the pivot a height t above the face,

    f_surface = sum_cells A [(p_c + p_a) b + mu p_c (0, -t cos psi, -t sin psi)].

Time integration: the generalized-alpha method (Chung & Hulbert 1993), a
Newmark-beta scheme whose equation of motion is balanced between the ends
of the step,

    M [(1 - am) a_n+1 + am a_n] + C [...] + K [...] = (1 - af) f_n+1 + af f_n,
    am = (2 rho - 1)/(rho + 1), af = rho/(rho + 1), gamma = 1/2 - am + af, beta = (1 - am + af)^2 / 4,

second order, with spectral radius rho (``numerics.rho_infinity``) at
infinite frequency: rho = 1 is the trapezoidal (average-acceleration)
Newmark rule.  The asperity contact's modes (MHz) are stiff and
hardening, and a step that does not resolve them can feed them energy:
chen_bogy2007's trailing pad landing at 1 mm/s on the asperities (no air,
no suspension; ``tests/test_partial.py``) leaves with E_after / E_before
= 1.75, 0.992, 0.998, 1.0002 at dt = 0.2, 0.1, 0.05, 0.025 us under the
trapezoidal rule, 0.84, 0.86, 0.90, 0.96 with rho = 0 (never more than
1), and 1.41, 0.965, 0.986, 0.996 with rho = 0.5.  But rho < 1 also damps
the resolved modes: the film's second pitch mode (728 kHz, damping ratio
0.16 % on chen_bogy2007, :mod:`solver.abs.modes`) gets 0.107 from rho = 0
at dt = 0.2 us and 5.1e-3 at 0.05 us, and its response to the track, which
dominates the bouncing at the element, was set by the step (the 3-sigma
doubled with every halving of dt).  The default, rho = 0.9 at dt = 0.1 us,
adds 6.7e-6 to that mode (rho = 0.5 at 0.05 us, the default until
November 2026, added 2.2e-4), and leaves the unresolved contact modes to
contact substeps (below: ``numerics.contact_omega_dt`` = 0.5, at most
eight substeps: with four, the 80-um trailing pad's sustained contact at dt 0.1 us ran
in rho-0 substeps and was held down, 3-sigma 0.77-0.86 nm against 2.54-2.63 nm at dt
0.025 us; README, "Scene 2 results"); the film's derivatives are refreshed every 50
steps (5 us).
Over 8 tracks it agrees with dt = 0.025 us on the 3-sigma and the contact
force within their intervals, and its mean flying height is 13 pm low
(README, "Scene 2 benchmark").  One step t_n -> t_n+1:

1. predictor: the film is advanced along an attitude path q_n -> q*, with
   the disk moved to t_n+1 (:meth:`solver.abs.film.AbsFilm.step`), giving
   f_air at t_n+1;
2. Newton's method on a_n+1 with the Newmark relations
   q = q_n + dt v_n + dt^2 ((1/2 - beta) a_n + beta a_n+1),
   v = v_n + dt ((1 - gamma) a_n + gamma a_n+1), the surface forces and
   their exact Jacobian implicit (one kernel for the Greenwood-Williamson
   law, :mod:`solver.kernels.newmark`).

``numerics.film_coupling`` says how the film follows the corrected attitude:

* "two_pass": q* is the Newmark attitude of a_n+1 = a_n, f_air is explicit in
  the Newton solve, and the film is advanced again along the corrected path
  q_n -> q_n+1 and Newton repeated: two film solves per step, one fixed-point
  iteration of the film-structure coupling.
* "linearized" (default): q* is the Newmark attitude of the extrapolated
  a_n + dt (a_n - a_n-1) / dt_n-1, and the film's step is linear in the end
  attitude about its path, P_n+1(q) = P_n+1(q*) + S (q - q*), f_air(q) =
  f_air(q*) + K_f (q - q*), with S = dP_n+1/dq_n+1 and K_f its forces from
  forward differences of the film step (three extra film solves every
  ``numerics.film_jacobian_every`` steps).  f_air is implicit in the Newton
  solve (K_f in its Jacobian), and the film is set to P_n+1(q_n+1): one film
  solve per step.  Where the corrected attitude moves a corner of the face
  farther than ``numerics.film_repass`` from q* (a hard contact), the film is
  advanced again along q_n -> q_n+1 and linearized about it.  The explicit
  coupling alone (no S, K_f) is unstable at the default step: the pad's film
  stiffness gives omega^2 dt^2 = 1.03 (measured K_f = 4.7e6 N/m in z).

``numerics.film_predictor`` says where the linearized film's path comes from.  "tangent" (default) solves the
step's own Newton problem, the surface forces as they are, with the film force on its tangent about the present
state, f_n + K_f (q - q_n), and advances the film along that solution's attitude: the linear correction then
carries far less (on a smooth drop the coupling error falls 7-8 times), for one more Newton solve per step.
"extrapolated" takes the Newmark attitude of the extrapolated acceleration above: with derivatives a few steps old
its larger correction grows the film's 728-kHz mode on a rough track (1 of 16 tracks in hard contact at dt 0.1
us).  "linear_model" adds to the tangent the last step's change that K_f does not explain (the disk, the squeeze)
and linearizes the surface forces (one 3 x 3 solve): the smallest error on a smooth drop, but on a rough track
that change is the last step's disk forcing, carried into the next step's path, and the bouncing comes out about
10 % below the converged coupling's at dt 0.1 us (README, "The film's predictor").

``numerics.contact_omega_dt`` > 0 splits a step of dt into 2^j equal substeps (j <= ``numerics.contact_splits``)
where the surface forces' stiffness K_s needs it: omega_c h <= contact_omega_dt with omega_c^2 the largest
eigenvalue of M^-1 K_s, at the step's start and at every substep's end (a substep whose end needs more is taken
back and the rest of the step redone finer; out of contact omega_c = 0).  The samples stay on the grid of dt.  On
the stiff landing at dt 0.2 us and rho 0.8, E_after / E_before is 1.73 with fixed steps and 0.9993 split to
omega_c h <= 0.5 (0.9992 at fixed dt / 8; 0.9985 split before the substeps kept their size through a contact).

``numerics.film_omega_dt`` > 0 splits steps the same way where the film is too stiff for them: omega_f h <=
film_omega_dt, omega_f^2 the largest |eigenvalue| of M^-1 K_f at the last refresh of the film's derivatives.  The
linearized coupling with derivatives some steps old stays stable while omega_f h is below about 1: at dt 0.2 us
the default face's 728-kHz mode has omega_f h = 1.01-1.06, and the 80-um trailing pad near contact up to 2.3 (at most
0.96 at dt 0.1 us), where its pitch mode grew from the first microseconds and flew the pad off at tens of nm;
refreshed every step it ran through (README, "A step the film can follow").

``numerics.film_update = "secant"`` keeps the derivatives fresh without refreshing them: each re-pass of the film
(the corrected attitude moved a corner more than ``numerics.film_repass`` from the predicted path) gives two film
steps from the same start and disk along paths dq apart, and Broyden's rank-one update makes S and K_f reproduce
their difference exactly (metric: the corner spacings), leaving them unchanged across dq.  The re-passes come
where the derivatives are most wrong, so the update costs no film step of its own.  Each step size then keeps its
own derivatives (a contact's substeps and the steps between them do not refresh on every change of size), refreshed
after ``film_jacobian_every`` substeps of that size or ``film_jacobian_every`` dt of time.  At dt 0.2 us with
``film_repass`` 0.02 nm this runs the 80-um pad through sustained contact, which stale derivatives threw off the
disk at tens to hundreds of nanometres (README, "A step the film can follow").

``numerics.film_refresh_gap`` > 0 refreshes the derivatives also where the attitude has moved a corner of the trailing
edge farther than the gap since their last refresh.  The film's stiffness grows steeply as the trailing pad comes
down, and derivatives from higher up let its 728-kHz mode grow into a limit cycle that strikes the disk once a
period (disk.seed 80 at dt 0.1 us: 21.7 uN, against 0.24 uN at dt / 4); refreshed where the trailing edge moved 0.5
nm it runs at 1.56 uN, for 494 refreshes instead of 263.  But over 184 tracks it lands as often as without, on other
tracks, and so does the reference at dt / 4: a landing is a rare event of the model, whose track any change of the
numerics moves (README, "Derivatives refreshed where the pad moves"); off by default.

The surface stiffness (asperities: 1e7-1e9 N/m) is far above the film's,
and the implicit treatment keeps the step stable with dt set by the film
and the disk's features, not by the contact.

Following scipy's solve_ivp contract, :class:`AbsStepper` holds the state
and takes one step; the driver :func:`simulate_abs` owns the time grid, the
output samples and stopping, and returns a flat :class:`AbsResult` (``t``,
states, series, ``status``, ``message`` and work counters).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from solver.abs.dynamics import mass_matrix, static_forces, stiffness_damping
from solver.abs.film import AbsFilm
from solver.abs.forces import Candidates, SurfaceForces, SurfaceModel
from solver.abs.params import SERIES, AbsScene
from solver.abs.steady import MIN_FORCE_SCALE, AbsSteady, element_row, element_spacing, fly_start
from solver.abs.track import Track
from solver.kernels import film as kfilm
from solver.kernels import newmark as knewmark

log = logging.getLogger(__name__)


#: A step whose Newton solve fails is halved at most this many times (dt / 256).
MAX_HALVINGS = 8
#: Cells within the surface forces' reach plus this [m] (and the step's predicted motion) are a step's
#: candidates: the only cells its Newton iterations evaluate.
CANDIDATE_MARGIN = 2.0e-9
#: Newton has converged when the residual is below this fraction of the forces (their round-off).
FORCE_ROUND_OFF = 1e-12
#: Backtracking halvings of a Newton step (the contact and adhesion laws are steep power laws), and the
#: smallest damping factor that is taken anyway.
MAX_BACKTRACKS = 12
MIN_DAMPING = 1e-3
#: Newton tolerance of the tangent predictor's solve (force / preload): its attitude is only the film's path, and a
#: residual r moves it by about r beta h^2 / m (1e-6 of the preload: ~1e-16 m at dt 0.2 us), far below the linear
#: correction that follows.
PREDICTOR_TOL = 1e-6
#: Film passes of a linearized step at most: along the predicted path, then along the corrected ones while the
#: corrected attitude moves the face farther than numerics.film_repass, or the correction makes P negative.
LINEARIZED_PASSES = 3
#: Largest spacing change [m] of the face's corners by which the film step is probed for its derivatives.
FILM_PROBE = 1.0e-12
#: A secant update needs passes whose paths differ by more than this many FILM_PROBE at the corners (in the metric).
SECANT_SMALLEST = 1.0
#: Samples this close [s] before the settling time count as after it (output times are multiples of dt).
SETTLE_SLACK = 1e-15


@dataclass
class AbsResult:
    """Time series and summary of one partial-contact run."""

    t: np.ndarray
    q: np.ndarray  # (n, 3)
    v: np.ndarray  # (n, 3)
    series: dict[str, np.ndarray]
    steady: AbsSteady
    status: int
    message: str
    work: dict[str, float] = field(default_factory=dict)


class AbsStepper:
    """The state of one run and its generalized-alpha steps (the scheme of the module docstring).

    State at time ``t``: attitude ``q``, velocities ``v`` and accelerations ``a`` (3,) [m, rad; /s; /s^2],
    the film (its pressure lives in ``film``), the disk heights under the nodes ``zd`` [m], and the forces
    at t: ``f_air`` (3,) and the surface forces ``sf``.  Like scipy's ``OdeSolver``, :meth:`step` advances
    the state and returns None, or returns why it could not, with ``status`` "running" or "failed".  Work
    counters: ``newton`` iterations, accepted ``substeps``, step ``halvings``, ``film_repasses`` and
    ``jacobian_refreshes`` of the film step's derivatives.
    """

    def __init__(self, scene: AbsScene, film: AbsFilm, track: Track, surface: SurfaceModel, steady: AbsSteady) -> None:
        num = scene.numerics
        self.film, self.track, self.surface = film, track, surface
        self.M = mass_matrix(scene)
        self.K, self.C = stiffness_damping(scene)
        self.f_static = static_forces(scene)
        self.q_ref = steady.q.copy()
        self.use_air = scene.models.air_bearing == "reynolds"
        self.newton_max_iter = num.newton_max_iter
        self.tol = num.newton_tol * max(scene.suspension.preload, MIN_FORCE_SCALE)
        self.weights = np.array([1.0, 1.0 / scene.slider.length, 1.0 / scene.slider.length])
        self.linearized = self.use_air and num.film_coupling == "linearized"
        self.repass_gap = num.film_repass if self.linearized else 0.0
        self.jacobian_every = num.film_jacobian_every
        self.refresh_gap = num.film_refresh_gap if self.linearized else 0.0
        self.moved_refreshes = 0  # refreshes because the trailing edge moved farther than refresh_gap
        self.film_dt = num.film_dt
        self._inner: tuple[np.ndarray, ...] = ()  # the disk inside this step at the film's own steps (film_dt)
        self.secant = self.linearized and num.film_update == "secant"
        self.secant_updates = 0
        # with the secant update, each step size keeps its own derivatives (a contact's substeps and the step
        # between them do not refresh on every change of size): h -> [K_f, S, age, omega_f, time of refresh]
        self._sizes: dict[float, list] = {}
        self.size_memory = num.film_jacobian_every * num.dt  # a size's derivatives are refreshed after this [s]
        self.film_omega = 0.0  # omega_f [rad/s]: sqrt of the largest |eigenvalue| of M^-1 K_f at the last refresh
        self.film_K = np.zeros((3, 3))
        self.film_dPdq = np.zeros((3, *film.P.shape))
        self.jacobian_age, self.jacobian_h = 0, 0.0
        self.jacobian_q = np.zeros(3)  # the end attitude of the last refresh's film step
        self.jacobian_ratio = 0.0  # and its BDF2 step ratio (film_scheme 'bdf2': BDF2 and backward Euler differ)
        self.newton_kernel = surface.law == "greenwood_williamson"
        self.damping_ratio = scene.contact.damping_ratio
        self.m_inv = np.linalg.inv(self.M)
        self.set_rho(num.rho_infinity)
        self.controls = (self.tol, FORCE_ROUND_OFF, self.newton_max_iter, MAX_BACKTRACKS, MIN_DAMPING)
        scale = max(scene.suspension.preload, MIN_FORCE_SCALE)
        self.predictor_controls = (max(self.tol, PREDICTOR_TOL * scale), *self.controls[1:])
        s = scene.slider
        corners_x = np.array([0.0, s.length, s.length, 0.0]) - s.pivot_x
        corners_y = np.array([-0.5, -0.5, 0.5, 0.5]) * s.width - s.pivot_y
        self.corner_b = np.stack([np.ones(4), -corners_x, -corners_y], axis=1)  # d(spacing)/dq at the corners
        self.trailing_b = self.corner_b[1:3]  # the trailing edge's corners (x = length)

        self.t = 0.0
        self.q = steady.q.copy()
        self.v = scene.initial.velocities(scene.disk.seed)
        self.zd, sd = track.at(0.0)
        film.set_disk(self.zd)
        self.f_air = film.forces() if self.use_air else np.zeros(3)
        self.sf = surface.forces(film.spacing(self.q), sd)
        self.restart_acceleration()
        self.status = "running"
        self.newton = self.substeps = self.halvings = self.film_repasses = self.jacobian_refreshes = 0
        self.contact_substeps = self.contact_redos = self.damped_substeps = 0
        self.contact_level = 0  # halvings of the last step (contact_split_step: no coarsening while in contact)
        self.residual = 0.0
        self.a_prev, self.h_prev = None, 0.0  # the acceleration and size of the last accepted step
        self.predictor = num.film_predictor if self.linearized else "extrapolated"
        self.f_prev, self.q_prev = None, None  # the film force and attitude at the last step's start
        self.predictions = 0  # steps whose film path came from a model of the step (film_predictor)
        self._omega_of, self._omega = None, 0.0  # contact_omega's last surface forces and value
        self._cache, self._cache_cells = np.empty((4, 0)), None  # the candidates' adhesion, kept (newton_step)

    def set_rho(self, rho: float) -> None:
        """The generalized-alpha parameters of spectral radius rho at infinite frequency (Chung & Hulbert)."""
        self.rho = rho
        self.alpha_m, self.alpha_f = (2.0 * rho - 1.0) / (rho + 1.0), rho / (rho + 1.0)
        self.gamma = 0.5 - self.alpha_m + self.alpha_f
        self.beta = 0.25 * (1.0 - self.alpha_m + self.alpha_f) ** 2
        self.scheme = (self.M, self.C, self.K, self.q_ref, self.f_static, self.weights, self.alpha_m, self.alpha_f,
                       self.gamma, self.beta)  # fmt: skip

    def restart_acceleration(self) -> None:
        """a = M^-1 f(t, q, v), the physical acceleration, as at the start of a run.

        The generalized-alpha a_n is an algorithmic acceleration that remembers past forces over a few steps (rho_inf
        < 1), in units of its own step: at a change of step size (:func:`contact_split_step`) that memory is
        forgotten, or it would be integrated over the new size.  The predictor's extrapolation restarts too.
        """
        self.a = np.linalg.solve(
            self.M, self.f_static + self.f_air + self.sf.f - self.C @ self.v - self.K @ (self.q - self.q_ref)
        )
        self.a_prev = None

    def step(self, h: float) -> str | None:
        """Advance the state from t by h (halving it where Newton fails); None, or the message of the failure."""
        message = self._advance(h, 0)
        if message:
            self.status = "failed"
            return message
        return None

    def snapshot(self) -> tuple:
        """What :meth:`restore` needs to take back the steps taken since (the film's pressure is copied)."""
        return (self.t, self.q, self.v, self.a, self.zd, self.f_air, self.sf, self.a_prev, self.h_prev,
                self.film.P.copy(), self.rho, self.film.history())  # fmt: skip

    def restore(self, saved: tuple) -> None:
        """Return to the state of :meth:`snapshot` (the film's derivatives are refreshed at the next size)."""
        (self.t, self.q, self.v, self.a, self.zd, self.f_air, self.sf, self.a_prev, self.h_prev, P, rho,
         history) = saved  # fmt: skip
        self.set_rho(rho)
        self.film.P[:] = P
        self.film.set_history(history)
        self.film.set_disk(self.zd)
        if not self.secant:  # (with the secant update the sizes keep their derivatives: _use_size)
            self.jacobian_h = 0.0
        self.f_prev = None

    def contact_omega(self) -> float:
        """omega_c [rad/s]: the largest eigenvalue of M^-1 K_s, K_s = -d f_surface / d q at the present state.

        0 out of contact (the adhesion alone is a softening spring, not resolved by the step size).
        """
        sf = self.sf
        if sf.contact <= 0.0:
            return 0.0
        if sf is not self._omega_of:  # a substep's end is the next one's start: one eigensolve for both
            lam = knewmark.contact_frequency_squared(self.m_inv, sf.dfdq)
            self._omega_of, self._omega = sf, math.sqrt(lam) if lam > 0.0 else 0.0
        return self._omega

    def _advance(self, h: float, depth: int) -> str:
        """Advance by h; on a failed film or Newton solve, restore the film and take two halves.  "" on success."""
        film, surface = self.film, self.surface
        q, v, a = self.q, self.v, self.a
        t1 = self.t + h
        zd1, sd1 = self.track.at(t1)
        m = film_steps(h, self.film_dt)
        self._inner = tuple(self.track.at(self.t + k * h / m)[0] for k in range(1, m))
        P_saved = film.P.copy()
        if self.secant:
            self._use_size(h)

        def fail(message: str) -> str:
            if depth >= MAX_HALVINGS:
                return f"{message} at t = {t1:.4g} s, dt / 2^{depth}"
            # A snap (adhesion pulling the pad in, a hard landing) outruns the step: restore, take two halves.
            film.P[:] = P_saved
            film.set_disk(self.zd)
            self.halvings += 1
            return self._advance(0.5 * h, depth + 1) or self._advance(0.5 * h, depth + 1)

        margin = CANDIDATE_MARGIN + float(np.abs(h * v + 2.0 * h * h * a) @ surface.b_max)
        cells = surface.candidates(zd1, sd1, q, margin)
        f_old = self.f_air + self.sf.f
        a_new = self._predicted_acceleration(h)
        q_path = q + h * v + 0.5 * h * h * a + self.beta * h * h * (a_new - a)  # Newmark's q(a_new)
        if self.predictor == "linear_model" and self.f_prev is not None and h == self.jacobian_h == self.h_prev:
            # The step's balance with the film force from its linear model about the last step: the film's
            # derivatives K_f for the attitude, the last step's change left over by them for the rest (the disk,
            # the squeeze).  Its attitude is the path the film is advanced along.
            a_new = self._model_acceleration(h, a_new, q_path, f_old)
            q_path = q + h * v + 0.5 * h * h * a + self.beta * h * h * (a_new - a)
            self.predictions += 1
        elif self.predictor == "tangent" and h == self.jacobian_h:
            # The step's own Newton problem (the surface forces as they are) with the film force on its tangent
            # about the present state, f_n + K_f (q - q_n).  A failed solve keeps the extrapolated path.
            solved = self._newton(h, cells, a_new, self.f_air, q, f_old, self.predictor_controls)
            if solved is not None:
                a_new = solved[0]
                q_path = q + h * v + 0.5 * h * h * a + self.beta * h * h * (a_new - a)
                self.predictions += 1
        passes = LINEARIZED_PASSES if self.linearized else 2
        last_pass = None  # (q_path, f_path, P) of the pass before, for the secant update
        q_passed, f_path = q_path, None
        for film_pass in range(passes):
            if film_pass:
                self.film_repasses += 1
                if self.secant:  # the film as the last pass left it (its linear correction was not applied)
                    last_pass = (q_passed, f_path, film.P.copy())
                film.P[:] = P_saved
            f_path = self._film_step(q_path, zd1, h)
            if f_path is None or (self.linearized and not self._film_jacobian(P_saved, q_path, zd1, h, f_path)):
                return fail("film failed (pressure not positive and finite)")
            if last_pass is not None:
                self._secant_update(*last_pass, q_path, f_path)
            q_passed = q_path
            solved = self._newton(h, cells, a_new, f_path, q_path, f_old)
            if solved is None:
                return fail(f"Newton did not converge (|G| = {self.residual:.2e})")
            a_new, q1, v1, sf = solved
            if not self.use_air:
                film.set_disk(zd1)
                break
            last = film_pass == passes - 1
            if (last or self._path_gap(q1 - q_path) <= self.repass_gap) and self._correct_film(q1 - q_path):
                break
            if last:
                return fail("film failed (its linear correction is not positive)")
            q_path = q1
        f_air = f_path + self.film_K @ (q1 - q_path)
        film.commit_step()
        self.substeps += 1
        self.jacobian_age += 1
        self.a_prev, self.h_prev = a, h
        self.f_prev, self.q_prev = self.f_air, q
        self.t, self.q, self.v, self.a = t1, q1, v1, a_new
        self.zd, self.f_air, self.sf = zd1, f_air, sf
        return ""

    def _predicted_acceleration(self, h: float) -> np.ndarray:
        """The first guess of a_n+1, whose Newmark attitude is the film's path: a_n for the two-pass coupling.

        The linearized coupling extrapolates a_n + h (a_n - a_n-1) / h_n-1: its film then moves along a
        path closer to the corrected one, where the linear correction is more accurate (on the rough default
        run, 200 us: max |FH - FH_exact| 0.019 nm instead of 0.054 nm with a_n, against the film re-advanced
        along the corrected path every step; the two-pass scheme: 0.146 nm).
        """
        if not self.linearized or self.a_prev is None:
            return self.a.copy()
        return self.a + (h / self.h_prev) * (self.a - self.a_prev)

    def _model_acceleration(self, h: float, a0: np.ndarray, q0: np.ndarray, f_old: np.ndarray) -> np.ndarray:
        """a_n+1 of the step's balance with every force linear about the present state (film_predictor 'linear_model').

        The film force is f_n + K_f (q - q_n) plus the drift: the change over the last step that K_f does not
        explain (the disk, the squeeze); the surface forces are f_s + (d f_s / d q) (q - q_n).  The balance is
        then linear in a_n+1: one solve of the Newton matrix from the guess a0 (whose attitude is q0).
        """
        q, v, a, sf = self.q, self.v, self.a, self.sf
        am, af, gamma, beta = self.alpha_m, self.alpha_f, self.gamma, self.beta
        stiffness = self.film_K + sf.dfdq
        drift = self.f_air - self.f_prev - self.film_K @ (q - self.q_prev)
        v0 = v + h * ((1.0 - gamma) * a + gamma * a0)
        forces = self.f_air + drift + sf.f + stiffness @ (q0 - q)
        inertia = self.M @ ((1.0 - am) * a0 + am * a)
        suspension = self.C @ ((1.0 - af) * v0 + af * v) + self.K @ ((1.0 - af) * q0 + af * q - self.q_ref)
        G = inertia + suspension - self.f_static - af * f_old - (1.0 - af) * forces
        J = (1.0 - am) * self.M + (1.0 - af) * (gamma * h * self.C + beta * h * h * (self.K - stiffness))
        return a0 - knewmark.solve3(J, G)

    def _film_step(self, q_path: np.ndarray, zd1: np.ndarray, h: float) -> np.ndarray | None:
        """Advance the film from t (attitude q, disk zd) to t + h along q -> q_path: its forces, None if it failed.

        Without an air bearing, zero forces.
        """
        if not self.use_air:
            return self.f_air
        film = self.film
        if not film.step(self.q, q_path, self.zd, zd1, h, self._inner):
            return None
        f_air = film.forces()
        if not (math.isfinite(f_air[0]) and math.isfinite(f_air[1]) and math.isfinite(f_air[2])):
            return None
        return f_air

    def _correct_film(self, dq: np.ndarray) -> bool:
        """Move the film to the end attitude q_path + dq, P += S dq (linearized); False if P would not stay > 0.

        The two-pass coupling's film stays where it is (True).
        """
        if not self.linearized:
            return True
        return kfilm.add_linear(self.film.P, self.film_dPdq, dq)

    def _film_jacobian(
        self, P_start: np.ndarray, q_path: np.ndarray, zd1: np.ndarray, h: float, f_path: np.ndarray
    ) -> bool:
        """Refresh, when due, the film step's derivatives with respect to the attitude at t + h; False if it failed.

        The film step P_n -> P_n+1(q_n+1) (from ``P_start``, along q -> q_path, just taken: ``film.P``) is
        differentiated by forward differences that move the face by FILM_PROBE at most:
        ``film_dPdq`` (3, 1, nx, ny) and the forces' ``film_K`` = d f_air / d q_n+1 (3, 3).  Refreshed every
        ``numerics.film_jacobian_every`` steps, whenever the step size (or BDF2's step ratio) changes, and where
        ``q_path`` has moved a corner of the trailing edge farther than ``numerics.film_refresh_gap`` from the last
        refresh's attitude; ``film.P`` is left as found.
        """
        same = h == self.jacobian_h and self.film.last_ratio == self.jacobian_ratio  # the same step (size, scheme)
        if self.jacobian_age < self.jacobian_every and same:
            if not (self.refresh_gap > 0.0 and self._trailing_gap(q_path - self.jacobian_q) > self.refresh_gap):
                return True
            self.moved_refreshes += 1
        film = self.film
        P_path = film.P.copy()
        for k in range(3):
            probe = FILM_PROBE / np.max(np.abs(self.corner_b[:, k]))
            film.P[:] = P_start
            q_probe = q_path.copy()
            q_probe[k] += probe
            film.step(self.q, q_probe, self.zd, zd1, h, self._inner, keep=False)
            self.film_dPdq[k] = (film.P - P_path) / probe
            self.film_K[:, k] = (film.forces() - f_path) / probe
        film.P[:] = P_path
        self.jacobian_age, self.jacobian_h, self.jacobian_q = 0, h, q_path.copy()
        self.jacobian_ratio = film.last_ratio
        self.jacobian_refreshes += 1
        if not np.all(np.isfinite(self.film_K)):
            return False
        self.film_omega = math.sqrt(float(np.max(np.abs(np.linalg.eigvals(self.m_inv @ self.film_K)))))
        if self.secant:
            self._sizes[h] = [self.film_K, self.film_dPdq, 0, self.film_omega, self.t, self.jacobian_q]
        return True

    def _use_size(self, h: float) -> None:
        """Make the derivatives of step size h the film's (numerics.film_update 'secant'): those kept for h if they
        were refreshed less than ``size_memory`` ago, else new arrays that :meth:`_film_jacobian` refreshes."""
        if h == self.jacobian_h:
            return
        if self.jacobian_h in self._sizes:
            self._sizes[self.jacobian_h][2] = self.jacobian_age
        entry = self._sizes.get(h)
        if entry is not None and self.t - entry[4] <= self.size_memory:
            self.film_K, self.film_dPdq, self.jacobian_age, self.film_omega, _, self.jacobian_q = entry
        else:
            self._sizes.pop(h, None)
            self.film_K, self.film_dPdq = np.zeros((3, 3)), np.zeros_like(self.film_dPdq)
            self.jacobian_age = self.jacobian_every  # due
        self.jacobian_h = h

    def _secant_update(self, q_a: np.ndarray, f_a: np.ndarray, P_a: np.ndarray, q_b: np.ndarray,
                       f_b: np.ndarray) -> None:  # fmt: skip
        """Broyden's rank-one update of the film step's derivatives from two passes of one step (numerics.film_update
        'secant'): the film advanced from the same start along q_a and along q_b (``film.P``), with forces f_a, f_b.

        With dq = q_b - q_a, in the metric W = B^T B of the face's corner spacings (B = ``corner_b``, so that
        pitch and roll weigh by the spacing they move), S += (dP - S dq) (W dq)^T / (dq^T W dq) and K_f the same
        with df: afterwards both reproduce the two passes' difference exactly, and are unchanged across dq.  The
        same step's disk and start, so the difference is the film's response to the attitude alone.
        """
        dq = q_b - q_a
        w = self.corner_b.T @ (self.corner_b @ dq)
        denom = float(dq @ w)
        if not denom > (SECANT_SMALLEST * FILM_PROBE) ** 2:
            return
        self.film_K += np.outer(f_b - f_a - self.film_K @ dq, w / denom)
        kfilm.secant_update(self.film_dPdq, self.film.P, P_a, dq, w / denom)
        self.secant_updates += 1

    def _path_gap(self, dq: np.ndarray) -> float:
        """Largest change of the spacing over the face's corners [m] made by the attitude change dq."""
        return float(np.max(np.abs(self.corner_b @ dq)))

    def _trailing_gap(self, dq: np.ndarray) -> float:
        """Largest change of the spacing at the trailing edge's corners [m] made by the attitude change dq."""
        return float(np.max(np.abs(self.trailing_b @ dq)))

    def _newton(self, h: float, cells: Candidates, a_new: np.ndarray, f_path: np.ndarray, q_path: np.ndarray,
                f_old: np.ndarray, controls: tuple | None = None):  # fmt: skip
        """Newton's method on a_n+1: (a, q, v, sf) at t + h, or None.

        The film force is f_path, that of the film advanced along q -> q_path, plus ``film_K`` (q_n+1 - q_path)
        (zero unless ``numerics.film_coupling`` is "linearized").  The Greenwood-Williamson law runs the whole
        iteration in one kernel (:func:`solver.kernels.newmark.newton_step`), other laws in
        :meth:`_newton_python`, the same iteration.

        None when it did not converge in ``numerics.newton_max_iter`` iterations (``self.residual`` holds the
        last weighted residual).  ``controls``: (tolerance, round-off, iterations, backtracks, smallest damping),
        the stepper's by default (``predictor_controls``: the tangent predictor's looser tolerance).
        """
        controls = self.controls if controls is None else controls
        if not self.newton_kernel:
            return self._newton_python(h, cells, a_new, f_path, q_path, f_old, controls[0])
        disk_rate = self._disk_rate(h, cells)
        q1, v1, f_s, dfdq = np.empty(3), np.empty(3), np.empty(3), np.empty((3, 3))
        a_new = a_new.copy()
        fill = self._cache_cells is not cells  # the first solve over these cells: the predictor's, or the only one
        if fill:
            self._cache, self._cache_cells = np.empty((4, cells.base.size)), cells
        iterations, self.residual, converged, contact, adhesion, in_reach = knewmark.newton_step(
            a_new,
            h,
            (self.q, self.v, self.a),
            self.scheme,
            (f_path, q_path, self.film_K, f_old),
            (cells.base, cells.sigma, cells.b, cells.area),
            self.surface.kernel_law,
            (self.damping_ratio, self.m_inv, disk_rate),
            controls,
            q1,
            v1,
            f_s,
            dfdq,
            tuple(self._cache),
            fill,
        )
        self.newton += iterations
        if not converged:
            return None
        sf = SurfaceForces(f_s, dfdq, contact, adhesion, self.surface.mu * contact, in_reach)
        return a_new, q1, v1, sf

    def _disk_rate(self, h: float, cells: Candidates) -> np.ndarray:
        """The resolved disk's rate at the candidate cells over this step (the contact damping's reference)."""
        if self.damping_ratio == 0.0:
            return np.zeros(0)
        index = cells.index
        disk_end = self.surface.surface[index] - cells.base  # cells.base = surface - disk at t + h
        return (disk_end - self.zd.ravel()[index]) / h

    def _newton_python(self, h: float, cells: Candidates, a_new: np.ndarray, f_path: np.ndarray, q_path: np.ndarray,
                       f_old: np.ndarray, tol: float | None = None):  # fmt: skip
        """:meth:`_newton` in Python, on the surface model's forces (any contact law, with its contact damping:
        its matrix in the iteration matrix; the elastic law's attitude derivative of the damping is left out)."""
        disk_rate = self._disk_rate(h, cells)
        surface = self.surface
        M, C, K = self.M, self.C, self.K
        alpha_m, alpha_f, gamma, beta = self.alpha_m, self.alpha_f, self.gamma, self.beta
        weights = self.weights
        tol = self.tol if tol is None else tol
        q, v, a = self.q, self.v, self.a
        film_K = self.film_K

        def newmark(a_trial: np.ndarray):
            q1 = q + h * v + h * h * ((0.5 - beta) * a + beta * a_trial)
            v1 = v + h * ((1.0 - gamma) * a + gamma * a_trial)
            damping = (self.damping_ratio, self.m_inv, v1, disk_rate) if self.damping_ratio > 0.0 else None
            sf = surface.forces_on(cells, q1, damping)
            f_air = f_path + film_K @ (q1 - q_path)
            G = (
                M @ ((1.0 - alpha_m) * a_trial + alpha_m * a)
                + C @ ((1.0 - alpha_f) * v1 + alpha_f * v)
                + K @ ((1.0 - alpha_f) * q1 + alpha_f * q - self.q_ref)
                - self.f_static
                - (1.0 - alpha_f) * (f_air + sf.f)
                - alpha_f * f_old
            )
            return q1, v1, sf, G

        def round_off(sf: SurfaceForces) -> float:
            return FORCE_ROUND_OFF * (np.max(np.abs(sf.f * weights)) + np.max(np.abs(f_path * weights)))

        q1, v1, sf, G = newmark(a_new)
        norm = np.max(np.abs(G * weights))
        for it in range(self.newton_max_iter):
            self.newton += 1
            if norm < tol or norm <= round_off(sf):
                break  # converged, absolutely or to round-off of the forces
            C_total = C if sf.damping is None else C + sf.damping
            Jn = (1.0 - alpha_m) * M + (1.0 - alpha_f) * (gamma * h * C_total + beta * h * h * (K - sf.dfdq - film_K))
            step_a = np.linalg.solve(Jn, G)
            lam = 1.0
            for _ in range(MAX_BACKTRACKS):
                trial = newmark(a_new - lam * step_a)
                trial_norm = np.max(np.abs(trial[3] * weights))
                if trial_norm < norm or lam < MIN_DAMPING:
                    break
                lam *= 0.5
            a_new = a_new - lam * step_a
            q1, v1, sf, G = trial
            norm = trial_norm
            log.debug("t = %.4g Newton %d: |G| = %.3e (lambda %.3g)", self.t + h, it, norm, lam)
        self.residual = norm
        if norm >= tol and norm > round_off(sf):
            return None
        return a_new, q1, v1, sf


class _Samples:
    """The stored time series: the state every ``output_every`` steps, preallocated."""

    def __init__(self, scene: AbsScene, n_out: int) -> None:
        self.scene = scene
        self.fh_row = element_row(scene)
        self.t = np.empty(n_out)
        self.q = np.empty((n_out, 3))
        self.v = np.empty((n_out, 3))
        self.series = {k: np.empty(n_out) for k in SERIES}
        self.k = 0

    @property
    def full(self) -> bool:
        return self.k >= self.t.size

    def record(self, t: float, stepper: AbsStepper) -> None:
        k, q, sf = self.k, stepper.q, stepper.sf
        self.t[k] = t
        self.q[k] = q
        self.v[k] = stepper.v
        self.series["flying_height"][k] = element_spacing(self.scene, q, self.fh_row)
        self.series["clearance"][k] = float(np.min(stepper.film.spacing(q)))
        self.series["contact_force"][k] = sf.contact
        self.series["adhesion_force"][k] = sf.adhesion
        self.series["friction_force"][k] = sf.friction
        self.series["air_force"][k] = stepper.f_air[0]
        self.series["contact_cells"][k] = sf.cells
        self.k += 1


def film_steps(h: float, film_dt: float) -> int:
    """Film steps in a step of h: the fewest equal ones no longer than ``film_dt`` (0: one)."""
    if film_dt <= 0.0 or h <= film_dt:
        return 1
    return math.ceil(h / film_dt * (1.0 - 1e-12))


def contact_splits_needed(omega: float, dt: float, limit: float, most: int) -> int:
    """Fewest halvings j <= most of dt with omega dt / 2^j <= limit."""
    if omega * dt <= limit:
        return 0
    return min(most, math.ceil(math.log2(omega * dt / limit)))


def contact_split_step(
    stepper: AbsStepper,
    t0: float,
    dt: float,
    limit: float,
    most: int,
    rho: float,
    rho_contact: float,
    film_limit: float = 0.0,
) -> str | None:
    """Advance from t0 by dt in 2^j equal substeps, j set by the contact's frequency (``numerics.contact_omega_dt``).

    j is the fewest halvings with omega_c h <= limit at the start (:meth:`AbsStepper.contact_omega`); a substep
    whose end needs more is taken back and the rest of the step redone with them (the substeps already taken
    stay: the step never coarsens within dt, so it ends on t0 + dt).  Nor does it coarsen from one step to the
    next while in contact: j is at least the last step's until a step starts out of contact (omega_c = 0), then
    one step of dt.  The substep size changes only where the surface force is smooth: coarsening as an
    asperity contact unloads, with the generalized-alpha acceleration a_n lagging over the finer substeps,
    created energy (the stiff landing at dt 0.05 us and rho_inf 0: E_after / E_before 1.0275 split, 0.899 with
    fixed steps and 0.989 at fixed dt / 4).  A substep whose contact is too stiff for it even at the finest size
    (omega_c h > limit at its start or its end, with j = most) takes the spectral radius ``rho_contact`` instead of
    ``rho`` (taken back and redone with it when only its end is), to damp the modes it cannot resolve; the
    acceleration restarts at every change of rho.  With ``film_limit`` > 0 (``numerics.film_omega_dt``) the film's
    frequency omega_f (:attr:`AbsStepper.film_omega`, at the last refresh of its derivatives) asks for halvings too,
    omega_f h <= film_limit, at the start and at each substep's end (a refresh that finds the film stiffer has the
    substep redone finer, as the contact's; the run's first step, before any refresh, is one); it does not hold the
    level from step to step.  None, or the message of a failed substep.
    """
    omega = stepper.contact_omega()
    j = contact_splits_needed(omega, dt, limit, most)
    if omega > 0.0:
        j = max(j, stepper.contact_level)
    if film_limit > 0.0:
        j = max(j, contact_splits_needed(stepper.film_omega, dt, film_limit, most))
    k = 0  # substeps of dt / 2^j taken
    damp_next = False  # the substep is redone with rho_contact: its end was unresolved
    while k < 2**j:
        h = dt / 2**j
        stepper.t = t0 + k * h
        unresolved = damp_next or omega * h > limit
        may_redo = j < most or (not unresolved and rho_contact != rho)
        saved = stepper.snapshot() if may_redo else None
        rho_h = rho_contact if unresolved else rho
        if rho_h != stepper.rho:
            stepper.set_rho(rho_h)
            stepper.restart_acceleration()
        elif stepper.h_prev > 0.0 and not math.isclose(h, stepper.h_prev, rel_tol=1e-9):
            stepper.restart_acceleration()
        failure = stepper.step(h)
        if failure:
            return failure
        omega = stepper.contact_omega()
        j_end = contact_splits_needed(omega, dt, limit, most)
        if film_limit > 0.0:  # the film's frequency as refreshed in this substep (the run's first, a stiffening)
            j_end = max(j_end, contact_splits_needed(stepper.film_omega, dt, film_limit, most))
        if j_end > j and saved is not None and j < most:
            stepper.restore(saved)
            stepper.contact_redos += 1
            k, j, damp_next = k << (j_end - j), j_end, False
            continue
        if saved is not None and not unresolved and rho_contact != rho and omega * h > limit:
            stepper.restore(saved)
            stepper.contact_redos += 1
            damp_next = True
            continue
        damp_next = False
        stepper.damped_substeps += unresolved
        k += 1
        if j:
            stepper.contact_substeps += 1
    stepper.contact_level = j
    return None


def simulate_abs(scene: AbsScene, steady: AbsSteady | None = None, profile=None) -> AbsResult:
    """Integrate one run from steady flight over the moving track; never raises for a physical failure.

    The driver: steps of ``numerics.dt`` on the grid t_n = n dt (:class:`AbsStepper`), a sample every
    ``numerics.output_every`` steps, a stop at t_end or at the first step that fails.
    status 0: reached t_end; -1: the film or the Newton solve failed (message says where).
    """
    wall0 = time.perf_counter()
    num = scene.numerics
    film = AbsFilm(scene)
    grid = film.grid
    if steady is None:
        steady = fly_start(scene, film)
    else:
        film.set_disk(np.zeros(grid.shape))
        film.solve_steady(steady.q)
    track = Track(scene, grid, profile)
    surface = SurfaceModel(scene, grid)
    stepper = AbsStepper(scene, film, track, surface, steady)
    dt = num.dt
    n_steps = int(round(num.t_end / dt))
    every = num.output_every
    out = _Samples(scene, n_steps // every + 1)
    out.record(0.0, stepper)
    status, message = 0, "reached t_end"
    n = -1
    for n in range(n_steps):
        stepper.t = n * dt  # on the grid: no round-off accumulates over the run
        if num.contact_omega_dt > 0.0:
            failure = contact_split_step(stepper, n * dt, dt, num.contact_omega_dt, num.contact_splits,
                                         num.rho_infinity, num.rho_infinity_contact, num.film_omega_dt)  # fmt: skip
        else:
            failure = stepper.step(dt)
        if failure:
            status, message = -1, failure
            break
        if (n + 1) % every == 0 and not out.full:
            out.record((n + 1) * dt, stepper)
    work = {
        "steps": n + 1 if n_steps else 0,
        "substeps": stepper.substeps,
        "step_halvings": stepper.halvings,
        "newton_iterations": stepper.newton,
        "reynolds_solves": film.reynolds_solves,
        "film_repasses": stepper.film_repasses,
        "film_jacobians": stepper.jacobian_refreshes,
        "film_jacobians_moved": stepper.moved_refreshes,
        "film_secant_updates": stepper.secant_updates,
        "contact_substeps": stepper.contact_substeps,
        "contact_redos": stepper.contact_redos,
        "contact_damped": stepper.damped_substeps,
        "nodes": grid.x.size * grid.y.size,
        "wall_time": time.perf_counter() - wall0,
    }
    k = out.k
    return AbsResult(
        t=out.t[:k],
        q=out.q[:k],
        v=out.v[:k],
        series={name: s[:k] for name, s in out.series.items()},
        steady=steady,
        status=status,
        message=message,
        work=work,
    )


def spectrum(t: np.ndarray, signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum (Hann window, mean removed): frequencies [Hz], amplitudes [signal units]."""
    n = signal.size
    if n < 4:
        return np.zeros(0), np.zeros(0)
    dt = (t[-1] - t[0]) / (n - 1)
    w = np.hanning(n)
    x = (signal - signal.mean()) * w
    amp = 2.0 * np.abs(np.fft.rfft(x)) / w.sum()
    return np.fft.rfftfreq(n, dt), amp


def settled_spectra(result: AbsResult, scene: AbsScene) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Amplitude spectra of the flying height, pitch and roll after the settling time: frequencies [Hz] and
    {name: amplitudes [m or rad]} (:func:`spectrum`)."""
    keep = result.t >= scene.numerics.settle_time - SETTLE_SLACK
    signals = {"flying_height": result.series["flying_height"], "pitch": result.q[:, 1], "roll": result.q[:, 2]}
    freq, out = np.zeros(0), {}
    for name, signal in signals.items():
        freq, out[name] = spectrum(result.t[keep], signal[keep])
    return freq, out


def summarize(result: AbsResult, scene: AbsScene) -> dict[str, float]:
    """Bouncing 3-sigma, contact measures and spectral peaks after the settling time."""
    num = scene.numerics
    keep = result.t >= num.settle_time - SETTLE_SLACK
    t = result.t[keep]
    fh = result.series["flying_height"][keep]
    fc = result.series["contact_force"][keep]
    out = {
        "bouncing_3sigma": 3.0 * float(np.std(fh)) if fh.size else float("nan"),
        "mean_flying_height": float(np.mean(fh)) if fh.size else float("nan"),
        "min_clearance": float(np.min(result.series["clearance"][keep])) if fh.size else float("nan"),
        "mean_contact_force": float(np.mean(fc)) if fc.size else float("nan"),
        "max_contact_force": float(np.max(fc)) if fc.size else float("nan"),
        "contact_fraction": float(np.mean(fc > num.contact_threshold)) if fc.size else float("nan"),
        "mean_adhesion_force": float(np.mean(result.series["adhesion_force"][keep])) if fc.size else float("nan"),
        "mean_friction_force": float(np.mean(result.series["friction_force"][keep])) if fc.size else float("nan"),
    }
    for name, signal in (("fh", fh), ("pitch", result.q[keep, 1]), ("roll", result.q[keep, 2])):
        f, amp = spectrum(t, signal)
        out[f"{name}_peak_frequency"] = float(f[1:][np.argmax(amp[1:])]) if f.size > 1 else float("nan")
        out[f"{name}_peak_amplitude"] = float(np.max(amp[1:])) if f.size > 1 else float("nan")
    return out
