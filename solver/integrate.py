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

from .airbearing import make_air_bearing
from .contact import ContactError, Impact, corner_normal, impact_map, surface_slope
from .dynamics import mass_matrix
from .geometry import corner_positions
from .kernels import motion as km
from .params import Scene
from .steady import SteadyFlight, fly

log = logging.getLogger(__name__)


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

    @property
    def min_spacing(self) -> np.ndarray:
        return self.corner_spacing.min(axis=1)


def simulate(scene: Scene, steady: SteadyFlight | None = None) -> Result:
    """Integrate one run of ``scene`` from steady flight plus the initial velocities."""
    wall0 = time.perf_counter()
    film = make_air_bearing(scene)
    if steady is None:
        steady = fly(scene, film=film)
    if steady.pressure.shape != film.P.shape:
        raise ValueError("the steady flight was computed on another grid than this scene's")
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
    film.P = steady.pressure / scene.air.ambient_pressure
    init = scene.initial
    v = np.array([init.zdot, init.pitch_rate, init.roll_rate])
    num = scene.numerics
    minv = np.linalg.inv(mass_matrix(scene.slider))
    corners = corner_positions(scene.slider)
    normals = np.array([corner_normal(x1, x2) for x1, x2 in corners])
    h0 = scene.disk.asperity_height
    touch_tol = 1e-9 * max(h0, 1e-9)
    dt, t_end = num.dt, num.t_end
    n_grid = int(round(t_end / dt))
    out_every = num.output_every
    force_args = film.force_args()
    film_args = film.kernel_args()
    f_air = np.empty(3)
    km.generalized_forces(film.P, film.area, force_args[2], force_args[3], force_args[0], force_args[1], f_air)
    acc = np.empty(3)
    km.accelerations(f_air, q, suspension, minv, acc)
    ts, qs, vs, fs = [0.0], [q.copy()], [v.copy()], [f_air.copy()]
    impacts: list[Impact] = []
    status, message = 0, "reached t_end"
    t, k = 0.0, 0
    steps = newton = 0
    start_gaps = normals @ q - h0
    if np.any(start_gaps < -touch_tol):
        raise ContactError(f"a corner starts below the asperity height (spacings {(start_gaps + h0).tolist()} m)")
    try:
        while k < n_grid:
            t_target = (k + 1) * dt
            s_max = t_target - t  # short after an impact: back onto the grid (the film step is fine at any s > 0)
            s_event, hit = km.first_event(normals, q, v, acc, h0, s_max)
            grid_step = not (hit >= 0 and s_event < s_max * (1.0 - 1e-12))
            s = s_max if grid_step else s_event
            newton += km.verlet_step(s, q, v, acc, f_air, minv, suspension, *force_args, film.P, *film_args)
            steps += 1
            if not np.isfinite(f_air).all():
                raise FloatingPointError(f"film pressure became non-finite at t = {t + s:.6g} s")
            if grid_step:
                t = t_target
                k += 1
                if k % out_every == 0 or k == n_grid:
                    ts.append(t)
                    qs.append(q.copy())
                    vs.append(v.copy())
                    fs.append(f_air.copy())
                continue
            t += s
            gap_hit = float(normals[hit] @ q - h0)
            if abs(gap_hit) > touch_tol:
                raise ContactError(f"event location missed the asperity height by {gap_hit:.3g} m")
            v = _resolve_impacts(scene, q, v, t, normals, touch_tol, minv, impacts)
            if len(impacts) >= scene.contact.max_impacts:
                status = 1
                message = f"stopped after {len(impacts)} impacts (contact.max_impacts) at t = {t:.6g} s"
                break
    except (ContactError, FloatingPointError, np.linalg.LinAlgError) as err:
        status, message = -1, f"{type(err).__name__}: {err}"
        log.warning("run failed: %s", message)
    film.work.reynolds_solves += steps
    film.work.newton_iterations += newton
    work = {
        "steps": steps,
        "reynolds_solves": film.work.reynolds_solves,
        "newton_iterations": newton,
        "rejected_steps": 0,
        "impacts": len(impacts),
        "wall_time": time.perf_counter() - wall0,
    }
    qs_arr = np.array(qs)
    return Result(
        t=np.array(ts),
        q=qs_arr,
        v=np.array(vs),
        corner_spacing=qs_arr @ normals.T,
        air_force=np.array(fs),
        impacts=impacts,
        status=status,
        message=message,
        steady=steady,
        work=work,
    )


def _resolve_impacts(
    scene: Scene,
    q: np.ndarray,
    v: np.ndarray,
    t: float,
    normals: np.ndarray,
    touch_tol: float,
    minv: np.ndarray,
    impacts: list[Impact],
) -> np.ndarray:
    """Apply the impact map at every corner touching the asperities and approaching them.

    Corners touching at once (two rear corners at zero roll) are resolved one
    after the other until none approaches (at most 8 passes).
    """
    touching = np.flatnonzero(np.abs(normals @ q - scene.disk.asperity_height) <= touch_tol)
    for _ in range(8):
        resolved = False
        for c in touching:
            v_new, impulse = impact_map(q, v, int(c), scene, minv)
            if impulse > 0.0:
                u_before = -float(normals[c] @ v)
                u_after = -float(normals[c] @ v_new)
                wedge = surface_slope(scene, int(c), float(q[1])) * scene.disk.speed
                impacts.append(Impact(t, int(c), impulse, u_before + wedge, u_after + wedge, u_before, u_after))
                v = v_new
                resolved = True
        if not resolved:
            break
    return v
