"""Quasi-static elastic contact on a patch of cells: influence coefficients and a complementarity solve.

The slider and the disk are elastic half-spaces with the composite modulus
E' (1/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2, see ``solver.surface``).  A
pressure p on the surface moves the two surfaces together by

    w(x, y) = (1 / (pi E')) int int p(x', y') / sqrt((x - x')^2 + (y - y')^2) dx' dy'.

With p piecewise constant on rectangular cells, w at the centre of cell i is
sum_j C_ij p_j, where C_ij [m/Pa] is Love's (1929) closed form for a uniformly
loaded rectangle: over the rectangle [x1, x2] x [y1, y2] relative to the
field point,

    int int dA / r = G(x2, y2) - G(x1, y2) - G(x2, y1) + G(x1, y1),
    G(x, y) = sgn(x) sgn(y) H(|x|, |y|),  H(a, b) = a asinh(b/a) + b asinh(a/b),

H(a, b) being the integral over [0, a] x [0, b] (the integrand is even in x
and y).

Contact with a gap g0 = rigid separation - eps [m] (negative where the rigid
surfaces interpenetrate) is the linear complementarity problem

    p >= 0,   g = g0 + C p >= 0,   p g = 0,

i.e. the minimum of (1/2) p^T C p + g0^T p over p >= 0 when C is symmetric
positive definite (uniform cells).  Collocation at the centres of unequal
cells makes C unsymmetric (C_ij scales with the area of cell j); the blocks
are then solved by LU instead of Cholesky.  ``solve_contact`` uses block
principal pivoting (Judice & Pires 1994, as in Kim & Park's NNLS): guess the
set A of cells in contact, solve C_AA p_A = -g0_A, and exchange every cell
that violates p >= 0 or g >= 0; if the number of violations stops
decreasing, fall back to exchanging one cell at a time (Murty's rule, finite
for a P-matrix).  At convergence the solution is exact: p = 0 off A and g = 0
on A up to the round-off of one Cholesky solve.

Rough surfaces (``solve_rough_contact``): where each cell also carries
roughness of RMS sigma_i that the grid does not resolve, its asperities
(Greenwood-Williamson, the law of ``solver.kernels.surface``) sit on the
elastic half-spaces: the cell's mean planes are u_i apart, its asperities
carry p_i = P(u_i, sigma_i), and the bulk deflection under all the cells'
pressures opens the gap,

    u = d + C p(u),

with d the rigid separation.  P is positive and decreasing in u, so the bulk
compliance and the asperities' act in series: the solution has
0 < p_i <= P(d_i), it tends to the Greenwood-Williamson pressures as C -> 0,
and to the complementarity problem above when the asperity layer becomes a
hard wall at eps (sigma -> 0 with stiff summits; with the scene's summits,
sigma -> 0 leaves a layer of equal summits, Hertzian each, in series with the
bulk).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import cho_factor, cho_solve, lu_factor, lu_solve

from .errors import ElasticContactError

logger = logging.getLogger(__name__)


def _quadrant_integral(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """H(a, b) = int_0^a int_0^b dx dy / sqrt(x^2 + y^2) for a, b >= 0 (0 if either is 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        value = a * np.arcsinh(b / a) + b * np.arcsinh(a / b)
    return np.where((a > 0.0) & (b > 0.0), value, 0.0)


def _corner_integral(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Signed integral of 1/r over the rectangle between the field point and the corner (x, y)."""
    return np.sign(x) * np.sign(y) * _quadrant_integral(np.abs(x), np.abs(y))


def influence_coefficients(
    xp: ArrayLike,
    yp: ArrayLike,
    xc: ArrayLike,
    yc: ArrayLike,
    half_dx: ArrayLike,
    half_dy: ArrayLike,
    e_composite: float,
) -> np.ndarray:
    """Normal displacements at points (xp, yp) due to unit pressures on rectangular cells.

    Parameters
    ----------
    xp, yp : array (m,) [m]
        field points.
    xc, yc : array (n,) [m]
        cell centres.
    half_dx, half_dy : array (n,) or float [m]
        cell half-widths.
    e_composite : float [Pa]
        composite modulus E'.

    Returns
    -------
    C : ndarray (m, n) [m/Pa]
        w(xp_i, yp_i) = sum_j C_ij p_j (both bodies together).
    """
    xp = np.asarray(xp, dtype=float).reshape(-1, 1)
    yp = np.asarray(yp, dtype=float).reshape(-1, 1)
    xc = np.asarray(xc, dtype=float).reshape(1, -1)
    yc = np.asarray(yc, dtype=float).reshape(1, -1)
    half_dx = np.broadcast_to(np.asarray(half_dx, dtype=float), xc.shape)
    half_dy = np.broadcast_to(np.asarray(half_dy, dtype=float), yc.shape)
    x1 = xc - half_dx - xp
    x2 = xc + half_dx - xp
    y1 = yc - half_dy - yp
    y2 = yc + half_dy - yp
    total = _corner_integral(x2, y2)
    total -= _corner_integral(x1, y2)
    total -= _corner_integral(x2, y1)
    total += _corner_integral(x1, y1)
    return total / (np.pi * e_composite)


def influence_matrix(
    xc: ArrayLike, yc: ArrayLike, half_dx: ArrayLike, half_dy: ArrayLike, e_composite: float
) -> np.ndarray:
    """Influence matrix C (n, n) [m/Pa]: displacement at the centre of cell i due to unit pressure on cell j."""
    return influence_coefficients(xc, yc, xc, yc, half_dx, half_dy, e_composite)


def solve_contact(
    gap: ArrayLike, C: np.ndarray, tol: float = 1e-12, max_iter: int = 200
) -> tuple[np.ndarray, np.ndarray]:
    """Contact pressures of the complementarity problem p >= 0, gap + C p >= 0, p (gap + C p) = 0.

    Parameters
    ----------
    gap : array (n,) [m]
        rigid separation minus eps (negative where the rigid surfaces interpenetrate).
    C : array (n, n) [m/Pa]
        influence matrix (symmetric positive definite for uniform cells; a P-matrix in practice otherwise).
    tol : float
        relative tolerance: p_i >= -tol max|p| and g_i >= -tol max|gap| count as feasible.
    max_iter : int
        maximum number of pivoting iterations (each one Cholesky factorisation of C_AA).

    Returns
    -------
    p : ndarray (n,) [Pa], >= 0
    active : ndarray (n,) of bool, cells in contact (p solved from g = 0 there).

    Raises
    ------
    ElasticContactError
        if the pivoting does not converge in ``max_iter`` iterations or a block C_AA is singular.
    """
    gap = np.asarray(gap, dtype=float).reshape(-1)
    n = gap.size
    if C.shape != (n, n):
        raise ValueError(f"C must have shape ({n}, {n}), got {C.shape}")
    symmetric = _is_symmetric(C)
    active = gap < 0.0
    gap_scale = tol * max(np.max(np.abs(gap), initial=0.0), np.finfo(float).tiny)
    fewest_violations = n + 1
    full_exchanges_left = 3
    for iteration in range(1, max_iter + 1):
        p = _pressures_on(active, gap, C, symmetric)
        g = gap + C @ p
        g[active] = 0.0
        p_scale = tol * max(np.max(np.abs(p), initial=0.0), np.finfo(float).tiny)
        violated = (active & (p < -p_scale)) | (~active & (g < -gap_scale))
        n_violated = int(np.count_nonzero(violated))
        if n_violated == 0:
            logger.debug("elastic contact: %d cells in contact after %d iterations", active.sum(), iteration)
            return np.where(active, np.maximum(p, 0.0), 0.0), active
        if n_violated < fewest_violations:
            fewest_violations = n_violated
            full_exchanges_left = 3
            active = active ^ violated
        elif full_exchanges_left > 0:
            full_exchanges_left -= 1
            active = active ^ violated
        else:
            last = np.flatnonzero(violated)[-1]
            active[last] = not active[last]
    raise ElasticContactError(f"elastic contact did not converge in {max_iter} pivoting iterations")


def _pressures_on(active: np.ndarray, gap: np.ndarray, C: np.ndarray, symmetric: bool) -> np.ndarray:
    """p with p_A = -C_AA^-1 gap_A on the active set A and 0 elsewhere."""
    p = np.zeros(gap.size)
    if np.any(active):
        index = np.flatnonzero(active)
        p[index] = -_solve_block(C[np.ix_(index, index)], gap[index], symmetric)
    return p


def _solve_block(block: np.ndarray, rhs: np.ndarray, symmetric: bool) -> np.ndarray:
    """block^-1 rhs by Cholesky (symmetric C, uniform cells) or LU (non-uniform cells make C unsymmetric)."""
    try:
        if symmetric:
            return cho_solve(cho_factor(block), rhs)
        return lu_solve(lu_factor(block, check_finite=False), rhs)
    except np.linalg.LinAlgError as error:
        raise ElasticContactError("influence matrix on the contact set is singular or not positive definite") from error


def _is_symmetric(C: np.ndarray) -> bool:
    return bool(np.allclose(C, C.T, rtol=1e-12, atol=0.0))


def pressure_sensitivity(C: np.ndarray, active: ArrayLike) -> np.ndarray:
    """Derivative dp/dgap (n, n) [Pa/m] of the contact pressures with the active set held fixed.

    On the active set A, p_A = -C_AA^-1 gap_A, so dp_A/dgap_A = -C_AA^-1; every
    other entry is zero.  The sensitivity to a rigid-body coordinate q is
    S @ dgap/dq.
    """
    active = np.asarray(active, dtype=bool)
    sensitivity = np.zeros(C.shape)
    index = np.flatnonzero(active)
    if index.size:
        block = C[np.ix_(index, index)]
        sensitivity[np.ix_(index, index)] = -_solve_block(block, np.eye(index.size), _is_symmetric(block))
    return sensitivity


def solve_rough_contact(
    d: ArrayLike, sigma: ArrayLike, C: np.ndarray, eps: float, gw_coef: float, max_iter: int = 60
) -> tuple[np.ndarray, np.ndarray, int]:
    """Asperity pressures on elastic half-spaces: p = P(u, sigma) with u = d + C p (module docstring).

    Parameters
    ----------
    d : array (n,) [m]
        rigid separations of the cells' mean planes.
    sigma : array (n,) [m], > 0
        the cells' unresolved RMS roughness.
    C : array (n, n) [m/Pa]
        influence matrix of the cells.
    eps, gw_coef :
        the Greenwood-Williamson law's wall [m] and constant 4/3 eta E' sqrt(R) (``solver.abs.forces``).

    Returns
    -------
    p : ndarray (n,) [Pa]
    dp_dd : ndarray (n, n) [Pa/m], dp_i/dd_j (for the time step's Newton Jacobian)
    iterations : int

    Newton's method on G(u) = u - d - C P(u) from the rigid separations u = d
    (where G <= 0), with backtracking on |G|; converged when every |G_i| is below
    1e-12 of the cell's sigma (plus 1e-15 max |d|, the round-off).  dp/dd = diag(P') (I - C diag(P'))^-1.

    Raises
    ------
    ElasticContactError
        if Newton's method does not converge in ``max_iter`` iterations.
    """
    from solver.kernels.surface import contact_pressures

    d = np.ascontiguousarray(d, dtype=float).reshape(-1)
    sigma = np.ascontiguousarray(sigma, dtype=float).reshape(-1)
    if np.any(sigma <= 0.0):
        raise ValueError("solve_rough_contact needs sigma > 0 on every cell (sigma = 0: use solve_contact)")
    n = d.size
    out = np.empty((2, n))
    tol = 1e-12 * sigma + 1e-15 * np.abs(d).max()  # and the round-off of u - d - C P

    def residual(u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        contact_pressures(u, sigma, eps, gw_coef, out)
        return u - d - C @ out[0], out[0].copy(), out[1].copy()

    u = d.copy()
    G, P, dP = residual(u)
    for iteration in range(max_iter + 1):
        if np.all(np.abs(G) <= tol):
            J = np.eye(n) - C * dP[None, :]
            return P, dP[:, None] * np.linalg.solve(J, np.eye(n)), iteration
        if iteration == max_iter:
            break
        J = np.eye(n) - C * dP[None, :]
        step = np.linalg.solve(J, -G)
        norm, alpha = np.linalg.norm(G), 1.0
        for _ in range(40):
            trial = residual(u + alpha * step)
            if np.linalg.norm(trial[0]) <= (1.0 - 1e-4 * alpha) * norm:
                break
            alpha *= 0.5
        u = u + alpha * step
        G, P, dP = trial
    raise ElasticContactError(
        f"rough elastic contact did not converge in {max_iter} Newton iterations "
        f"(largest residual {np.abs(G).max():.3e} m on {n} cells)"
    )
