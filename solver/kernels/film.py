"""Compressible Reynolds equation on one tensor grid with a general slip law and a skewed disk velocity.

Scaled equation (P = p/p0, H = h/h_ref, X = x/L, Y = y/L):

    sigma d(P H)/dt + d/dX[Lx H P - D dP/dX] + d/dY[Ly H P - D dP/dY] = 0,
    D(P, H) = H^3 P phi(P, H),

with (Lx, Ly) = 6 eta (Ux, Uy) L / (p0 h_ref^2), sigma = 12 eta L^2 /
(p0 h_ref^2) [s] and phi the Poiseuille flow factor of the slip law
(:mod:`solver.kernels.slip`: 1 for continuum flow, Fukui-Kaneko, ...).

Node-centred control volumes; both face fluxes are Scharfetter-Gummel
(exponentially fitted) fluxes F = g (P_L - P_R) + a P_L, g = (D/d) B(Pe),
a = L H_f, Pe = a d / D, which hold for either sign of a (the skewed
disk's cross velocity may point either way) because B(-x) = B(x) + x.  D
is taken at the face spacing and the mean face pressure.  The Jacobian is
returned as x- and y-line tridiagonal parts, as in
:mod:`solver.kernels.reynolds`, whose approximate factorisation
(:func:`~solver.kernels.reynolds.af_solve`) advances the film in time.

Arrays carry a leading axis of length 1 (one "rail": the whole face) so
that the line solvers of :mod:`solver.kernels.reynolds` apply unchanged.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..jit import njit
from .reynolds import af_solve, bernoulli, sg_flux
from .slip import flow_factor


class AbsFilmConstants(NamedTuple):
    """What the film kernels read and never write: scaled grid and coefficients (fixed for a run).

    One argument of :func:`assemble` and :func:`film_step`: the field order below is the only place
    their order is written.  Passed like :class:`solver.kernels.reynolds.RailFilmConstants` (the
    plain tuple of the fields, named again inside the kernels).
    """

    dx: np.ndarray  # (nx-1,) scaled node spacings
    dy: np.ndarray  # (ny-1,)
    dxc: np.ndarray  # (nx,) scaled control-volume widths
    dyc: np.ndarray  # (ny,)
    area: np.ndarray  # (nx, ny) scaled control-volume areas
    lamx: float  # bearing numbers (Lx, Ly) of the disk velocity
    lamy: float
    kn: float  # Knudsen number lambda / h_ref
    h_ref: float  # reference spacing [m]
    h_switch: float  # spacing where a composite slip law switches [m]
    code: int  # slip law (:data:`solver.kernels.slip.SLIP_NAMES`)


class AbsFilmScratch(NamedTuple):
    """Arrays the film kernels overwrite, passed like :class:`AbsFilmConstants`; (1, nx, ny) unless stated.

    R and the Jacobian hold the last :func:`assemble` (the steady solve reads them).
    """

    R: np.ndarray  # flux residual
    Jcx: np.ndarray  # x-line Jacobian: centre, lower, upper
    Jxm: np.ndarray
    Jxp: np.ndarray
    Jcy: np.ndarray  # y-line Jacobian: centre, lower, upper
    Jym: np.ndarray
    Jyp: np.ndarray
    xface: np.ndarray  # (3, nx-1, ny) x-face fluxes F, dF/dP_L, dF/dP_R
    yface: np.ndarray  # (3, nx, ny-1) y-face fluxes
    diag: np.ndarray  # ct A H_new
    rhs: np.ndarray  # right-hand side of the step
    delta: np.ndarray  # the step's update of P
    work: np.ndarray  # line-solver scratch


@njit
def bernoulli_signed(x: float) -> tuple[float, float]:
    """B(x) = x / (exp(x) - 1) and B'(x) for either sign: B(x) = B(-x) - x for x < 0."""
    if x >= 0.0:
        return bernoulli(x)
    b, db = bernoulli(-x)
    return b - x, -db - 1.0


@njit
def face_flux(
    pl: float, pr: float, hf: float, inv_d: float, lam: float, kn: float, h_ref: float, h_switch: float, code: int
) -> tuple[float, float, float]:
    """Scharfetter-Gummel flux between nodes L and R and its derivatives dF/dP_L, dF/dP_R."""
    pf = 0.5 * (pl + pr)
    phi, dphi = flow_factor(code, pf, hf, kn, h_ref, h_switch)
    h3 = hf * hf * hf
    d = h3 * pf * phi
    dd = 0.5 * h3 * (phi + pf * dphi)  # dD / dP_node
    a = lam * hf
    pe = a / (d * inv_d)
    b, db = bernoulli_signed(pe)
    return sg_flux(pl, pr, d, dd, a, pe, b, db, inv_d)


@njit
def assemble(P: np.ndarray, Hx: np.ndarray, Hy: np.ndarray, constants: tuple, scratch: tuple) -> None:
    """Flux residual R(P; H) and its Jacobian in x- and y-line parts, at interior nodes.

    P : (1, nx, ny); Hx : (1, nx-1, ny) x-face spacings; Hy : (1, nx, ny-1);
    constants : :class:`AbsFilmConstants`; scratch : :class:`AbsFilmScratch`,
    whose R and Jacobian parts receive the result (and xface, yface the
    fluxes F, dF/dP_L, dF/dP_R).  Dirichlet rows (the edges, P = 1) are not
    written.

        R_ij = (F_i+1/2,j - F_i-1/2,j) dyc_j + (G_i,j+1/2 - G_i,j-1/2) dxc_i
    """
    film = AbsFilmConstants(*constants)
    out = AbsFilmScratch(*scratch)
    xface, yface = out.xface, out.yface
    kn, h_ref, h_switch, code = film.kn, film.h_ref, film.h_switch, film.code
    nx, ny = P.shape[1], P.shape[2]
    for i in range(nx - 1):
        inv = 1.0 / film.dx[i]
        for j in range(ny):
            xface[0, i, j], xface[1, i, j], xface[2, i, j] = face_flux(
                P[0, i, j], P[0, i + 1, j], Hx[0, i, j], inv, film.lamx, kn, h_ref, h_switch, code
            )
    for i in range(nx):
        for j in range(ny - 1):
            yface[0, i, j], yface[1, i, j], yface[2, i, j] = face_flux(
                P[0, i, j], P[0, i, j + 1], Hy[0, i, j], 1.0 / film.dy[j], film.lamy, kn, h_ref, h_switch, code
            )
    for i in range(1, nx - 1):
        w = film.dxc[i]
        for j in range(1, ny - 1):
            v = film.dyc[j]
            out.R[0, i, j] = (xface[0, i, j] - xface[0, i - 1, j]) * v + (yface[0, i, j] - yface[0, i, j - 1]) * w
            out.Jcx[0, i, j] = (xface[1, i, j] - xface[2, i - 1, j]) * v
            out.Jxm[0, i, j] = -xface[1, i - 1, j] * v
            out.Jxp[0, i, j] = xface[2, i, j] * v
            out.Jcy[0, i, j] = (yface[1, i, j] - yface[2, i, j - 1]) * w
            out.Jym[0, i, j] = -yface[1, i, j - 1] * w
            out.Jyp[0, i, j] = yface[2, i, j] * w


@njit
def fill_spacing(
    q: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    pivot_x: float,
    pivot_y: float,
    surface: np.ndarray,
    disk: np.ndarray,
    inv_href: float,
    floor: float,
    H: np.ndarray,
) -> None:
    """H = max(z - (x - xp) pitch - (y - yp) roll + s - z_d, floor) / h_ref on a tensor set of points.

    x : (n1,), y : (n2,) [m]; surface, disk, H : (1, n1, n2) [m, m, 1]; floor [m].
    """
    z, pitch, roll = q[0], q[1], q[2]
    n1, n2 = H.shape[1], H.shape[2]
    for i in range(n1):
        base = z - (x[i] - pivot_x) * pitch
        for j in range(n2):
            h = base - (y[j] - pivot_y) * roll + surface[0, i, j] - disk[0, i, j]
            H[0, i, j] = max(h, floor) * inv_href


@njit
def film_step(
    P: np.ndarray,
    H_old: np.ndarray,
    H_new: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    ct: float,
    constants: tuple,
    scratch: tuple,
) -> None:
    """One linearly implicit midpoint step in place on P (the film at the old time on entry).

    Hx, Hy are the face spacings at mid-step, H_old and H_new the node
    spacings at both ends.  With ct = sigma / dt and A the scaled control
    volume areas, solves by approximate factorisation

        (ct A H_new + J(P_n)/2) delta = -[ct A P_n (H_new - H_old) + R(P_n)]

    and sets P = P_n + delta: second order in time, one linear solve.
    constants : :class:`AbsFilmConstants`; scratch : :class:`AbsFilmScratch`.
    """
    assemble(P, Hx, Hy, constants, scratch)
    film = AbsFilmConstants(*constants)
    buf = AbsFilmScratch(*scratch)
    nx, ny = P.shape[1], P.shape[2]
    for i in range(1, nx - 1):
        for j in range(1, ny - 1):
            ca = ct * film.area[i, j]
            buf.diag[0, i, j] = ca * H_new[0, i, j]
            buf.rhs[0, i, j] = -(ca * P[0, i, j] * (H_new[0, i, j] - H_old[0, i, j]) + buf.R[0, i, j])
    af_solve(buf.diag, buf.Jcx, buf.Jxm, buf.Jxp, buf.Jcy, buf.Jym, buf.Jyp, buf.rhs, 0.5, buf.delta, buf.work)
    for i in range(1, nx - 1):
        for j in range(1, ny - 1):
            P[0, i, j] += buf.delta[0, i, j]


@njit
def film_forces(
    P: np.ndarray, area: np.ndarray, x: np.ndarray, y: np.ndarray, pivot_x: float, pivot_y: float
) -> tuple[float, float, float]:
    """Integrals of (P - 1) dA, -(x - xp)(P - 1) dA and -(y - yp)(P - 1) dA: generalized forces on (z, pitch, roll).

    P : (1, nx, ny) scaled; area (nx, ny) [m2]; x, y [m]: returns [m2, m3, m3] (times p0 for N, N m).
    """
    nx, ny = P.shape[1], P.shape[2]
    f = 0.0
    mp = 0.0
    mr = 0.0
    for i in range(nx):
        s = 0.0
        t = 0.0
        for j in range(ny):
            dq = (P[0, i, j] - 1.0) * area[i, j]
            s += dq
            t += (y[j] - pivot_y) * dq
        f += s
        mp -= (x[i] - pivot_x) * s
        mr -= t
    return f, mp, mr
