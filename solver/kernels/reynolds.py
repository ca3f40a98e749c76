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
def bernoulli_series(x: float) -> tuple[float, float]:
    """B(x) and B'(x) from the Taylor series above, for |x| < 1 (branch-free, so loops over it vectorize)."""
    u = x * x
    even = 1.0 + u * (_C2 + u * (_C4 + u * (_C6 + u * (_C8 + u * (_C10 + u * (_C12 + u * (
        _C14 + u * (_C16 + u * (_C18 + u * _C20)))))))))  # fmt: skip
    odd = 2.0 * _C2 + u * (4.0 * _C4 + u * (6.0 * _C6 + u * (8.0 * _C8 + u * (10.0 * _C10 + u * (
        12.0 * _C12 + u * (14.0 * _C14 + u * (16.0 * _C16 + u * (18.0 * _C18 + u * 20.0 * _C20))))))))  # fmt: skip
    return even - 0.5 * x, -0.5 + x * odd


@njit
def bernoulli(x: float) -> tuple[float, float]:
    """B(x) = x / (exp(x) - 1) and B'(x), for x >= 0 (series below 1, exp above)."""
    if x < 1.0:
        return bernoulli_series(x)
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
def x_face_coefficients(
    pl: float, pr: float, hf: float, inv_dx: float, lam: float, kn1: float, kn2: float, second_order: bool
) -> tuple[float, float, float, float]:
    """D and dD/dP_node at the mean face pressure, a = Lambda H_f and the cell Peclet number Pe = a dx / D."""
    d, dd = face_diffusion(hf, 0.5 * (pl + pr), kn1, kn2, second_order)
    a = lam * hf
    return d, dd, a, a / (d * inv_dx)


@njit
def sg_flux(
    pl: float, pr: float, d: float, dd: float, a: float, pe: float, b: float, db: float, inv_dx: float
) -> tuple[float, float, float]:
    """Scharfetter-Gummel flux F = g (P_L - P_R) + a P_L, g = (D / dx) B(Pe), and dF/dP_L, dF/dP_R.

    b, db = B(Pe), B'(Pe); dg/dP_node = (B - Pe B') (dD/dP_node) / dx.
    """
    g = d * b * inv_dx
    dg = (b - pe * db) * inv_dx * dd
    jump = pl - pr
    return g * jump + a * pl, g + a + jump * dg, -g + jump * dg


@njit
def x_face_fluxes(
    P: np.ndarray,
    Hx: np.ndarray,
    dx: np.ndarray,
    r: int,
    lam: float,
    kn1: float,
    kn2: float,
    second_order: bool,
    xface: np.ndarray,
) -> None:
    """Scharfetter-Gummel fluxes on all x-faces (i+1/2, j) of rail r, the Dirichlet columns included.

    xface : (4, (nx-1) ny), flat face index k = i ny + j: F, dF/dP_L,
    dF/dP_R and 1/dx_i.  Face k lies between nodes k (P_L) and k + ny (P_R)
    of the flattened rail.  One flat loop over the faces is long and
    branch-free, so it vectorizes: B(Pe) comes from its series there, and
    the rare faces with Pe >= 1 are then redone with the exponential form.
    """
    nx, ny = P.shape[1], P.shape[2]
    nf = (nx - 1) * ny
    flux, dfl, dfr, inv_dx = xface[0], xface[1], xface[2], xface[3]
    for i in range(nx - 1):
        inv = 1.0 / dx[i]
        for j in range(ny):
            inv_dx[i * ny + j] = inv
    P_left = P[r].reshape(nx * ny)
    P_right = P_left[ny:]  # a shifted view keeps every index a plain loop counter (no negative-index checks)
    H_face = Hx[r].reshape(nf)
    n_exp = 0  # an integer count keeps the loop vectorizable
    for k in range(nf):
        pl = P_left[k]
        pr = P_right[k]
        d, dd, a, pe = x_face_coefficients(pl, pr, H_face[k], inv_dx[k], lam, kn1, kn2, second_order)
        n_exp += pe >= 1.0
        b, db = bernoulli_series(pe)
        flux[k], dfl[k], dfr[k] = sg_flux(pl, pr, d, dd, a, pe, b, db, inv_dx[k])
    if n_exp == 0:
        return
    for k in range(nf):
        pl = P_left[k]
        pr = P_right[k]
        d, dd, a, pe = x_face_coefficients(pl, pr, H_face[k], inv_dx[k], lam, kn1, kn2, second_order)
        if pe >= 1.0:
            b, db = bernoulli(pe)
            flux[k], dfl[k], dfr[k] = sg_flux(pl, pr, d, dd, a, pe, b, db, inv_dx[k])


@njit
def y_face_flux(
    pl: float, pr: float, hf: float, inv_dy: float, kn1: float, kn2: float, second_order: bool
) -> tuple[float, float, float]:
    """Diffusive y-face flux G = -D (P_R - P_L) / dy and dG/dP_L, dG/dP_R."""
    d, dd = face_diffusion(hf, 0.5 * (pl + pr), kn1, kn2, second_order)
    jump = pr - pl
    return -d * jump * inv_dy, (d - jump * dd) * inv_dy, (-d - jump * dd) * inv_dy


@njit
def node_share(
    f_plus: float,
    f_minus: float,
    dl_plus: float,
    dl_minus: float,
    dr_plus: float,
    dr_minus: float,
    width: float,
) -> tuple[float, float, float, float]:
    """A node's share of the two faces around it along one line (fluxes F, dF/dP_L, dF/dP_R; face width w).

    Net outflow (F_+ - F_-) w and the node's tridiagonal Jacobian row along
    the line: centre (dF_+/dP_L - dF_-/dP_R) w, lower -dF_-/dP_L w, upper
    dF_+/dP_R w.
    """
    return (f_plus - f_minus) * width, (dl_plus - dr_minus) * width, -dl_minus * width, dr_plus * width


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

    Per rail the x-face fluxes go into buffers (:func:`x_face_fluxes`),
    per node row the y-face fluxes into a line buffer, and each interior
    node takes its :func:`node_share` of both lines:
    R = (F_{i+1/2} - F_{i-1/2}) dyc_j + (G_{j+1/2} - G_{j-1/2}) dxc_i.
    """
    nr, nx, ny = P.shape
    kn1 = c1 * kn
    kn2 = c2 * kn * kn
    second_order = kn2 != 0.0
    xface = np.empty((4, (nx - 1) * ny))
    flux, dfl, dfr = xface[0].reshape(nx - 1, ny), xface[1].reshape(nx - 1, ny), xface[2].reshape(nx - 1, ny)
    yface = np.zeros((3, ny))  # G, dG/dP_L, dG/dP_R at j+1/2; stays zero without y fluxes
    inv_dy = np.empty(ny)
    for j in range(ny - 1):
        inv_dy[j] = 1.0 / dy[j]
    for r in range(nr):
        x_face_fluxes(P, Hx, dx, r, lam, kn1, kn2, second_order, xface)
        for i in range(1, nx - 1):
            if y_flux:
                for j in range(ny - 1):
                    yface[0, j], yface[1, j], yface[2, j] = y_face_flux(
                        P[r, i, j], P[r, i, j + 1], Hy[r, i, j], inv_dy[j], kn1, kn2, second_order
                    )
            w = dxc[i]
            for j in range(1, ny - 1):
                rx, Jcx[r, i, j], Jxm[r, i, j], Jxp[r, i, j] = node_share(
                    flux[i, j], flux[i - 1, j], dfl[i, j], dfl[i - 1, j], dfr[i, j], dfr[i - 1, j], dyc[j]
                )
                R[r, i, j] = rx + (yface[0, j] - yface[0, j - 1]) * w
            if y_flux:
                for j in range(1, ny - 1):
                    _, Jcy[r, i, j], Jym[r, i, j], Jyp[r, i, j] = node_share(
                        yface[0, j], yface[0, j - 1], yface[1, j], yface[1, j - 1], yface[2, j], yface[2, j - 1], w
                    )


@njit
def eliminate(
    lower: float, mid: float, upper: float, source: float, c_prev: float, d_prev: float
) -> tuple[float, float]:
    """One forward step of the Thomas algorithm on a tridiagonal line (l, m, u) with source s.

    c_k = u_k / (m_k - l_k c_{k-1}),  d_k = (s_k - l_k d_{k-1}) / (m_k - l_k c_{k-1});
    then x_last = d_last and x_k = d_k - c_k x_{k+1}.
    """
    inv = 1.0 / (mid - lower * c_prev)
    return upper * inv, (source - lower * d_prev) * inv


#: y-lines solved together by :func:`af_y_lines`: a tile of 16 lines fills the vector lanes and stays in L1.
AF_TILE = 16


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
    delta = 0.  diag must be > 0 at interior nodes.  work : (nr, nx, ny)
    scratch.

    The x-lines are eliminated together (:func:`eliminate`), j innermost
    (contiguous), with c kept in ``delta`` and d in ``work``; then
    :func:`af_y_lines` back-substitutes them and solves the y-lines.
    """
    nr, nx, ny = rhs.shape
    for r in range(nr):
        for i in range(1, nx - 1):
            first = i == 1  # no lower neighbour on the first row
            for j in range(1, ny - 1):
                lower = 0.0 if first else weight * Jxm[r, i, j]
                c_prev = 0.0 if first else delta[r, i - 1, j]
                d_prev = 0.0 if first else work[r, i - 1, j]
                delta[r, i, j], work[r, i, j] = eliminate(
                    lower, diag[r, i, j] + weight * Jcx[r, i, j], weight * Jxp[r, i, j], rhs[r, i, j], c_prev, d_prev
                )
    af_y_lines(diag, Jcy, Jym, Jyp, weight, delta, work)


@njit
def af_y_lines(
    diag: np.ndarray,
    Jcy: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    weight: float,
    delta: np.ndarray,
    work: np.ndarray,
) -> None:
    """Second half of :func:`af_solve`: x-line back-substitution, then the y-lines.

    On entry ``delta`` and ``work`` hold the forward elimination (c, d) of
    the x-lines (diag + weight Jx) w = rhs at the interior nodes; on return
    ``delta`` solves (diag + weight Jy) delta = diag w, zero on Dirichlet
    nodes.  The back-substitution w_i = d_i - c_i w_{i+1} runs down the
    rows in tiles of AF_TILE rows (the top tile takes the remainder); each
    tile's lines go straight into (j, line) order, where its y-lines are
    eliminated together, the lines innermost, and back-substituted before
    delta is written back.
    """
    nr, nx, ny = diag.shape
    lo = np.empty((ny, AF_TILE))
    up = np.empty((ny, AF_TILE))
    c = np.zeros((ny, AF_TILE))  # row 0 stays zero: no coupling below j = 1
    d = np.zeros((ny, AF_TILE))
    w_above = np.empty(ny)  # x-line solution w on the row above
    for r in range(nr):
        w_above[:] = 0.0  # so that w = d on the top row
        i1 = nx - 1
        nl = (nx - 3) % AF_TILE + 1
        while i1 > 1:
            i0 = i1 - nl
            for k in range(nl - 1, -1, -1):
                i = i0 + k
                for j in range(1, ny - 1):
                    w = work[r, i, j] - delta[r, i, j] * w_above[j]
                    w_above[j] = w
                    lo[j, k] = weight * Jym[r, i, j]
                    up[j, k] = weight * Jyp[r, i, j]
                    c[j, k] = diag[r, i, j] + weight * Jcy[r, i, j]  # m, until c replaces it
                    d[j, k] = diag[r, i, j] * w  # s, until d replaces it
            for j in range(1, ny - 1):
                for k in range(nl):
                    c[j, k], d[j, k] = eliminate(lo[j, k], c[j, k], up[j, k], d[j, k], c[j - 1, k], d[j - 1, k])
            for j in range(ny - 3, 0, -1):
                for k in range(nl):
                    d[j, k] -= c[j, k] * d[j + 1, k]
            for k in range(nl):
                for j in range(1, ny - 1):
                    delta[r, i0 + k, j] = d[j, k]
            i1 = i0
            nl = AF_TILE
        for j in range(ny):
            delta[r, 0, j] = 0.0
            delta[r, nx - 1, j] = 0.0
        for i in range(1, nx - 1):
            delta[r, i, 0] = 0.0
            delta[r, i, ny - 1] = 0.0


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
    Summed row by row: with s_i = sum_j (P - 1) dA and t_i = sum_j y_j (P - 1) dA,
    the integrals are sum_i s_i, sum_i x_i s_i and sum_i t_i.
    """
    nr, nx, ny = P.shape
    q = 0.0
    qx = 0.0
    qy = 0.0
    for r in range(nr):
        for i in range(nx):
            s = 0.0
            t = 0.0
            for j in range(ny):
                dq = (P[r, i, j] - 1.0) * area[i, j]
                s += dq
                t += y[r, j] * dq
            q += s
            qx += x[i] * s
            qy += t
    return q, qx, qy


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
    Hx: np.ndarray,
    Hy: np.ndarray,
    Jcy: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    diag: np.ndarray,
    delta: np.ndarray,
    work: np.ndarray,
) -> int:
    """One implicit-midpoint film step in place on P; returns the Newton iterations.

    The attitude moves linearly from q_old to q_new over the step, so the
    face spacings are those at (q_old + q_new) / 2; the node spacings H, H'
    at q_old, q_new are computed on the fly (as :func:`fill_node_spacing`
    would).  Iteration k solves

        (ct A H' + J(P_lin)/2) delta = -[ct A (P H' - P_n H) + R(P_lin)]

    by approximate factorisation, with P_lin = P_n (the old pressure) on
    the first iterate and (P_n + P) / 2 after it; later iterates stop once
    max |rhs| / (ct A H') < tol.  This is :func:`assemble` followed by
    :func:`af_solve`, fused: each node's residual and x-line Jacobian row go
    straight into the forward elimination of its x-line, so R, Jx and the
    right-hand side are never stored; only the y-line data (diag = ct A H',
    Jy) and the elimination (c, d) are, for :func:`af_y_lines`.  P holds
    P_n until the first update; P_old keeps a copy when later iterates
    need it.
    """
    weight = 0.5
    z_mid, pitch_mid, roll_mid = 0.5 * (q_old[0] + q_new[0]), 0.5 * (q_old[1] + q_new[1]), 0.5 * (q_old[2] + q_new[2])
    fill_node_spacing(z_mid, pitch_mid, roll_mid, xf, y, recess_xf, inv_href, Hx)
    fill_node_spacing(z_mid, pitch_mid, roll_mid, x, yf, recess_yf, inv_href, Hy)
    z0, pitch0, roll0 = q_old[0], q_old[1], q_old[2]
    z1, pitch1, roll1 = q_new[0], q_new[1], q_new[2]
    nr, nx, ny = P.shape
    kn1 = c1 * kn
    kn2 = c2 * kn * kn
    second_order = kn2 != 0.0
    xface = np.empty((4, (nx - 1) * ny))
    flux, dfl, dfr = xface[0].reshape(nx - 1, ny), xface[1].reshape(nx - 1, ny), xface[2].reshape(nx - 1, ny)
    yface = np.zeros((3, ny))  # G, dG/dP_L, dG/dP_R at j+1/2
    residual = np.empty(ny)
    inv_dy = np.empty(ny)
    for j in range(ny - 1):
        inv_dy[j] = 1.0 / dy[j]
    its = 0
    for k in range(max_iter):
        if k == 0:
            P_n = P
            P_lin = P
        else:
            P_n = P_old
            P_mid[:] = P_old
            P_mid += P
            P_mid *= 0.5
            P_lin = P_mid
        worst = 0.0
        for r in range(nr):
            x_face_fluxes(P_lin, Hx, dx, r, lam, kn1, kn2, second_order, xface)
            for i in range(1, nx - 1):
                for j in range(ny - 1):
                    yface[0, j], yface[1, j], yface[2, j] = y_face_flux(
                        P_lin[r, i, j], P_lin[r, i, j + 1], Hy[r, i, j], inv_dy[j], kn1, kn2, second_order
                    )
                w = dxc[i]
                base0 = z0 - x[i] * pitch0
                base1 = z1 - x[i] * pitch1
                first = i == 1  # no lower neighbour on the first row
                for j in range(1, ny - 1):
                    rx, jcx, jxm, jxp = node_share(
                        flux[i, j], flux[i - 1, j], dfl[i, j], dfl[i - 1, j], dfr[i, j], dfr[i - 1, j], dyc[j]
                    )
                    ry, Jcy[r, i, j], Jym[r, i, j], Jyp[r, i, j] = node_share(
                        yface[0, j], yface[0, j - 1], yface[1, j], yface[1, j - 1], yface[2, j], yface[2, j - 1], w
                    )
                    h_old = (base0 - y[r, j] * roll0 + recess[r, i, j]) * inv_href
                    h_new = (base1 - y[r, j] * roll1 + recess[r, i, j]) * inv_href
                    ca = ct * area[i, j]
                    dg = ca * h_new
                    diag[r, i, j] = dg
                    res = ca * (P[r, i, j] * h_new - P_n[r, i, j] * h_old) + (rx + ry)
                    residual[j] = res
                    lower = 0.0 if first else weight * jxm
                    c_prev = 0.0 if first else delta[r, i - 1, j]
                    d_prev = 0.0 if first else work[r, i - 1, j]
                    delta[r, i, j], work[r, i, j] = eliminate(
                        lower, dg + weight * jcx, weight * jxp, -res, c_prev, d_prev
                    )
                if k > 0:
                    for j in range(1, ny - 1):
                        worst = max(worst, abs(residual[j]) / diag[r, i, j])
        if k > 0 and worst < tol:
            break
        af_y_lines(diag, Jcy, Jym, Jyp, weight, delta, work)
        if k == 0 and max_iter > 1:
            P_old[:] = P
        P += delta
        its += 1
    return its
