"""Rigid-body step of the slider around the film step, and exact event roots.

Velocity Verlet (see :mod:`solver.rails.integrate`): half kick with the old
acceleration, drift, film step over the drift, forces, half kick.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from .reynolds import film_step, load_moments


@njit
def first_crossing(gap0: float, rate: float, curvature: float, s_max: float) -> float:
    """Smallest s in (0, s_max] with gap0 + rate s + curvature s^2 / 2 = 0, crossing downward.

    Returns inf if there is none.  gap0 >= 0 is the spacing above the
    asperities [m]; rate its time derivative [m/s]; curvature its second.
    A corner already touching (gap0 == 0) that approaches (rate < 0, or
    rate == 0 and curvature < 0) returns 0: the event is now.
    """
    if gap0 <= 0.0 and (rate < 0.0 or (rate == 0.0 and curvature < 0.0)):
        return 0.0
    a = 0.5 * curvature
    b = rate
    c = gap0
    best = math.inf
    r1 = math.inf
    r2 = math.inf
    if a == 0.0 or abs(a) * s_max * s_max <= 1e-14 * (abs(b) * s_max + abs(c)):
        if b < 0.0:
            r1 = -c / b
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            sq = math.sqrt(disc)
            qq = -0.5 * (b + math.copysign(sq, b))
            if qq != 0.0:
                r1 = qq / a
                r2 = c / qq
            else:
                r1 = 0.0
    for s in (r1, r2):
        if 0.0 < s <= s_max and rate + curvature * s < 0.0 and s < best:
            best = s
    return best


@njit
def first_event(
    normals: np.ndarray, q: np.ndarray, v: np.ndarray, acc: np.ndarray, h0: float, s_max: float
) -> tuple[float, int]:
    """Earliest corner reaching the asperity height on the step's drift q + s v + s^2/2 acc.

    normals : (nc, 3) rows n with corner spacing n . q.  Returns (s, corner)
    or (inf, -1).
    """
    best = math.inf
    hit = -1
    for c in range(normals.shape[0]):
        gap = 0.0
        rate = 0.0
        curv = 0.0
        for k in range(3):
            gap += normals[c, k] * q[k]
            rate += normals[c, k] * v[k]
            curv += normals[c, k] * acc[k]
        gap -= h0
        s = first_crossing(max(gap, 0.0), rate, curv, s_max)
        if s < best:
            best = s
            hit = c
    return best, hit


@njit
def generalized_forces(
    P: np.ndarray,
    area: np.ndarray,
    x_scaled: np.ndarray,
    y_scaled: np.ndarray,
    force_scale: float,
    moment_scale: float,
    out: np.ndarray,
) -> None:
    """Film generalized forces (Q, -S1 Q, -S2 Q) [N, N m, N m] into ``out``."""
    q, qx, qy = load_moments(P, area, x_scaled, y_scaled)
    out[0] = q * force_scale
    out[1] = -qx * moment_scale
    out[2] = -qy * moment_scale


@njit
def accelerations(f_air: np.ndarray, q: np.ndarray, suspension: np.ndarray, minv: np.ndarray, acc: np.ndarray) -> None:
    """acc = M^-1 (f_air + f_susp); suspension = (F, M1, M2, k1, k2)."""
    f0 = f_air[0] - suspension[0]
    f1 = f_air[1] + suspension[1] - suspension[3] * q[1]
    f2 = f_air[2] + suspension[2] - suspension[4] * q[2]
    for k in range(3):
        acc[k] = minv[k, 0] * f0 + minv[k, 1] * f1 + minv[k, 2] * f2


@njit
def verlet_step(
    s: float,
    q: np.ndarray,
    v: np.ndarray,
    acc: np.ndarray,
    f_air: np.ndarray,
    minv: np.ndarray,
    suspension: np.ndarray,
    force_scale: float,
    moment_scale: float,
    x_scaled: np.ndarray,
    y_scaled: np.ndarray,
    P: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    xf: np.ndarray,
    yf: np.ndarray,
    recess: np.ndarray,
    recess_xf: np.ndarray,
    recess_yf: np.ndarray,
    inv_href: float,
    dx: np.ndarray,
    dy: np.ndarray,
    dxc: np.ndarray,
    dyc: np.ndarray,
    area: np.ndarray,
    lam: float,
    kn: float,
    c1: float,
    c2: float,
    sigma: float,
    max_iter: int,
    tol: float,
    P_old: np.ndarray,
    P_mid: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    Jcy: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    diag: np.ndarray,
    delta: np.ndarray,
    work: np.ndarray,
) -> int:
    """One Verlet step of size s in place on (q, v, acc, f_air, P); returns Newton iterations."""
    q_old = q.copy()
    for k in range(3):
        v[k] += 0.5 * s * acc[k]
        q[k] += s * v[k]
    its = film_step(
        P, q_old, q, x, y, xf, yf, recess, recess_xf, recess_yf, inv_href, dx, dy, dxc, dyc, area,
        lam, kn, c1, c2, sigma / s, max_iter, tol, P_old, P_mid, Hx, Hy, Jcy, Jym, Jyp, diag, delta, work,
    )  # fmt: skip
    generalized_forces(P, area, x_scaled, y_scaled, force_scale, moment_scale, f_air)
    accelerations(f_air, q, suspension, minv, acc)
    for k in range(3):
        v[k] += 0.5 * s * acc[k]
    return its


@njit
def spacing_error(normals: np.ndarray, free: np.ndarray, dacc: np.ndarray, s: float) -> float:
    """Verlet's local error in the free corners' spacing: max_c |n_c . (a_{n+1} - a_n)| s^2 / 6 [m]."""
    worst = 0.0
    for c in range(normals.shape[0]):
        if free[c]:
            d = abs(normals[c, 0] * dacc[0] + normals[c, 1] * dacc[1] + normals[c, 2] * dacc[2])
            worst = max(worst, d)
    return worst * s * s / 6.0
