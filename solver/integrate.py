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
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .airbearing import make_air_bearing
from .contact import ContactError, Impact, corner_normal, impact_map, surface_slope
from .dynamics import mass_matrix, suspension_forces
from .geometry import corner_positions
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


def first_crossing(gap0: float, rate: float, curvature: float, s_max: float) -> float:
    """Smallest s in (0, s_max] with gap0 + rate s + curvature s^2 / 2 = 0, crossing downward.

    Returns inf if there is none.  gap0 >= 0 is the spacing above the
    asperities (m); rate its derivative (m/s); curvature its second derivative.
    """
    a, b, c = 0.5 * curvature, rate, gap0
    roots: list[float] = []
    if abs(a) * s_max * s_max <= 1e-14 * (abs(b) * s_max + abs(c)) or a == 0.0:
        if b < 0.0:
            roots.append(-c / b)
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            sq = math.sqrt(disc)
            # numerically stable pair of roots
            qq = -0.5 * (b + math.copysign(sq, b))
            if qq != 0.0:
                roots.extend([qq / a, c / qq])
            else:
                roots.append(0.0)
    best = math.inf
    for s in roots:
        if 0.0 < s <= s_max and rate + curvature * s < 0.0:
            best = min(best, s)
    return best


def simulate(scene: Scene, steady: SteadyFlight | None = None, *, progress: bool = False) -> Result:
    """Integrate one run of ``scene`` from steady flight plus the initial velocities."""
    wall0 = time.perf_counter()
    film = make_air_bearing(scene)
    if steady is None:
        steady = fly(scene, film=film)
    suspension = steady.suspension
    q = steady.q.copy()
    film.solve_steady(q, steady.pressure / scene.air.ambient_pressure)
    film.work.reynolds_solves = 0
    film.work.newton_iterations = 0
    init = scene.initial
    v = np.array([init.zdot, init.pitch_rate, init.roll_rate])
    num = scene.numerics
    minv = np.linalg.inv(mass_matrix(scene.slider))
    corners = corner_positions(scene.slider)
    normals = np.array([corner_normal(x1, x2) for x1, x2 in corners])
    h0 = scene.disk.asperity_height
    dt, t_end = num.dt, num.t_end
    n_grid = int(round(t_end / dt))
    out_every = max(1, int(round(num.output_interval / dt))) if num.output_interval > 0 else 1

    f_air = film.generalized_forces()
    acc = minv @ (f_air + suspension_forces(suspension, q))
    ts, qs, vs, cs, fs = [0.0], [q.copy()], [v.copy()], [normals @ q], [f_air.copy()]
    impacts: list[Impact] = []
    status, message = 0, "reached t_end"
    t, k = 0.0, 0
    steps = 0
    gaps0 = normals @ q - h0
    if np.any(gaps0 < -1e-9 * max(h0, 1e-12)):
        raise ContactError(f"a corner starts below the asperity height (spacings {(gaps0 + h0).tolist()} m)")
    try:
        while k < n_grid:
            t_target = (k + 1) * dt
            s_max = t_target - t
            grid_step = True
            if s_max < 1e-3 * dt and k + 1 < n_grid:
                k += 1
                t_target = (k + 1) * dt
                s_max = t_target - t
            gaps = normals @ q - h0
            rates = normals @ v
            curv = normals @ acc
            s_event, hit = math.inf, -1
            for c in range(4):
                s_c = first_crossing(max(gaps[c], 0.0), float(rates[c]), float(curv[c]), s_max)
                if s_c < s_event:
                    s_event, hit = s_c, c
            s = s_max
            if hit >= 0 and s_event < s_max * (1.0 - 1e-12):
                s = s_event
                grid_step = False
            v_half = v + 0.5 * s * acc
            q_new = q + s * v_half
            film.step(q, q_new, s)
            q = q_new
            f_air = film.generalized_forces()
            if not np.all(np.isfinite(f_air)):
                raise FloatingPointError(f"film pressure became non-finite at t = {t + s:.6g} s")
            acc = minv @ (f_air + suspension_forces(suspension, q))
            v = v_half + 0.5 * s * acc
            t = t_target if grid_step else t + s
            steps += 1
            if grid_step:
                k += 1
            else:
                gap_hit = float(normals[hit] @ q - h0)
                if abs(gap_hit) > 1e-9 * max(h0, 1e-9):
                    raise ContactError(f"event location missed corner spacing by {gap_hit:.3g} m")
                # resolve every corner that sits at the asperity height and approaches
                for _ in range(8):
                    touching = np.flatnonzero(np.abs(normals @ q - h0) <= 1e-9 * max(h0, 1e-9))
                    resolved = False
                    for c in touching:
                        v_new, impulse = impact_map(q, v, int(c), scene, minv)
                        if impulse > 0.0:
                            u_before = -float(normals[c] @ v)
                            u_after = -float(normals[c] @ v_new)
                            wedge = surface_slope(scene, int(c), float(q[1])) * scene.disk.speed
                            impacts.append(
                                Impact(t, int(c), impulse, u_before + wedge, u_after + wedge, u_before, u_after)
                            )
                            v = v_new
                            resolved = True
                    if not resolved:
                        break
                if len(impacts) >= scene.contact.max_impacts:
                    status, message = 1, f"stopped after {len(impacts)} impacts (contact.max_impacts) at t = {t:.6g} s"
                    break
            if grid_step and (k % out_every == 0 or k == n_grid):
                ts.append(t)
                qs.append(q.copy())
                vs.append(v.copy())
                cs.append(normals @ q)
                fs.append(f_air.copy())
    except (ContactError, FloatingPointError, np.linalg.LinAlgError) as err:
        status, message = -1, f"{type(err).__name__}: {err}"
        log.warning("run failed: %s", message)
    wall = time.perf_counter() - wall0
    work = {
        "steps": steps,
        "reynolds_solves": film.work.reynolds_solves,
        "newton_iterations": film.work.newton_iterations,
        "rejected_steps": 0,
        "impacts": len(impacts),
        "wall_time": wall,
    }
    return Result(
        t=np.array(ts),
        q=np.array(qs),
        v=np.array(vs),
        corner_spacing=np.array(cs),
        air_force=np.array(fs),
        impacts=impacts,
        status=status,
        message=message,
        steady=steady,
        work=work,
    )
