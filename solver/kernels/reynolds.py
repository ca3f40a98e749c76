"""Finite-volume compressible Reynolds equation with slip: residual, Jacobian, line solves.

Scaled equation (P = p/p0, H = h/h_ref, X = x/L, Y = y/L):

    sigma d(P H)/dt + d/dX[Lambda H P - D dP/dX] + d/dY[- D dP/dY] = 0,
    D(P, H) = H^3 P + c1 Kn H^2 + c2 Kn^2 H / P,

with Lambda = 6 eta V L / (p0 h_ref^2), sigma = 12 eta L^2 / (p0 h_ref^2) [s]
and Kn = lambda / h_ref.  First-order slip is (c1, c2) = (6, 0), continuum
flow (0, 0), the Hsia-Domoto second-order law (6, 6).

Node-centred control volumes on a tensor grid per rail.  The x-face flux is
the Scharfetter-Gummel (exponentially fitted) flux, exact for 1-D
convection-diffusion with constant coefficients and stable at any cell
Peclet number Pe = Lambda H dx / D:

    F = g (P_L - P_R) + a P_L,   a = Lambda H_f,   g = (D_f / dx) B(Pe),
    B(x) = x / (exp(x) - 1),

with D_f evaluated at the face spacing and the mean face pressure.  The
y-face flux is pure diffusion, G = -D_f (P_R - P_L) / dy.  Node residual:

    R_ij = (F_{i+1/2} - F_{i-1/2}) dy_j + (G_{j+1/2} - G_{j-1/2}) dx_i

(telescoping sums: the scheme conserves mass exactly).  Dirichlet nodes
(P = 1 on every rail edge) carry R = 0 and empty Jacobian rows.

The Jacobian is returned as x-line and y-line tridiagonal parts,
J = Jx + Jy, so that both a sparse direct Newton step (steady state) and an
approximate factorisation (D + Jx) D^-1 (D + Jy) (time stepping, linear
cost) can be built from one assembly.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit

# Taylor coefficients of B(x) = x / (exp(x) - 1) = 1 - x/2 + sum_k C_2k x^2k,
# C_2k = b_2k / (2k)! with the Bernoulli numbers b_2k.  Up to x^20 the
# truncation error is below 6e-18 for x <= 1 (the x^22 term).
_BERNOULLI_2K = (
    1 / 6,
    -1 / 30,
    1 / 42,
    -1 / 30,
    5 / 66,
    -691 / 2730,
    7 / 6,
    -3617 / 510,
    43867 / 798,
    -174611 / 330,
)
_C2, _C4, _C6, _C8, _C10, _C12, _C14, _C16, _C18, _C20 = (
    b / math.factorial(2 * k + 2) for k, b in enumerate(_BERNOULLI_2K)
)


@njit
def bernoulli(x: float) -> tuple[float, float]:
    """B(x) = x / (exp(x) - 1) and B'(x), for x >= 0 (series below 1, exp above)."""
    if x < 1.0:
        u = x * x
        even = 1.0 + u * (_C2 + u * (_C4 + u * (_C6 + u * (_C8 + u * (_C10 + u * (_C12 + u * (
            _C14 + u * (_C16 + u * (_C18 + u * _C20)))))))))  # fmt: skip
        odd = 2.0 * _C2 + u * (4.0 * _C4 + u * (6.0 * _C6 + u * (8.0 * _C8 + u * (10.0 * _C10 + u * (
            12.0 * _C12 + u * (14.0 * _C14 + u * (16.0 * _C16 + u * (18.0 * _C18 + u * 20.0 * _C20))))))))  # fmt: skip
        return even - 0.5 * x, -0.5 + x * odd
    if x > 700.0:
        return 0.0, 0.0
    em = math.exp(-x)
    one_minus = 1.0 - em
    inv = 1.0 / one_minus
    b = x * em * inv
    db = em * (one_minus - x) * inv * inv
    return b, db


@njit
def face_diffusion(hf: float, pf: float, kn1: float, kn2: float, second_order: bool) -> tuple[float, float]:
    """Face coefficient D = H^3 P + c1 Kn H^2 + c2 Kn^2 H / P and dD/dP_node = (dD/dP_face) / 2."""
    h2 = hf * hf
    d = h2 * hf * pf + kn1 * h2
    dd = 0.5 * h2 * hf
    if second_order:
        inv_pf = 1.0 / pf
        d += kn2 * hf * inv_pf
        dd -= 0.5 * kn2 * hf * inv_pf * inv_pf
    return d, dd


@njit
def assemble(
    P: np.ndarray,
    H: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dxc: np.ndarray,
    dyc: np.ndarray,
    lam: float,
    kn: float,
    c1: float,
    c2: float,
    R: np.ndarray,
    Jcx: np.ndarray,
    Jxm: np.ndarray,
    Jxp: np.ndarray,
    Jcy: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    y_flux: bool,
) -> None:
    """Flux residual R(P; H) and its Jacobian split into x- and y-line parts.

    ``y_flux=False`` drops the y-face fluxes: an infinitely wide bearing
    (no side leakage), used for the 1-D analytic checks.

    P, H : (nr, nx, ny) nodes; Hx : (nr, nx-1, ny) x-faces; Hy : (nr, nx, ny-1) y-faces.
    dx : (nx-1,) node spacings; dxc : (nx,) control-volume widths (same for y).
    Outputs (nr, nx, ny) are overwritten at interior nodes only; their
    Dirichlet rows are never touched, so allocate them with zeros.  With
    ``y_flux=False`` Jcy, Jym, Jyp are not written either.
    """
    nr, nx, ny = P.shape
    kn1 = c1 * kn
    kn2 = c2 * kn * kn
    second_order = kn2 != 0.0
    for r in range(nr):
        for i in range(nx - 1):
            inv_dx = 1.0 / dx[i]
            for j in range(1, ny - 1):
                hf = Hx[r, i, j]
                pl = P[r, i, j]
                pr = P[r, i + 1, j]
                d, dd = face_diffusion(hf, 0.5 * (pl + pr), kn1, kn2, second_order)
                a = lam * hf
                pe = a * dx[i] / d
                b, db = bernoulli(pe)
                g = d * b * inv_dx
                dg = (b - pe * db) * inv_dx
                jump = pl - pr
                flux = g * jump + a * pl
                dfl = g + a + jump * dg * dd
                dfr = -g + jump * dg * dd
                w = dyc[j]
                # faces are visited in order, so a node's left face (which
                # assigns) always comes before its right face (which adds)
                if i > 0:
                    R[r, i, j] += flux * w
                    Jcx[r, i, j] += dfl * w
                    Jxp[r, i, j] = dfr * w
                if i + 1 < nx - 1:
                    R[r, i + 1, j] = -flux * w
                    Jxm[r, i + 1, j] = -dfl * w
                    Jcx[r, i + 1, j] = -dfr * w
        if not y_flux:
            continue
        for i in range(1, nx - 1):
            w = dxc[i]
            for j in range(ny - 1):
                inv_dy = 1.0 / dy[j]
                hf = Hy[r, i, j]
                pl = P[r, i, j]
                pr = P[r, i, j + 1]
                d, dd = face_diffusion(hf, 0.5 * (pl + pr), kn1, kn2, second_order)
                jump = pr - pl
                flux = -d * jump * inv_dy
                dfl = (d - jump * dd) * inv_dy
                dfr = (-d - jump * dd) * inv_dy
                if j > 0:
                    R[r, i, j] += flux * w
                    Jcy[r, i, j] += dfl * w
                    Jyp[r, i, j] = dfr * w
                if j + 1 < ny - 1:
                    R[r, i, j + 1] -= flux * w
                    Jym[r, i, j + 1] = -dfl * w
                    Jcy[r, i, j + 1] = -dfr * w


@njit
def af_solve(
    diag: np.ndarray,
    Jcx: np.ndarray,
    Jxm: np.ndarray,
    Jxp: np.ndarray,
    Jcy: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    rhs: np.ndarray,
    weight: float,
    delta: np.ndarray,
    work: np.ndarray,
) -> None:
    """Approximate-factorisation solve of (diag + weight J) delta = rhs.

    Solves (diag + weight Jx) w = rhs along x-lines, then
    (diag + weight Jy) delta = diag w along y-lines (Thomas algorithm), i.e.
    (diag + wJx) diag^-1 (diag + wJy) delta = rhs, which differs from the
    exact system by weight^2 Jx diag^-1 Jy delta.  Dirichlet nodes get
    delta = 0.  diag must be > 0 at interior nodes.  work : (nr, nx, ny).
    """
    nr, nx, ny = rhs.shape
    cp = np.empty((nx, ny))
    dp = np.empty((nx, ny))
    delta[:] = 0.0
    work[:] = 0.0
    for r in range(nr):
        # x-lines, swept for all j at once (contiguous inner loop)
        for i in range(1, nx - 1):
            for j in range(1, ny - 1):
                lower = weight * Jxm[r, i, j] if i > 1 else 0.0
                upper = weight * Jxp[r, i, j] if i < nx - 2 else 0.0
                inv = (
                    1.0 / (diag[r, i, j] + weight * Jcx[r, i, j] - lower * cp[i - 1, j])
                    if i > 1
                    else 1.0 / (diag[r, i, j] + weight * Jcx[r, i, j])
                )
                cp[i, j] = upper * inv
                dp[i, j] = (rhs[r, i, j] - lower * dp[i - 1, j]) * inv if i > 1 else rhs[r, i, j] * inv
        for j in range(1, ny - 1):
            work[r, nx - 2, j] = dp[nx - 2, j]
        for i in range(nx - 3, 0, -1):
            for j in range(1, ny - 1):
                work[r, i, j] = dp[i, j] - cp[i, j] * work[r, i + 1, j]
        for i in range(1, nx - 1):
            for j in range(1, ny - 1):
                lower = weight * Jym[r, i, j] if j > 1 else 0.0
                upper = weight * Jyp[r, i, j] if j < ny - 2 else 0.0
                mid = diag[r, i, j] + weight * Jcy[r, i, j]
                source = diag[r, i, j] * work[r, i, j]
                if j > 1:
                    inv = 1.0 / (mid - lower * cp[0, j - 1])
                    cp[0, j] = upper * inv
                    dp[0, j] = (source - lower * dp[0, j - 1]) * inv
                else:
                    inv = 1.0 / mid
                    cp[0, j] = upper * inv
                    dp[0, j] = source * inv
            delta[r, i, ny - 2] = dp[0, ny - 2]
            for j in range(ny - 3, 0, -1):
                delta[r, i, j] = dp[0, j] - cp[0, j] * delta[r, i, j + 1]


@njit
def fill_spacing(
    z: float,
    pitch: float,
    roll: float,
    x: np.ndarray,
    y: np.ndarray,
    xf: np.ndarray,
    yf: np.ndarray,
    recess: np.ndarray,
    recess_xf: np.ndarray,
    recess_yf: np.ndarray,
    inv_href: float,
    H: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
) -> None:
    """Scaled spacing at nodes and faces: H = (z - x1 pitch - x2 roll + recess) / h_ref.

    x : (nx,) [m]; y : (nr, ny) absolute x2 of each rail's nodes [m];
    xf : (nx-1,) x-face positions; yf : (nr, ny-1); recess arrays [m] give
    the surface's depth below the flat (taper, etch) at nodes and faces.
    """
    fill_node_spacing(z, pitch, roll, x, y, recess, inv_href, H)
    fill_node_spacing(z, pitch, roll, xf, y, recess_xf, inv_href, Hx)
    fill_node_spacing(z, pitch, roll, x, yf, recess_yf, inv_href, Hy)


@njit
def fill_node_spacing(
    z: float,
    pitch: float,
    roll: float,
    x: np.ndarray,
    y: np.ndarray,
    recess: np.ndarray,
    inv_href: float,
    H: np.ndarray,
) -> None:
    """Scaled spacing on one tensor grid of points (nodes or faces), see :func:`fill_spacing`."""
    nr, nx, ny = H.shape
    for r in range(nr):
        for i in range(nx):
            base = z - x[i] * pitch
            for j in range(ny):
                H[r, i, j] = (base - y[r, j] * roll + recess[r, i, j]) * inv_href


@njit
def load_moments(P: np.ndarray, area: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Integrals of (P - 1) dA, x (P - 1) dA and y (P - 1) dA (midpoint rule on control volumes).

    P : (nr, nx, ny); area : (nx, ny) control-volume areas; x : (nx,); y : (nr, ny).
    """
    nr, nx, ny = P.shape
    q = 0.0
    qx = 0.0
    qy = 0.0
    for r in range(nr):
        for i in range(nx):
            for j in range(ny):
                dq = (P[r, i, j] - 1.0) * area[i, j]
                q += dq
                qx += x[i] * dq
                qy += y[r, j] * dq
    return q, qx, qy


@njit
def midpoint_rhs(
    P_iter: np.ndarray,
    P_old: np.ndarray,
    H_new: np.ndarray,
    H_old: np.ndarray,
    area: np.ndarray,
    ct: float,
    R: np.ndarray,
    diag: np.ndarray,
    rhs: np.ndarray,
) -> float:
    """Newton right-hand side of the implicit-midpoint film step.

    Residual  ct A (P H_new - P_old H_old) + R((P_old + P) / 2; H_mid)  with R
    already evaluated at the midpoint; diag = ct A H_new.  Returns the max
    of |rhs| / diag, a pressure change in units of p0.
    """
    nr, nx, ny = P_iter.shape
    worst = 0.0
    for r in range(nr):
        for i in range(1, nx - 1):
            for j in range(1, ny - 1):
                ca = ct * area[i, j]
                dg = ca * H_new[r, i, j]
                diag[r, i, j] = dg
                res = ca * (P_iter[r, i, j] * H_new[r, i, j] - P_old[r, i, j] * H_old[r, i, j]) + R[r, i, j]
                rhs[r, i, j] = -res
                scaled = abs(res) / dg
                if scaled > worst:
                    worst = scaled
    return worst


@njit
def film_step(
    P: np.ndarray,
    q_old: np.ndarray,
    q_new: np.ndarray,
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
    ct: float,
    max_iter: int,
    tol: float,
    P_old: np.ndarray,
    P_mid: np.ndarray,
    H_old: np.ndarray,
    H_new: np.ndarray,
    H_mid: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    R: np.ndarray,
    Jcx: np.ndarray,
    Jxm: np.ndarray,
    Jxp: np.ndarray,
    Jcy: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    diag: np.ndarray,
    rhs: np.ndarray,
    delta: np.ndarray,
    work: np.ndarray,
) -> int:
    """One implicit-midpoint film step in place on P; returns the Newton iterations.

    The attitude moves linearly from q_old to q_new over the step, so the
    midpoint spacing is the spacing at (q_old + q_new) / 2.  Iteration k
    solves (ct A H' + J(P_mid)/2) delta = -residual by approximate
    factorisation; the first iterate linearises about the old pressure.
    """
    fill_node_spacing(q_old[0], q_old[1], q_old[2], x, y, recess, inv_href, H_old)
    fill_node_spacing(q_new[0], q_new[1], q_new[2], x, y, recess, inv_href, H_new)
    fill_spacing(0.5 * (q_old[0] + q_new[0]), 0.5 * (q_old[1] + q_new[1]), 0.5 * (q_old[2] + q_new[2]),
                 x, y, xf, yf, recess, recess_xf, recess_yf, inv_href, H_mid, Hx, Hy)  # fmt: skip
    P_old[:] = P
    its = 0
    for k in range(max_iter):
        if k == 0:
            P_lin = P_old
        else:
            for idx in range(P.size):
                P_mid.flat[idx] = 0.5 * (P_old.flat[idx] + P.flat[idx])
            P_lin = P_mid
        assemble(
            P_lin,
            H_mid,
            Hx,
            Hy,
            dx,
            dy,
            dxc,
            dyc,
            lam,
            kn,
            c1,
            c2,
            R,
            Jcx,
            Jxm,
            Jxp,
            Jcy,
            Jym,
            Jyp,
            True,
        )
        worst = midpoint_rhs(P, P_old, H_new, H_old, area, ct, R, diag, rhs)
        if k > 0 and worst < tol:
            break
        af_solve(diag, Jcx, Jxm, Jxp, Jcy, Jym, Jyp, rhs, 0.5, delta, work)
        for idx in range(P.size):
            P.flat[idx] += delta.flat[idx]
        its += 1
    return its
