"""The implicit generalized-alpha step of an "abs" slider on its surface forces, as one kernel.

Unknown: the acceleration a = a_n+1 (3,).  The Newmark relations

    q(a) = q_n + h v_n + h^2 ((1/2 - beta) a_n + beta a),   v(a) = v_n + h ((1 - gamma) a_n + gamma a),

and the balance of the generalized-alpha method (:mod:`solver.abs.integrate`)

    G(a) = M [(1 - am) a + am a_n] + C [(1 - af) v + af v_n] + K [(1 - af) q + af q_n - q_ref] - f_static
           - (1 - af) (f_air(q) + f_s(q)) - af f_old = 0,

with the film force linear in q about the path the film was advanced along,
f_air(q) = f_path + K_f (q - q_path), and the Greenwood-Williamson surface
forces f_s (:func:`solver.kernels.surface.generalized_forces`, with either
adhesion law).  Newton's method with the exact Jacobian

    dG/da = (1 - am) M + (1 - af) (gamma h C + beta h^2 (K - df_s/dq - K_f)),

each step halved (at most ``max_backtracks`` times, down to ``min_damping``)
until the weighted residual max |W G| decreases.  Converged when max |W G|
< tol, or at the round-off of the forces: max |W G| <= round_off (max |W f_s|
+ max |W f_path|).  The same iteration as the Python loop of
:meth:`solver.abs.integrate.AbsStepper._newton`, which the elastic law uses.
The cells' adhesion (a quadrature per cell, most of the cost) is evaluated
with its curvature at the first iterate and taken from its Taylor expansion
at the later ones, whose separations move by far less than the roughness
(:func:`~solver.kernels.surface.generalized_forces`' cache).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .surface import CACHE_FILL, CACHE_USE, contact_damping, generalized_forces


@njit
def solve3(A: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x with A x = rhs for a 3 x 3 A: Gaussian elimination with partial pivoting (A and rhs are not changed)."""
    m = A.copy()
    x = rhs.copy()
    for k in range(3):
        p = k
        for r in range(k + 1, 3):
            if abs(m[r, k]) > abs(m[p, k]):
                p = r
        if p != k:
            for c in range(3):
                m[k, c], m[p, c] = m[p, c], m[k, c]
            x[k], x[p] = x[p], x[k]
        for r in range(k + 1, 3):
            factor = m[r, k] / m[k, k]
            for c in range(k, 3):
                m[r, c] -= factor * m[k, c]
            x[r] -= factor * x[k]
    for k in range(2, -1, -1):
        s = x[k]
        for c in range(k + 1, 3):
            s -= m[k, c] * x[c]
        x[k] = s / m[k, k]
    return x


@njit
def _balance(
    a_trial: np.ndarray,
    h: float,
    state: tuple,
    scheme: tuple,
    film: tuple,
    cells: tuple,
    law: tuple,
    damping: tuple,
    q1: np.ndarray,
    v1: np.ndarray,
    f_s: np.ndarray,
    dfdq: np.ndarray,
    c_s: np.ndarray,
    G: np.ndarray,
    cache: tuple,
    mode: int,
) -> tuple[float, float, int]:
    """q(a), v(a), the surface forces and G(a) into the output arrays; returns contact, adhesion, cells in reach.

    The contact force includes the contact damping's (zero unless ``damping`` = (zeta, M^-1, disk rates)
    has zeta > 0); ``c_s`` receives its damping matrix.
    """
    q, v, a = state
    M, C, K, q_ref, f_static, weights, alpha_m, alpha_f, gamma, beta = scheme
    f_path, q_path, film_K, f_old = film
    offset, sigma, b, area = cells
    eps, gw_coef, adh_coef, adhesion_law, summit_coef, mu, arm, reach, reach_sigmas = law
    zeta, m_inv, disk_rate = damping
    for k in range(3):
        q1[k] = q[k] + h * v[k] + h * h * ((0.5 - beta) * a[k] + beta * a_trial[k])
        v1[k] = v[k] + h * ((1.0 - gamma) * a[k] + gamma * a_trial[k])
    contact, adhesion, in_reach = generalized_forces(
        offset, sigma, b, area, q1, eps, gw_coef, adh_coef, adhesion_law, summit_coef, mu, arm, reach, reach_sigmas,
        f_s, dfdq, cache, mode,
    )  # fmt: skip
    if zeta > 0.0:
        contact += contact_damping(
            offset, sigma, b, area, q1, v1, disk_rate, eps, gw_coef, m_inv, zeta, mu, arm, f_s, dfdq, c_s
        )
    else:
        c_s[:, :] = 0.0
    for r in range(3):
        g = -f_static[r] - alpha_f * f_old[r]
        f_air = f_path[r]
        for c in range(3):
            g += M[r, c] * ((1.0 - alpha_m) * a_trial[c] + alpha_m * a[c])
            g += C[r, c] * ((1.0 - alpha_f) * v1[c] + alpha_f * v[c])
            g += K[r, c] * ((1.0 - alpha_f) * q1[c] + alpha_f * q[c] - q_ref[c])
            f_air += film_K[r, c] * (q1[c] - q_path[c])
        G[r] = g - (1.0 - alpha_f) * (f_air + f_s[r])
    return contact, adhesion, in_reach


@njit
def _weighted_max(x: np.ndarray, weights: np.ndarray) -> float:
    return max(abs(x[0] * weights[0]), abs(x[1] * weights[1]), abs(x[2] * weights[2]))


@njit
def newton_step(
    a_new: np.ndarray,
    h: float,
    state: tuple,
    scheme: tuple,
    film: tuple,
    cells: tuple,
    law: tuple,
    damping: tuple,
    controls: tuple,
    q1: np.ndarray,
    v1: np.ndarray,
    f_s: np.ndarray,
    dfdq: np.ndarray,
    cache: tuple,
    fill: bool,
) -> tuple[int, float, bool, float, float, int]:
    """Newton's method on a_n+1 (the module docstring), in place on a_new (the initial guess on entry).

    state : (q_n, v_n, a_n); scheme : (M, C, K, q_ref, f_static, weights, am, af, gamma, beta);
    film : (f_path, q_path, K_f, f_old); cells : (offset, sigma, b, area) of the candidate cells;
    law : (eps, gw_coef, adh_coef, adhesion_law, summit_coef, mu, arm, reach, reach_sigmas);
    damping : (zeta, M^-1, disk rate at the cells) of the contact damping
    (:func:`solver.kernels.surface.contact_damping`; zeta = 0: none);
    controls : (tol, round_off, max_iter, max_backtracks, min_damping).  On return q1, v1, f_s, dfdq
    hold the last iterate's attitude, velocities, surface force and its Jacobian.  ``cache`` = (d, p_a, p_a',
    p_a'') (k,) each: the cells' adhesion kept for its Taylor expansion
    (:func:`~solver.kernels.surface.generalized_forces`), filled at the first iterate when ``fill``, else
    taken as left by an earlier solve over the same cells (the step's predictor: a cell it no longer covers
    is evaluated afresh).  Returns (iterations, weighted residual, converged, contact force, adhesion force,
    cells in reach).
    """
    M, C, K, q_ref, f_static, weights, alpha_m, alpha_f, gamma, beta = scheme
    f_path, q_path, film_K, f_old = film
    tol, round_off, max_iter, max_backtracks, min_damping = controls
    G = np.empty(3)
    trial = np.empty(3)
    tq, tv, tf, tG = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    tJ = np.empty((3, 3))
    Cs, tC = np.empty((3, 3)), np.empty((3, 3))
    Jn = np.empty((3, 3))
    contact, adhesion, in_reach = _balance(
        a_new, h, state, scheme, film, cells, law, damping, q1, v1, f_s, dfdq, Cs, G, cache,
        CACHE_FILL if fill else CACHE_USE,
    )  # fmt: skip
    norm = _weighted_max(G, weights)
    scale = _weighted_max(f_path, weights)
    iterations = 0
    for _ in range(max_iter):
        iterations += 1
        if norm < tol or norm <= round_off * (_weighted_max(f_s, weights) + scale):
            break
        for r in range(3):
            for c in range(3):
                Jn[r, c] = (1.0 - alpha_m) * M[r, c] + (1.0 - alpha_f) * (
                    gamma * h * (C[r, c] + Cs[r, c]) + beta * h * h * (K[r, c] - dfdq[r, c] - film_K[r, c])
                )
        step = solve3(Jn, G)
        lam = 1.0
        trial_norm = norm
        totals = (contact, adhesion, in_reach)
        for _ in range(max_backtracks):
            for k in range(3):
                trial[k] = a_new[k] - lam * step[k]
            totals = _balance(
                trial, h, state, scheme, film, cells, law, damping, tq, tv, tf, tJ, tC, tG, cache, CACHE_USE
            )
            trial_norm = _weighted_max(tG, weights)
            if trial_norm < norm or lam < min_damping:
                break
            lam *= 0.5
        a_new[:] = trial
        q1[:] = tq
        v1[:] = tv
        f_s[:] = tf
        dfdq[:, :] = tJ
        Cs[:, :] = tC
        G[:] = tG
        norm = trial_norm
        contact, adhesion, in_reach = totals
    converged = norm < tol or norm <= round_off * (_weighted_max(f_s, weights) + scale)
    return iterations, norm, converged, contact, adhesion, in_reach


@njit
def contact_frequency_squared(m_inv: np.ndarray, dfdq: np.ndarray) -> float:
    """omega_c^2: the largest real part of the eigenvalues of M^-1 K_s, K_s = -dfdq (3, 3) [1/s^2].

    LAPACK's eigenvalues inside a kernel: called once or twice per step, where numpy's call costs about ten
    times the eigensolve of a 3 x 3.  Friction makes the matrix unsymmetric and its eigenvalues may be complex,
    which numba's real eigvals refuses: the matrix is passed as complex.
    """
    a = np.empty((3, 3), dtype=np.complex128)
    for r in range(3):
        for c in range(3):
            a[r, c] = -(m_inv[r, 0] * dfdq[0, c] + m_inv[r, 1] * dfdq[1, c] + m_inv[r, 2] * dfdq[2, c])
    return float(np.max(np.linalg.eigvals(a).real))
