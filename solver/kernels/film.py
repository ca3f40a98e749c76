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
from .elementary import exp_minus
from .reynolds import af_solve, bernoulli, bernoulli_series
from .slip import FUKUI_KANEKO, fk_factor_vectorizable, flow_factor


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
    pl: float, pr: float, hl: float, hr: float, hf: float, inv_d: float, lam: float, kn: float, h_ref: float,
    h_switch: float, code: int,
) -> tuple[float, float, float]:  # fmt: skip
    """Flux between nodes L and R of one region and its derivatives dF/dP_L, dF/dP_R.

    The flux F = L H P - D dP/dX is fitted exponentially in the mass
    variable m = P H (node spacings hl, hr; hf at the face):

        F = A m - K dm/dX,   K = D / hf,   A = L + D H' / hf^2,   H' = (hr - hl) inv_d,
        F = (K inv_d) B(Pe) (m_L - m_R) + A m_L,   Pe = A / (K inv_d)

    (Scharfetter-Gummel in m; B(-x) = B(x) + x covers either sign of A).
    Where Couette flow dominates (Pe >> 1, the pad under a thin film) it
    tends to F = L m_L, so that P H is conserved node to node as it is
    along the exact solution; the same fit in P (F -> L hf P_L) shifts
    P = C / H by half a cell and is first order.  With a uniform spacing it
    is the fit in P.  D is taken at the face spacing and mean pressure.
    """
    pf = 0.5 * (pl + pr)
    phi, dphi = flow_factor(code, pf, hf, kn, h_ref, h_switch)
    h3 = hf * hf * hf
    d = h3 * pf * phi
    dd = 0.5 * h3 * (phi + pf * dphi)  # dD / dP_node
    slope = (hr - hl) * inv_d / (hf * hf)
    k = d / hf
    a = lam + d * slope
    pe = a / (k * inv_d)
    b, db = bernoulli_signed(pe)
    g = k * inv_d * b
    ml, mr = pl * hl, pr * hr
    # d/dD of K, A, Pe, g: K' = 1/hf, A' = slope, Pe' = (A' K - A K') / (K^2 inv_d)
    dpe = (slope * k - a / hf) / (k * k * inv_d)
    dg = inv_d * (b / hf + k * db * dpe)
    f_d = dg * (ml - mr) + slope * ml  # dF/dD
    return g * (ml - mr) + a * ml, (g + a) * hl + f_d * dd, -g * hr + f_d * dd


@njit(inline=True)
def bernoulli_vectorizable(x: float) -> tuple[float, float]:
    """:func:`bernoulli_signed` without branches or libm calls (both forms computed, one selected).

    |x| < 1: the Taylor series; above, B = u e^-u / (1 - e^-u) with e^-u from
    :func:`solver.kernels.elementary.exp_minus`; B = 0 beyond u = 700, as there.
    """
    u = abs(x)
    b_series, db_series = bernoulli_series(u)
    em = exp_minus(u)
    one_minus = 1.0 - em
    inv = 1.0 / max(one_minus, 1e-300)  # used from u = 1 on; the floor keeps u = 0 finite (and plain Python happy)
    small = u < 1.0
    vanishing = u > 700.0
    b = b_series if small else (0.0 if vanishing else u * em * inv)
    db = db_series if small else (0.0 if vanishing else em * (one_minus - u) * inv * inv)
    negative = x < 0.0
    return (b + u if negative else b), (-db - 1.0 if negative else db)


@njit(inline=True)
def fk_link(
    pf: float, h: float, hl: float, hr: float, inv: float, lam: float, kn: float
) -> tuple[float, float, float, float, float, float, float]:  # fmt: skip
    """The Scharfetter-Gummel coefficients of :func:`face_flux` for the Fukui-Kaneko law above its switch,
    written to vectorize: g, dg/dD, A, H' / h^2, dD/dP_node, Pe and B(Pe).

    :func:`~solver.kernels.slip.fk_factor_vectorizable` and :func:`bernoulli_vectorizable`, and two divisions
    where :func:`face_flux` has five: with r = 1 / (K inv), Pe = A r and dPe/dD = (H' / h^2 - Pe inv / h) r.
    """
    phi, dphi = fk_factor_vectorizable(pf, h, kn)
    inv_h = 1.0 / h
    h2 = h * h
    k = h2 * pf * phi  # D / h
    dd = 0.5 * h2 * h * (phi + pf * dphi)
    slope = (hr - hl) * inv * inv_h * inv_h
    k_inv = k * inv
    r = 1.0 / k_inv
    a = lam + k * h * slope
    pe = a * r
    b, db = bernoulli_vectorizable(pe)
    dg = inv * (b * inv_h + k * db * (slope - pe * inv * inv_h) * r)
    return k_inv * b, dg, a, slope, dd, pe, b


@njit(inline=True)
def face_flux_fk(
    pl: float, pr: float, hl: float, hr: float, hf: float, inv_d: float, lam: float, kn: float
) -> tuple[float, float, float]:  # fmt: skip
    """:func:`face_flux` of the Fukui-Kaneko law on a face at least ``h_switch`` thick, written to vectorize
    (:func:`fk_link`); within a few ulp of it."""
    g, dg, a, slope, dd, _, _ = fk_link(0.5 * (pl + pr), hf, hl, hr, inv_d, lam, kn)
    ml, mr = pl * hl, pr * hr
    f_d = dg * (ml - mr) + slope * ml
    return g * (ml - mr) + a * ml, (g + a) * hl + f_d * dd, -g * hr + f_d * dd


@njit
def fk_face_fluxes(
    P: np.ndarray, Hx: np.ndarray, Hy: np.ndarray, Hxe: np.ndarray, Hye: np.ndarray, dx: np.ndarray,
    dy: np.ndarray, lamx: float, lamy: float, kn: float, h_ref: float, h_switch: float, xface: np.ndarray,
    yface: np.ndarray,
) -> None:  # fmt: skip
    """The plain faces' fluxes (F, dF/dP_L, dF/dP_R) of the Fukui-Kaneko law into xface and yface.

    What the face loops of :func:`assemble` compute with :func:`face_flux`, in loops that vectorize
    (:func:`face_flux_fk`); the faces thinner than ``h_switch``, where the law is the bounded second-order
    one, are taken again by :func:`face_flux` in a scalar pass (in contact only).
    """
    nx, ny = P.shape[1], P.shape[2]
    for i in range(nx - 1):
        inv = 1.0 / dx[i]
        for j in range(ny):
            xface[0, i, j], xface[1, i, j], xface[2, i, j] = face_flux_fk(
                P[0, i, j], P[0, i + 1, j], Hxe[0, i, j], Hxe[1, i, j], Hx[0, i, j], inv, lamx, kn
            )
    for i in range(nx):
        for j in range(ny - 1):
            yface[0, i, j], yface[1, i, j], yface[2, i, j] = face_flux_fk(
                P[0, i, j], P[0, i, j + 1], Hye[0, i, j], Hye[1, i, j], Hy[0, i, j], 1.0 / dy[j], lamy, kn
            )
    if min(Hx.min(), Hy.min()) * h_ref >= h_switch:
        return  # no face under the switch (a vectorized minimum: the scans below are scalar)
    for i in range(nx - 1):
        for j in range(ny):
            if Hx[0, i, j] * h_ref < h_switch:
                xface[0, i, j], xface[1, i, j], xface[2, i, j] = face_flux(
                    P[0, i, j], P[0, i + 1, j], Hxe[0, i, j], Hxe[1, i, j], Hx[0, i, j], 1.0 / dx[i], lamx, kn,
                    h_ref, h_switch, FUKUI_KANEKO,
                )  # fmt: skip
    for i in range(nx):
        for j in range(ny - 1):
            if Hy[0, i, j] * h_ref < h_switch:
                yface[0, i, j], yface[1, i, j], yface[2, i, j] = face_flux(
                    P[0, i, j], P[0, i, j + 1], Hye[0, i, j], Hye[1, i, j], Hy[0, i, j], 1.0 / dy[j], lamy, kn,
                    h_ref, h_switch, FUKUI_KANEKO,
                )  # fmt: skip


class AbsFilmCuts(NamedTuple):
    """The cut links of the face (:mod:`solver.abs.cuts`), passed like :class:`AbsFilmConstants`.

    Per axis (x: links i -> i+1, y: links j -> j+1): face (n, 2) the link's lower node (i, j);
    piece_ptr (n + 1,) into the pieces, weight (m,) their shares of the strip; seg_ptr (m + 1,) into
    the segments, theta (k,) their shares of the link, H (3, k) their scaled spacings at mid-point and
    ends (set per step); then owner (k,) each segment's link (index into face) and coef (6, k), the
    segments' coefficients (:func:`segment_coefficients`, scratch); xcell, ycell (k,) each segment's link as a
    flat index into the link arrays (:func:`segment_cells`).
    """

    xface: np.ndarray
    xpiece_ptr: np.ndarray
    xweight: np.ndarray
    xseg_ptr: np.ndarray
    xtheta: np.ndarray
    xH: np.ndarray
    yface: np.ndarray
    ypiece_ptr: np.ndarray
    yweight: np.ndarray
    yseg_ptr: np.ndarray
    ytheta: np.ndarray
    yH: np.ndarray
    xowner: np.ndarray
    xcoef: np.ndarray
    yowner: np.ndarray
    ycoef: np.ndarray
    xcell: np.ndarray
    ycell: np.ndarray


@njit
def segment(
    pf: float, h: float, hl: float, hr: float, inv: float, lam: float, kn: float, h_ref: float, h_switch: float,
    code: int,
) -> tuple[float, float, float, float, float]:  # fmt: skip
    """One segment's flux F = c P_left - g P_right (fitted in m = P H, :func:`face_flux`): g, dg, c, dc, Pe.

    h: the spacing at its mid-point, hl and hr at its ends (on its own surface); inv = 1/length;
    dg, dc: derivatives with respect to a node pressure (through D at the link's mean pressure pf).
    """
    if code == FUKUI_KANEKO and h * h_ref >= h_switch:
        phi, dphi = fk_factor_vectorizable(pf, h, kn)
    else:
        phi, dphi = flow_factor(code, pf, h, kn, h_ref, h_switch)
    h3 = h * h * h
    d = h3 * pf * phi
    dd = 0.5 * h3 * (phi + pf * dphi)
    slope = (hr - hl) * inv / (h * h)
    k = d / h
    a = lam + d * slope
    pe = a / (k * inv)
    b, db = bernoulli_vectorizable(pe)
    g = k * inv * b
    dg = inv * (b / h + k * db * (slope * k - a / h) / (k * k * inv)) * dd
    return g * hr, dg * hr, (g + a) * hl, (dg + slope * dd) * hl, pe


@njit(inline=True)
def segment_fk(
    pf: float, h: float, hl: float, hr: float, inv: float, lam: float, kn: float
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """:func:`segment` of the Fukui-Kaneko law in a film at least ``h_switch`` thick, written to vectorize
    (:func:`fk_link`), and the segment's :func:`profile_weight`: g, dg, c, dc, Pe, w(Pe)."""
    g, dg, a, slope, dd, pe, b = fk_link(pf, h, hl, hr, inv, lam, kn)
    tiny = abs(pe) < PROFILE_SERIES
    w = 0.5 - pe / 12.0 if tiny else (1.0 - b) / (1.0 if tiny else pe)
    return g * hr, dg * dd * hr, (g + a) * hl, (dg + slope) * dd * hl, pe, w


@njit
def segment_coefficients(
    P: np.ndarray, face: np.ndarray, owner: np.ndarray, theta: np.ndarray, H: np.ndarray, spacing: np.ndarray,
    axis: int, lam: float, kn: float, h_ref: float, h_switch: float, code: int, coef: np.ndarray,
) -> None:  # fmt: skip
    """Every cut segment's coefficients at the pressure P and the spacings H (3, k), into coef (6, k):

        g, dg, c, dc, Pe (:func:`segment`, at its link's mean pressure) and w(Pe) (:func:`profile_weight`).

    One pass over the segments, which vectorizes for the Fukui-Kaneko law (:func:`segment_fk`); segments under
    its switch, and the other laws, by :func:`segment`.  The series of :func:`series_flux` and
    :func:`series_mean` then only combine them.
    """
    n_seg = theta.size
    fk = code == FUKUI_KANEKO
    if fk:
        # the links' mean pressures and inverse lengths gathered first (coef[4], coef[5] hold them), so that
        # the loop over the segments reads contiguous arrays and vectorizes
        for k in range(n_seg):
            n = owner[k]
            i, j = face[n, 0], face[n, 1]
            pr = P[0, i + 1, j] if axis == 0 else P[0, i, j + 1]
            coef[4, k] = 0.5 * (P[0, i, j] + pr)
            coef[5, k] = 1.0 / ((spacing[i] if axis == 0 else spacing[j]) * theta[k])
        for k in range(n_seg):
            coef[0, k], coef[1, k], coef[2, k], coef[3, k], coef[4, k], coef[5, k] = segment_fk(
                coef[4, k], H[0, k], H[1, k], H[2, k], coef[5, k], lam, kn
            )
    for k in range(n_seg):
        if fk and H[0, k] * h_ref >= h_switch:
            continue
        n = owner[k]
        i, j = face[n, 0], face[n, 1]
        pr = P[0, i + 1, j] if axis == 0 else P[0, i, j + 1]
        inv = 1.0 / (spacing[i] if axis == 0 else spacing[j]) / theta[k]
        g, dg, c, dc, pe = segment(0.5 * (P[0, i, j] + pr), H[0, k], H[1, k], H[2, k], inv, lam, kn, h_ref,
                                   h_switch, code)  # fmt: skip
        coef[0, k], coef[1, k], coef[2, k], coef[3, k], coef[4, k], coef[5, k] = g, dg, c, dc, pe, profile_weight(pe)


@njit
def series_flux(pl: float, pr: float, coef: np.ndarray, s0: int, s1: int, lam: float) -> tuple[float, float, float]:
    """Flux through segments s0 .. s1-1 of a link in series (L to R), and dF/dP_L, dF/dP_R.

    Segment k (length theta_k d, spacings H[0, k] at its mid-point, H[1, k]
    and H[2, k] at its ends) carries F = c_k P_k-1 - g_k P_k
    (:func:`segment`; its g, dg, c, dc in ``coef`` from :func:`segment_coefficients`), the same F through
    every segment (mass conservation at the steps, where P is continuous).  Eliminating the inner pressures
    gives F in terms of P_L and P_R; the elimination runs from the
    downstream end when the flow goes L -> R (ratios g / c <= 1 there), the
    other way otherwise, so it never overflows.  D is taken at the link's
    mean pressure; its derivative enters by forward differentiation.
    """
    u, v, du, dv = 1.0, 0.0, 0.0, 0.0
    for m in range(s1 - s0):
        k = s1 - 1 - m if lam >= 0.0 else s0 + m
        g, dg, c, dc = coef[0, k], coef[1, k], coef[2, k], coef[3, k]
        if lam >= 0.0:  # P_k-1 = u' P_R + v' F from P_k = u P_R + v F
            u, du = g * u / c, (dg * u + g * du) / c - g * u * dc / (c * c)
            v, dv = (1.0 + g * v) / c, (dg * v + g * dv) / c - (1.0 + g * v) * dc / (c * c)
        else:  # P_k = u' P_L - v' F from P_k-1 = u P_L - v F (u = 1, v = 0 at P_L)
            u, du = c * u / g, (dc * u + c * du) / g - c * u * dg / (g * g)
            v, dv = (c * v + 1.0) / g, (dc * v + c * dv) / g - (c * v + 1.0) * dg / (g * g)
    if lam >= 0.0:  # P_L = u P_R + v F
        F = (pl - u * pr) / v
        fd = (-du * pr - F * dv) / v
        return F, 1.0 / v + fd, -u / v + fd
    F = (u * pl - pr) / v  # P_R = u P_L - v F
    fd = (du * pl - F * dv) / v
    return F, u / v + fd, -1.0 / v + fd


#: Below this |Pe| the profile weight is its series 1/2 - Pe/12 (the closed form cancels).
PROFILE_SERIES = 1e-4


@njit
def profile_weight(pe: float) -> float:
    """w(Pe) = (1 - B(Pe)) / Pe: the mean of the exponential profile between P0 and P1 is P0 + (P1 - P0) w.

    The segment's exact solution with constant coefficients (what the
    Scharfetter-Gummel flux assumes): w = 1/2 without convection, -> 0
    when the flow sweeps the pressure change to the downstream end.
    """
    if abs(pe) < PROFILE_SERIES:
        return 0.5 - pe / 12.0
    b, _ = bernoulli_signed(pe)
    return (1.0 - b) / pe


@njit
def series_mean(
    pl: float, pr: float, coef: np.ndarray, H: np.ndarray, theta: np.ndarray, pos: np.ndarray, s0: int, s1: int,
    lam: float, arm0: float,
) -> tuple[float, float]:  # fmt: skip
    """Mean of P - 1 over a link's segments in series, and of (P - 1)(pos - arm0): each segment's exact profile.

    The flux comes from the elimination of :func:`series_flux` (the same recurrences, without the
    derivatives) on the segments' g and c in ``coef`` (:func:`segment_coefficients`); the inner pressures are
    then marched again with the flux known, each segment's profile averaged with its weight w(Pe) (coef[5]).
    pos (k,) are the segments' mid-points along the link [m], the moment arm of each segment.
    """
    u, v = 1.0, 0.0
    for m in range(s1 - s0):
        k = s1 - 1 - m if lam >= 0.0 else s0 + m
        g, c = coef[0, k], coef[2, k]
        if lam >= 0.0:
            u, v = g * u / c, (1.0 + g * v) / c
        else:
            u, v = c * u / g, (c * v + 1.0) / g
    F = (pl - u * pr) / v if lam >= 0.0 else (u * pl - pr) / v
    u, v = 1.0, 0.0
    mean = moment = 0.0
    near = pr if lam >= 0.0 else pl  # pressure at the end the march starts from
    for m in range(s1 - s0):
        k = s1 - 1 - m if lam >= 0.0 else s0 + m
        g, c = coef[0, k], coef[2, k]
        if lam >= 0.0:
            u, v = g * u / c, (1.0 + g * v) / c
            far = u * pr + v * F  # the segment's upstream (left) end
            p0, p1 = far, near
        else:
            u, v = c * u / g, (c * v + 1.0) / g
            far = u * pl - v * F  # the segment's downstream (right) end
            p0, p1 = near, far
        m0, m1 = p0 * H[1, k], p1 * H[2, k]  # the profile is exponential in m = P H
        avg = (m0 + (m1 - m0) * coef[5, k]) / H[0, k] - 1.0
        mean += theta[k] * avg
        moment += theta[k] * avg * (pos[k] - arm0)
        near = far
    return mean, moment


@njit
def link_geometry(
    P: np.ndarray, i: int, j: int, axis: int, spacing: np.ndarray, width: np.ndarray, cross: np.ndarray,
    cross0: float,
) -> tuple[float, float, float, int, float, float]:  # fmt: skip
    """The link from node (i, j) along ``axis``: its end pressures, 1/length (scaled), its index along the axis,
    its strip width across and the strip's moment arm across (cross - cross0)."""
    if axis == 0:
        return P[0, i, j], P[0, i + 1, j], 1.0 / spacing[i], i, width[j], cross[j] - cross0
    return P[0, i, j], P[0, i, j + 1], 1.0 / spacing[j], j, width[i], cross[i] - cross0


@njit
def cut_corrections(
    P: np.ndarray, face: np.ndarray, piece_ptr: np.ndarray, weight: np.ndarray, seg_ptr: np.ndarray,
    theta: np.ndarray, H: np.ndarray, pos: np.ndarray, nodes: np.ndarray, cross: np.ndarray, width: np.ndarray,
    spacing: np.ndarray, axis: int, lam: float, kn: float, h_ref: float, h_switch: float, code: int, arm0: float,
    cross0: float, owner: np.ndarray, coef: np.ndarray,
) -> tuple[float, float, float]:  # fmt: skip
    """What the cut links change in the integrals of P - 1, (P - 1)(s - arm0) and (P - 1)(c - cross0) [m2, m3, m3].

    The node quadrature integrates P - 1 along each link by the trapezoid
    rule; a cut link holds a step, and often the pressure's boundary layer
    against it, inside it.  Its integral is the segments' exact profiles
    (:func:`series_mean`), pieces in parallel, over the link length times
    the strip ``width`` (the control volumes' extent across the link).
    s is the coordinate along the link (x for axis 0, y for axis 1), c the
    one across it, whose node coordinates are ``cross``.  owner, coef: the segments' links and their
    coefficients' scratch (:func:`segment_coefficients`).
    """
    segment_coefficients(P, face, owner, theta, H, spacing, axis, lam, kn, h_ref, h_switch, code, coef)
    load = moment = moment_cross = 0.0
    for n in range(face.shape[0]):
        i, j = face[n, 0], face[n, 1]
        pl, pr, inv_d, k, strip, arm = link_geometry(P, i, j, axis, spacing, width, cross, cross0)
        length = nodes[k + 1] - nodes[k]
        mean = mom = 0.0
        for p in range(piece_ptr[n], piece_ptr[n + 1]):
            a, b = series_mean(pl, pr, coef, H, theta, pos, seg_ptr[p], seg_ptr[p + 1], lam, arm0)
            mean += weight[p] * a
            mom += weight[p] * b
        trap = 0.5 * ((pl - 1.0) + (pr - 1.0))
        trap_mom = 0.5 * ((pl - 1.0) * (nodes[k] - arm0) + (pr - 1.0) * (nodes[k + 1] - arm0))
        load += strip * length * (mean - trap)
        moment += strip * length * (mom - trap_mom)
        moment_cross += strip * length * (mean - trap) * arm
    return load, moment, moment_cross


@njit
def edge_corrections(
    P: np.ndarray, Hm: np.ndarray, He: np.ndarray, face: np.ndarray, axis: int, nodes: np.ndarray,
    cross: np.ndarray, width: np.ndarray, spacing: np.ndarray, lam: float, kn: float, h_ref: float,
    h_switch: float, code: int, arm0: float, cross0: float,
) -> tuple[float, float, float]:  # fmt: skip
    """:func:`cut_corrections` of plain links (one segment each, spacings Hm (1, n1, n2) at the link mid-points
    and He (2, n1, n2) at its nodes): the links ``face`` (n, 2) to the edge of the face, whose exponential
    profile holds a thin film's boundary layer against P = 1.

    With one segment the march of :func:`series_mean` ends where it starts: the profile runs from P_L to P_R,
    exponential in m = P H with the segment's Pe, and its mean is (m_L + (m_R - m_L) w(Pe)) / H_mid - 1.  The
    weights of the Fukui-Kaneko law come from a first pass that vectorizes (:func:`segment_fk`).
    """
    n_links = face.shape[0]
    fk = code == FUKUI_KANEKO
    weights = np.empty(n_links)
    if fk:
        link = np.empty((5, n_links))  # gathered first, so that the loop over the links vectorizes
        for n in range(n_links):
            i, j = face[n, 0], face[n, 1]
            pr = P[0, i + 1, j] if axis == 0 else P[0, i, j + 1]
            link[0, n], link[1, n], link[2, n] = 0.5 * (P[0, i, j] + pr), Hm[0, i, j], He[0, i, j]
            link[3, n], link[4, n] = He[1, i, j], 1.0 / (spacing[i] if axis == 0 else spacing[j])
        for n in range(n_links):
            weights[n] = segment_fk(link[0, n], link[1, n], link[2, n], link[3, n], link[4, n], lam, kn)[5]
    load = moment = moment_cross = 0.0
    for n in range(n_links):
        i, j = face[n, 0], face[n, 1]
        pl, pr, inv_d, k, strip, arm = link_geometry(P, i, j, axis, spacing, width, cross, cross0)
        h, hl, hr = Hm[0, i, j], He[0, i, j], He[1, i, j]
        if fk and h * h_ref >= h_switch:
            w = weights[n]
        else:
            w = profile_weight(segment(0.5 * (pl + pr), h, hl, hr, inv_d, lam, kn, h_ref, h_switch, code)[4])
        m0, m1 = pl * hl, pr * hr
        mean = (m0 + (m1 - m0) * w) / h - 1.0
        length = nodes[k + 1] - nodes[k]
        mid = 0.5 * (nodes[k] + nodes[k + 1]) - arm0
        trap = 0.5 * ((pl - 1.0) + (pr - 1.0))
        trap_mom = 0.5 * ((pl - 1.0) * (nodes[k] - arm0) + (pr - 1.0) * (nodes[k + 1] - arm0))
        load += strip * length * (mean - trap)
        moment += strip * length * (mean * mid - trap_mom)
        moment_cross += strip * length * (mean - trap) * arm
    return load, moment, moment_cross


@njit
def link_corrections(P: np.ndarray, x_links: tuple, y_links: tuple) -> tuple[float, float, float]:
    """The cut links' and edge links' corrections to the integrals of P - 1, -(x - xp)(P - 1) and -(y - yp)(P - 1)
    [m2, m3, m3]: :func:`cut_corrections` then :func:`edge_corrections` along x, then along y, summed in that order.

    One call per force evaluation in place of four.  Per axis the links are the tuple (face, piece_ptr, weight,
    seg_ptr, theta, H, pos, nodes, cross, width, spacing, lam, kn, h_ref, h_switch, code, arm0, cross0, owner,
    coef, edges, Hm, He): the cut links' arguments of :func:`cut_corrections` in its order, then the edge links
    and the spacings :func:`edge_corrections` reads.
    """
    f = mp = mr = 0.0
    for axis in range(2):
        links = x_links if axis == 0 else y_links
        (face, ptr, weight, seg_ptr, theta, H, pos, nodes, cross, width, spacing, lam, kn, h_ref, h_switch, code,
         arm0, cross0, owner, coef, edges, Hm, He) = links  # fmt: skip
        load, m_along, m_across = cut_corrections(
            P, face, ptr, weight, seg_ptr, theta, H, pos, nodes, cross, width, spacing, axis, lam, kn, h_ref, h_switch,
            code, arm0, cross0, owner, coef,
        )  # fmt: skip
        e_load, e_along, e_across = edge_corrections(
            P, Hm, He, edges, axis, nodes, cross, width, spacing, lam, kn, h_ref, h_switch, code, arm0, cross0
        )  # fmt: skip
        for load_k, along_k, across_k in ((load, m_along, m_across), (e_load, e_along, e_across)):
            m_pitch, m_roll = (along_k, across_k) if axis == 0 else (across_k, along_k)
            f, mp, mr = f + load_k, mp - m_pitch, mr - m_roll
    return f, mp, mr


@njit
def cut_fluxes(
    P: np.ndarray, face_out: np.ndarray, face: np.ndarray, piece_ptr: np.ndarray, weight: np.ndarray,
    seg_ptr: np.ndarray, theta: np.ndarray, H: np.ndarray, owner: np.ndarray, coef: np.ndarray, spacing: np.ndarray,
    axis: int, lam: float, kn: float, h_ref: float, h_switch: float, code: int,
) -> None:  # fmt: skip
    """Overwrite the fluxes (F, dF/dP_L, dF/dP_R) of the cut links: pieces in parallel, segments in series."""
    segment_coefficients(P, face, owner, theta, H, spacing, axis, lam, kn, h_ref, h_switch, code, coef)
    for n in range(face.shape[0]):
        i, j = face[n, 0], face[n, 1]
        pl = P[0, i, j]
        pr = P[0, i + 1, j] if axis == 0 else P[0, i, j + 1]
        F = dl = dr = 0.0
        for p in range(piece_ptr[n], piece_ptr[n + 1]):
            f, fl, fr = series_flux(pl, pr, coef, seg_ptr[p], seg_ptr[p + 1], lam)
            F += weight[p] * f
            dl += weight[p] * fl
            dr += weight[p] * fr
        face_out[0, i, j], face_out[1, i, j], face_out[2, i, j] = F, dl, dr


@njit
def assemble(
    P: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    Hxe: np.ndarray,
    Hye: np.ndarray,
    constants: tuple,
    scratch: tuple,
    cuts: tuple,
) -> None:
    """Flux residual R(P; H) and its Jacobian in x- and y-line parts, at interior nodes.

    P : (1, nx, ny); Hx : (1, nx-1, ny) x-face spacings; Hy : (1, nx, ny-1); Hxe (2, nx-1, ny) and
    Hye (2, nx, ny-1) the spacings at each link's two nodes, on the link's own surface;
    constants : :class:`AbsFilmConstants`; scratch : :class:`AbsFilmScratch`,
    whose R and Jacobian parts receive the result (and xface, yface the
    fluxes F, dF/dP_L, dF/dP_R); cuts : :class:`AbsFilmCuts`, whose links
    replace the plain face fluxes (:func:`cut_fluxes`).  Dirichlet rows (the
    edges, P = 1) are not written.

        R_ij = (F_i+1/2,j - F_i-1/2,j) dyc_j + (G_i,j+1/2 - G_i,j-1/2) dxc_i
    """
    film = AbsFilmConstants(*constants)
    out = AbsFilmScratch(*scratch)
    xface, yface = out.xface, out.yface
    kn, h_ref, h_switch, code = film.kn, film.h_ref, film.h_switch, film.code
    nx, ny = P.shape[1], P.shape[2]
    if code == FUKUI_KANEKO:
        fk_face_fluxes(P, Hx, Hy, Hxe, Hye, film.dx, film.dy, film.lamx, film.lamy, kn, h_ref, h_switch, xface, yface)
    else:
        for i in range(nx - 1):
            inv = 1.0 / film.dx[i]
            for j in range(ny):
                xface[0, i, j], xface[1, i, j], xface[2, i, j] = face_flux(
                    P[0, i, j], P[0, i + 1, j], Hxe[0, i, j], Hxe[1, i, j], Hx[0, i, j], inv, film.lamx, kn, h_ref,
                    h_switch, code,
                )  # fmt: skip
        for i in range(nx):
            for j in range(ny - 1):
                yface[0, i, j], yface[1, i, j], yface[2, i, j] = face_flux(
                    P[0, i, j], P[0, i, j + 1], Hye[0, i, j], Hye[1, i, j], Hy[0, i, j], 1.0 / film.dy[j], film.lamy,
                    kn, h_ref, h_switch, code,
                )  # fmt: skip
    cut = AbsFilmCuts(*cuts)
    cut_fluxes(P, xface, cut.xface, cut.xpiece_ptr, cut.xweight, cut.xseg_ptr, cut.xtheta, cut.xH, cut.xowner,
               cut.xcoef, film.dx, 0, film.lamx, kn, h_ref, h_switch, code)  # fmt: skip
    cut_fluxes(P, yface, cut.yface, cut.ypiece_ptr, cut.yweight, cut.yseg_ptr, cut.ytheta, cut.yH, cut.yowner,
               cut.ycoef, film.dy, 1, film.lamy, kn, h_ref, h_switch, code)  # fmt: skip
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


@njit(inline=True)
def link_spacings(
    t_m: float, t_0: float, t_1: float, s_m: float, s_0: float, s_1: float, d0: float, d1: float, inv_href: float,
    floor: float,
) -> tuple[float, float, float]:  # fmt: skip
    """One link's scaled spacings at its mid-point and its two nodes: max(t + s - z_d, floor) / h_ref, with t the
    plane's height there (z - (x - xp) pitch - (y - yp) roll), s the link's surface and z_d the disk (the mean of
    the two nodes' at the mid-point)."""
    return (
        max(t_m + s_m - 0.5 * (d1 + d0), floor) * inv_href,
        max(t_0 + s_0 - d0, floor) * inv_href,
        max(t_1 + s_1 - d1, floor) * inv_href,
    )


@njit(inline=True)
def _x_links_of_row(
    i: int, z: float, pitch: float, roll: float, x: np.ndarray, y: np.ndarray, pivot_x: float, pivot_y: float,
    surface_xf: np.ndarray, surface_xe: np.ndarray, disk: np.ndarray, inv_href: float, floor: float, Hx: np.ndarray,
    Hxe: np.ndarray,
) -> None:  # fmt: skip
    """:func:`fill_links` of the x-links i -> i + 1 (a branch-free loop over j: it vectorizes)."""
    base_m = z - (0.5 * (x[i] + x[i + 1]) - pivot_x) * pitch
    base_0 = z - (x[i] - pivot_x) * pitch
    base_1 = z - (x[i + 1] - pivot_x) * pitch
    for j in range(y.size):
        by = (y[j] - pivot_y) * roll
        Hx[0, i, j], Hxe[0, i, j], Hxe[1, i, j] = link_spacings(
            base_m - by, base_0 - by, base_1 - by, surface_xf[0, i, j], surface_xe[0, i, j], surface_xe[1, i, j],
            disk[0, i, j], disk[0, i + 1, j], inv_href, floor,
        )  # fmt: skip


@njit(inline=True)
def _y_link(
    i: int, j: int, base: float, roll: float, y: np.ndarray, pivot_y: float, surface_yf: np.ndarray,
    surface_ye: np.ndarray, disk: np.ndarray, inv_href: float, floor: float, Hy: np.ndarray, Hye: np.ndarray,
) -> None:  # fmt: skip
    """:func:`fill_links` of the y-link (i, j) -> (i, j + 1); ``base`` = z - (x_i - xp) pitch."""
    Hy[0, i, j], Hye[0, i, j], Hye[1, i, j] = link_spacings(
        base - (0.5 * (y[j] + y[j + 1]) - pivot_y) * roll, base - (y[j] - pivot_y) * roll,
        base - (y[j + 1] - pivot_y) * roll, surface_yf[0, i, j], surface_ye[0, i, j], surface_ye[1, i, j],
        disk[0, i, j], disk[0, i, j + 1], inv_href, floor,
    )  # fmt: skip


@njit
def fill_links(
    q: np.ndarray, x: np.ndarray, y: np.ndarray, pivot_x: float, pivot_y: float, surface_xf: np.ndarray,
    surface_yf: np.ndarray, surface_xe: np.ndarray, surface_ye: np.ndarray, disk: np.ndarray, inv_href: float,
    floor: float, Hx: np.ndarray, Hy: np.ndarray, Hxe: np.ndarray, Hye: np.ndarray, edges_only: bool = False,
) -> None:  # fmt: skip
    """The links' scaled spacings at attitude q over the node disk heights ``disk`` (1, nx, ny) [m].

    Hx (1, nx-1, ny) at each x-link's mid-point over the mean of its nodes' disk, Hxe (2, nx-1, ny) at its
    two nodes on the link's own surface (``surface_xe``) over each node's disk; Hy, Hye the same for the
    y-links.  Each value is :func:`fill_spacing`'s, max(z - (x - xp) pitch - (y - yp) roll + s - z_d, floor)
    / h_ref, for all six arrays in one pass (:func:`link_spacings`).

    ``edges_only``: only the links from the edge of the face (x-links i = 0 and nx - 2, y-links j = 0 and
    ny - 2), the same values; the others are left as they were.  What the force's edge links read
    (:func:`edge_corrections`) at the end of a time step, whose film step filled every link at mid-step.
    """
    z, pitch, roll = q[0], q[1], q[2]
    nx, ny = x.size, y.size
    for i in range(nx - 1):  # separate branch-free loops over j: each vectorizes
        if edges_only and 0 < i < nx - 2:
            continue
        _x_links_of_row(i, z, pitch, roll, x, y, pivot_x, pivot_y, surface_xf, surface_xe, disk, inv_href, floor,
                        Hx, Hxe)  # fmt: skip
    for i in range(nx):
        base = z - (x[i] - pivot_x) * pitch
        if edges_only:
            _y_link(i, 0, base, roll, y, pivot_y, surface_yf, surface_ye, disk, inv_href, floor, Hy, Hye)
            _y_link(i, ny - 2, base, roll, y, pivot_y, surface_yf, surface_ye, disk, inv_href, floor, Hy, Hye)
        else:
            for j in range(ny - 1):
                _y_link(i, j, base, roll, y, pivot_y, surface_yf, surface_ye, disk, inv_href, floor, Hy, Hye)


@njit
def fill_cut_points(
    q: np.ndarray, seg_x: np.ndarray, seg_y: np.ndarray, pivot_x: float, pivot_y: float, seg_surface: np.ndarray,
    disk_f: np.ndarray, cell: np.ndarray, inv_href: float, floor: float, H: np.ndarray,
) -> None:  # fmt: skip
    """H = max(z - (x - xp) pitch - (y - yp) roll + surface - z_d, floor) / h_ref at the cut segments' points.

    seg_x, seg_y, seg_surface and H (3, k): each segment's mid-point and both ends; the disk height z_d of
    segment k is that of its link, ``disk_f`` (1, n1, n2) [m] (C-contiguous) at the flat index ``cell[k]``
    (:func:`segment_cells`: one gather instead of two).
    """
    z, pitch, roll = q[0], q[1], q[2]
    flat = disk_f.reshape(disk_f.size)
    for r in range(3):
        for k in range(seg_x.shape[1]):
            h = (z - (seg_x[r, k] - pivot_x) * pitch - (seg_y[r, k] - pivot_y) * roll + seg_surface[r, k]
                 - flat[cell[k]])  # fmt: skip
            H[r, k] = max(h, floor) * inv_href


def segment_cells(face: np.ndarray, owner: np.ndarray, n2: int) -> np.ndarray:
    """Each cut segment's link as a flat index into a (1, n1, n2) link array: face[owner] (i, j) -> i n2 + j."""
    return np.ascontiguousarray(face[owner, 0] * n2 + face[owner, 1], dtype=np.int64)


@njit
def set_disk(nodes: np.ndarray, disk: np.ndarray, disk_xf: np.ndarray, disk_yf: np.ndarray) -> None:
    """Resolved disk heights at the nodes (nx, ny) into ``disk`` (1, nx, ny) and their link means into
    ``disk_xf`` (1, nx-1, ny) and ``disk_yf`` (1, nx, ny-1) [m]: one pass instead of three array expressions."""
    nx, ny = nodes.shape
    for i in range(nx):
        for j in range(ny):
            disk[0, i, j] = nodes[i, j]
    for i in range(nx - 1):
        for j in range(ny):
            disk_xf[0, i, j] = 0.5 * (nodes[i + 1, j] + nodes[i, j])
    for i in range(nx):
        for j in range(ny - 1):
            disk_yf[0, i, j] = 0.5 * (nodes[i, j + 1] + nodes[i, j])


@njit
def set_disk_mid(old: np.ndarray, new: np.ndarray, mid: np.ndarray, disk: np.ndarray, disk_xf: np.ndarray,
                 disk_yf: np.ndarray) -> None:  # fmt: skip
    """:func:`set_disk` of the mid-step disk (old + new) / 2, which is also written to ``mid`` (nx, ny)."""
    nx, ny = old.shape
    for i in range(nx):
        for j in range(ny):
            mid[i, j] = 0.5 * (old[i, j] + new[i, j])
    set_disk(mid, disk, disk_xf, disk_yf)


@njit
def secant_update(S: np.ndarray, P_b: np.ndarray, P_a: np.ndarray, dq: np.ndarray, w: np.ndarray) -> None:
    """S[k] += (P_b - P_a - sum_m dq_m S[m]) w_k in place: Broyden's rank-one update of the film step's derivatives
    S (3, 1, nx, ny) from two passes P_a, P_b (1, nx, ny) whose paths differ by dq, w = W dq / (dq^T W dq)."""
    nx, ny = P_b.shape[1], P_b.shape[2]
    for i in range(nx):
        for j in range(ny):
            r = P_b[0, i, j] - P_a[0, i, j] - (dq[0] * S[0, 0, i, j] + dq[1] * S[1, 0, i, j] + dq[2] * S[2, 0, i, j])
            S[0, 0, i, j] += r * w[0]
            S[1, 0, i, j] += r * w[1]
            S[2, 0, i, j] += r * w[2]


@njit
def add_linear(P: np.ndarray, S: np.ndarray, dq: np.ndarray) -> bool:
    """P += sum_k dq_k S[k] in place if every result stays positive (True); otherwise P is left as it was (False).

    P : (1, nx, ny); S : (3, 1, nx, ny), the film step's derivatives with respect to the attitude.
    """
    nx, ny = P.shape[1], P.shape[2]
    for i in range(nx):
        for j in range(ny):
            if not P[0, i, j] + dq[0] * S[0, 0, i, j] + dq[1] * S[1, 0, i, j] + dq[2] * S[2, 0, i, j] > 0.0:
                return False
    for i in range(nx):
        for j in range(ny):
            P[0, i, j] += dq[0] * S[0, 0, i, j] + dq[1] * S[1, 0, i, j] + dq[2] * S[2, 0, i, j]
    return True


@njit
def film_step(
    P: np.ndarray,
    H_old: np.ndarray,
    H_new: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    Hxe: np.ndarray,
    Hye: np.ndarray,
    ct: float,
    constants: tuple,
    scratch: tuple,
    cuts: tuple,
) -> None:
    """One linearly implicit midpoint step in place on P (the film at the old time on entry).

    Hx, Hy are the face spacings at mid-step, H_old and H_new the node
    spacings at both ends.  With ct = sigma / dt and A the scaled control
    volume areas, solves by approximate factorisation

        (ct A H_new + J(P_n)/2) delta = -[ct A P_n (H_new - H_old) + R(P_n)]

    and sets P = P_n + delta: second order in time, one linear solve.
    constants : :class:`AbsFilmConstants`; scratch : :class:`AbsFilmScratch`; cuts : :class:`AbsFilmCuts`.
    """
    assemble(P, Hx, Hy, Hxe, Hye, constants, scratch, cuts)
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
def solve_and_add(P: np.ndarray, scratch: tuple, weight: float) -> None:
    """P += delta, delta from the approximate factorisation of (diag + weight J) delta = rhs (scratch's arrays)."""
    buf = AbsFilmScratch(*scratch)
    af_solve(buf.diag, buf.Jcx, buf.Jxm, buf.Jxp, buf.Jcy, buf.Jym, buf.Jyp, buf.rhs, weight, buf.delta, buf.work)
    for i in range(1, P.shape[1] - 1):
        for j in range(1, P.shape[2] - 1):
            P[0, i, j] += buf.delta[0, i, j]


#: ``scheme`` of :func:`film_advance` (``numerics.film_scheme``, in this order).
SCHEME_MIDPOINT, SCHEME_BDF2, SCHEME_TRAPEZOID = 0, 1, 2


@njit
def film_step_at_ends(
    P: np.ndarray, H_old: np.ndarray, H_new: np.ndarray, Hx: np.ndarray, Hy: np.ndarray, Hxe: np.ndarray,
    Hye: np.ndarray, ct: float, aux: np.ndarray, ratio: float, scheme: int, constants: tuple, scratch: tuple,
    cuts: tuple,
) -> None:  # fmt: skip
    """One BDF2 or trapezoidal step in place on P (the film at the old time on entry; Hx, Hy, Hxe, Hye the links'
    spacings at the end of the step, H_old and H_new the nodes' at both ends), linearized about P_n and solved by
    approximate factorisation in one linear solve.

    SCHEME_BDF2, with m = P H at the nodes, aux = m_n-1 and ratio w = h_n / h_n-1 (variable-step BDF2,
    a0 = (1 + 2w) / (1 + w), a1 = -(1 + w), a2 = w^2 / (1 + w)):

        ct A (a0 m_n+1 + a1 m_n + a2 m_n-1) + R(P_n+1) = 0,
        (ct A H_new + J(P_n) / a0) delta = -[ct A (P_n H_new + (a1 P_n H_old + a2 m_n-1) / a0) + R(P_n) / a0];

    ratio 0 is backward Euler (a0 = 1, a1 = -1, a2 = 0): the first step, and after a change of step size that BDF2
    would not stand (:data:`solver.abs.film.BDF2_MAX_RATIO`).  L-stable, unlike the midpoint step of
    :func:`film_step`.

    SCHEME_TRAPEZOID, with aux = R(P_n) over the links at the start of the step:

        ct A (P_n+1 H_new - P_n H_old) + (R(P_n; start) + R(P_n+1; end)) / 2 = 0,
        (ct A H_new + J(P_n; end) / 2) delta = -[ct A P_n (H_new - H_old) + (R_start + R(P_n; end)) / 2].

    Symmetric in time like :func:`film_step`, but each flux takes the pressure and the spacing at one time.  Both
    are of stage order 2, which the midpoint rule (stage order 1) is not (README, "The film's time scheme").
    constants, scratch, cuts as :func:`film_step`.
    """
    assemble(P, Hx, Hy, Hxe, Hye, constants, scratch, cuts)
    film = AbsFilmConstants(*constants)
    buf = AbsFilmScratch(*scratch)
    nx, ny = P.shape[1], P.shape[2]
    if scheme == SCHEME_BDF2:
        w = ratio
        a0 = (1.0 + 2.0 * w) / (1.0 + w)
        a1 = -(1.0 + w) / a0
        a2 = w * w / (1.0 + w) / a0
        weight = 1.0 / a0
        for i in range(1, nx - 1):
            for j in range(1, ny - 1):
                ca = ct * film.area[i, j]
                p = P[0, i, j]
                buf.diag[0, i, j] = ca * H_new[0, i, j]
                buf.rhs[0, i, j] = -(ca * (p * H_new[0, i, j] + a1 * p * H_old[0, i, j] + a2 * aux[0, i, j])
                                     + buf.R[0, i, j] * weight)  # fmt: skip
    else:
        weight = 0.5
        for i in range(1, nx - 1):
            for j in range(1, ny - 1):
                ca = ct * film.area[i, j]
                buf.diag[0, i, j] = ca * H_new[0, i, j]
                buf.rhs[0, i, j] = -(ca * P[0, i, j] * (H_new[0, i, j] - H_old[0, i, j])
                                     + 0.5 * (aux[0, i, j] + buf.R[0, i, j]))  # fmt: skip
    solve_and_add(P, scratch, weight)


@njit
def film_advance(
    q_old: np.ndarray, q_new: np.ndarray, disk_old: np.ndarray, disk_new: np.ndarray, ct: float, geometry: tuple,
    state: tuple, constants: tuple, scratch: tuple, cuts: tuple,
) -> bool:  # fmt: skip
    """One time step of the film, all of it in one call (:meth:`solver.abs.film.AbsFilm.step`): True if every
    node pressure after it is positive (and so finite).

    The spacings of the control volumes at both ends (:func:`fill_spacing`), the links' and the cut segments'
    at mid-step over the mid-step disk (:func:`fill_links`, :func:`fill_cut_points`), the disk set to its end,
    :func:`film_step` with ct = sigma / dt, and the spacings the force's link profiles read at the end attitude
    (the cut segments and the links from the face's edge: :func:`link_corrections`).  The links inside the face
    keep their mid-step spacings.

    disk_old, disk_new (1, nx, ny) [m]; geometry : (x, y, pivot_x, pivot_y, storage, surface_xf, surface_yf,
    surface_xe, surface_ye, inv_href, floor, x cut segments' (seg_x, seg_y, seg_surface), y cut segments' the
    same); state : (P, H, H_new, Hx, Hy, Hxe, Hye, disk, disk_xf, disk_yf, disk_mid), written.
    """
    (x, y, pivot_x, pivot_y, storage, surface_xf, surface_yf, surface_xe, surface_ye, inv_href, floor, xseg_x,
     xseg_y, xseg_surface, yseg_x, yseg_y, yseg_surface) = geometry  # fmt: skip
    P, H, H_new, Hx, Hy, Hxe, Hye, disk, disk_xf, disk_yf, disk_mid = state
    c = AbsFilmCuts(*cuts)
    fill_spacing(q_old, x, y, pivot_x, pivot_y, storage, disk_old, inv_href, floor, H)
    fill_spacing(q_new, x, y, pivot_x, pivot_y, storage, disk_new, inv_href, floor, H_new)
    set_disk_mid(disk_old[0], disk_new[0], disk_mid, disk, disk_xf, disk_yf)
    for end in range(2):  # the links at mid-step, then what the force reads at the end
        q = 0.5 * (q_old + q_new) if end == 0 else q_new
        fill_links(q, x, y, pivot_x, pivot_y, surface_xf, surface_yf, surface_xe, surface_ye, disk, inv_href, floor,
                   Hx, Hy, Hxe, Hye, end == 1)  # fmt: skip
        fill_cut_points(q, xseg_x, xseg_y, pivot_x, pivot_y, xseg_surface, disk_xf, c.xcell, inv_href, floor, c.xH)
        fill_cut_points(q, yseg_x, yseg_y, pivot_x, pivot_y, yseg_surface, disk_yf, c.ycell, inv_href, floor, c.yH)
        if end == 0:
            set_disk(disk_new[0], disk, disk_xf, disk_yf)
            film_step(P, H, H_new, Hx, Hy, Hxe, Hye, ct, constants, scratch, cuts)
    return positive(P)


@njit
def film_advance_at_ends(
    q_old: np.ndarray, q_new: np.ndarray, disk_old: np.ndarray, disk_new: np.ndarray, ct: float, geometry: tuple,
    state: tuple, constants: tuple, scratch: tuple, cuts: tuple, aux: np.ndarray, ratio: float, scheme: int,
    carried: bool, carry: np.ndarray,
) -> bool:  # fmt: skip
    """:func:`film_advance` of the schemes that take the fluxes at the step's ends (:func:`film_step_at_ends`):
    True if every node pressure after it is positive.

    The spacings of the control volumes at both ends; for SCHEME_TRAPEZOID, unless ``carried`` (``aux`` holds
    R(P_n) already: the last step's end residual carried to its new pressure), the links' and the cut segments'
    at the start, and R(P_n) over them into ``aux``; then (both schemes) the links at the end, over the disk at the
    end, which the step and the force read; the step (BDF2: ``aux`` its history m_n-1, ``ratio`` h_n / h_n-1); for
    SCHEME_TRAPEZOID the end residual carried to the new pressure into ``carry`` (:func:`linearized_residual`),
    the next step's start flux.  A separate kernel, so that the midpoint's (:func:`film_advance`) compiles as
    before.  Arguments as there.
    """
    (x, y, pivot_x, pivot_y, storage, surface_xf, surface_yf, surface_xe, surface_ye, inv_href, floor, xseg_x,
     xseg_y, xseg_surface, yseg_x, yseg_y, yseg_surface) = geometry  # fmt: skip
    P, H, H_new, Hx, Hy, Hxe, Hye, disk, disk_xf, disk_yf, _ = state
    c = AbsFilmCuts(*cuts)
    fill_spacing(q_old, x, y, pivot_x, pivot_y, storage, disk_old, inv_href, floor, H)
    fill_spacing(q_new, x, y, pivot_x, pivot_y, storage, disk_new, inv_href, floor, H_new)
    for end in range(2):  # the trapezoid's fluxes at the start, then both schemes' links at the end
        if end == 0 and (scheme == SCHEME_BDF2 or carried):
            continue
        q, d = (q_old, disk_old) if end == 0 else (q_new, disk_new)
        set_disk(d[0], disk, disk_xf, disk_yf)
        fill_links(q, x, y, pivot_x, pivot_y, surface_xf, surface_yf, surface_xe, surface_ye, disk, inv_href, floor,
                   Hx, Hy, Hxe, Hye, False)  # fmt: skip
        fill_cut_points(q, xseg_x, xseg_y, pivot_x, pivot_y, xseg_surface, disk_xf, c.xcell, inv_href, floor, c.xH)
        fill_cut_points(q, yseg_x, yseg_y, pivot_x, pivot_y, yseg_surface, disk_yf, c.ycell, inv_href, floor, c.yH)
        if end == 0:
            assemble(P, Hx, Hy, Hxe, Hye, constants, scratch, cuts)
            aux[:, :, :] = AbsFilmScratch(*scratch).R
    film_step_at_ends(P, H, H_new, Hx, Hy, Hxe, Hye, ct, aux, ratio, scheme, constants, scratch, cuts)
    if scheme == SCHEME_TRAPEZOID:
        buf = AbsFilmScratch(*scratch)
        linearized_residual(buf.R, scratch, buf.delta, carry)
    return positive(P)


@njit
def linearized_residual(R: np.ndarray, scratch: tuple, d: np.ndarray, out: np.ndarray) -> None:
    """out = R + J d at the interior nodes, J the Jacobian of the last :func:`assemble` (whole, not its
    factorisation) and d a change of the pressure, 0 at the edges (the Dirichlet nodes): R carried to first
    order to P + d.  The edges' rows are 0; out may be R."""
    buf = AbsFilmScratch(*scratch)
    nx, ny = d.shape[1], d.shape[2]
    for i in range(1, nx - 1):
        for j in range(1, ny - 1):
            out[0, i, j] = (R[0, i, j] + (buf.Jcx[0, i, j] + buf.Jcy[0, i, j]) * d[0, i, j]
                            + buf.Jxm[0, i, j] * d[0, i - 1, j] + buf.Jxp[0, i, j] * d[0, i + 1, j]
                            + buf.Jym[0, i, j] * d[0, i, j - 1] + buf.Jyp[0, i, j] * d[0, i, j + 1])  # fmt: skip
    out[0, 0, :] = 0.0
    out[0, nx - 1, :] = 0.0
    out[0, :, 0] = 0.0
    out[0, :, ny - 1] = 0.0


@njit
def positive(P: np.ndarray) -> bool:
    """True if every node pressure is positive (and so finite)."""
    for i in range(P.shape[1]):
        for j in range(P.shape[2]):
            if not P[0, i, j] > 0.0:
                return False
    return True


@njit
def film_forces_linked(
    P: np.ndarray, area: np.ndarray, x: np.ndarray, y: np.ndarray, pivot_x: float, pivot_y: float, x_links: tuple,
    y_links: tuple,
) -> tuple[float, float, float]:  # fmt: skip
    """:func:`film_forces` plus :func:`link_corrections`, in one call [m2, m3, m3]."""
    f, mp, mr = film_forces(P, area, x, y, pivot_x, pivot_y)
    cf, cp, cr = link_corrections(P, x_links, y_links)
    return f + cf, mp + cp, mr + cr


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
