"""Verlet steps of the slider on the reduced air-bearing models (no film state).

``quasi_static``: the film force is a function of the attitude only, read
from a table of steady solutions by tensor-product cubic Lagrange
interpolation (4 nodes per axis, non-uniform nodes).
``linearized``: f = f_s - K (q - q_s) - C v about steady flight; the damping
term makes the closing half kick implicit (a 3x3 solve).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .motion import accelerations


@njit
def _stencil(axis: np.ndarray, x: float, w: np.ndarray) -> tuple[int, int]:
    """First node of the 4-node stencil around x and its Lagrange weights in ``w``; flag 1 if x was clamped."""
    n = axis.size
    clamped = 0
    if x < axis[0]:
        x = axis[0]
        clamped = 1
    elif x > axis[n - 1]:
        x = axis[n - 1]
        clamped = 1
    i = 0
    while i < n - 2 and axis[i + 1] <= x:
        i += 1
    first = min(max(i - 1, 0), n - 4)
    for a in range(4):
        wa = 1.0
        xa = axis[first + a]
        for b in range(4):
            if b != a:
                xb = axis[first + b]
                wa *= (x - xb) / (xa - xb)
        w[a] = wa
    return first, clamped


@njit
def table_forces(
    q: np.ndarray, table: np.ndarray, az: np.ndarray, ap: np.ndarray, ar: np.ndarray, out: np.ndarray
) -> int:
    """Interpolated film generalized forces at q into ``out``; returns 1 if q lay outside the table."""
    wz = np.empty(4)
    wp = np.empty(4)
    wr = np.empty(4)
    iz, cz = _stencil(az, q[0], wz)
    ip, cp = _stencil(ap, q[1], wp)
    ir, cr = _stencil(ar, q[2], wr)
    for k in range(3):
        acc = 0.0
        for a in range(4):
            for b in range(4):
                wab = wz[a] * wp[b]
                for c in range(4):
                    acc += wab * wr[c] * table[iz + a, ip + b, ir + c, k]
        out[k] = acc
    return 1 if cz + cp + cr > 0 else 0


@njit
def kick_drift(s: float, q: np.ndarray, v: np.ndarray, acc: np.ndarray) -> None:
    """Verlet's opening half kick and drift, in place."""
    for k in range(3):
        v[k] += 0.5 * s * acc[k]
        q[k] += s * v[k]


@njit
def verlet_step_table(
    s: float,
    q: np.ndarray,
    v: np.ndarray,
    acc: np.ndarray,
    f_air: np.ndarray,
    minv: np.ndarray,
    suspension: np.ndarray,
    table: np.ndarray,
    az: np.ndarray,
    ap: np.ndarray,
    ar: np.ndarray,
) -> int:
    """One Verlet step on the quasi-static table; returns 1 if the attitude left the table."""
    kick_drift(s, q, v, acc)
    outside = table_forces(q, table, az, ap, ar, f_air)
    accelerations(f_air, q, suspension, minv, acc)
    for k in range(3):
        v[k] += 0.5 * s * acc[k]
    return outside


@njit
def linear_forces(
    q: np.ndarray, v: np.ndarray, f_s: np.ndarray, q_s: np.ndarray, K: np.ndarray, C: np.ndarray, out: np.ndarray
) -> None:
    """f = f_s - K (q - q_s) - C v into ``out``."""
    for i in range(3):
        f = f_s[i]
        for j in range(3):
            f -= K[i, j] * (q[j] - q_s[j]) + C[i, j] * v[j]
        out[i] = f


@njit
def verlet_step_linear(
    s: float,
    q: np.ndarray,
    v: np.ndarray,
    acc: np.ndarray,
    f_air: np.ndarray,
    minv: np.ndarray,
    suspension: np.ndarray,
    f_s: np.ndarray,
    q_s: np.ndarray,
    K: np.ndarray,
    C: np.ndarray,
) -> int:
    """One Verlet step on the linearized bearing (implicit in the damping of the closing half kick)."""
    kick_drift(s, q, v, acc)
    zero = np.zeros(3)
    f_static = np.empty(3)
    linear_forces(q, zero, f_s, q_s, K, C, f_static)
    a_static = np.empty(3)
    accelerations(f_static, q, suspension, minv, a_static)
    # (I + s/2 M^-1 C) v' = v_half + s/2 a_static
    mat = np.eye(3) + 0.5 * s * (minv @ C)
    rhs = np.empty(3)
    for k in range(3):
        rhs[k] = v[k] + 0.5 * s * a_static[k]
    v_new = np.linalg.solve(mat, rhs)
    for k in range(3):
        v[k] = v_new[k]
    linear_forces(q, v, f_s, q_s, K, C, f_air)
    accelerations(f_air, q, suspension, minv, acc)
    return 0
