"""Rough-surface pressures per cell: Greenwood-Williamson contact and intermolecular adhesion.

A cell of the slider face sees the local mean plane of the disk at the
separation ``d`` [m]; the disk heights z about that plane are Gaussian with
standard deviation ``sigma`` [m] (``sigma = 0``: a smooth disk).  ``eps`` [m]
is the intermolecular equilibrium spacing.  Positive pressure pushes the
slider away from the disk (repulsion); adhesion is negative.

Contact (Greenwood-Williamson with a repulsive wall at ``eps``): a summit of
height z is compressed by z - (d - eps) when that is positive, and Hertz gives

    p_c(d) = gw_coef sigma^(3/2) F_{3/2}(t),   t = (d - eps) / sigma,
    dp_c/dd = -(3/2) gw_coef sigma^(1/2) F_{1/2}(t),

with ``gw_coef = (4/3) eta_s E' sqrt(R)`` and the standardized integrals

    F_n(t) = int_t^inf (s - t)^n phi(s) ds,   dF_n/dt = -n F_{n-1},

phi the standard normal density.  Smooth limit: p_c = gw_coef max(eps - d, 0)^(3/2).

Adhesion is chosen by a law code (``ADHESION_FLAT``, ``ADHESION_ASPERITY``;
their names are in :data:`solver.surface.ADHESION_LAWS`).

Flat law (Lennard-Jones flat-flat law over the part of the disk farther than
``eps`` from the slider), with h = d - z the local gap:

    p_LJ(h) = adh_coef [(eps/h)^9 - (eps/h)^3],   adh_coef = 8 dgamma / (3 eps),
    p_a(d) = int_eps^inf p_LJ(h) phi_sigma(d - h) dh,
    dp_a/dd = int_eps^inf p_LJ'(h) phi_sigma(d - h) dh,

(the boundary term of the derivative vanishes because p_LJ(eps) = 0).
Smooth limit: p_a = p_LJ(d) for d >= eps, else 0.

Asperity law (DMT summits): the summits of the contact law (density eta_s,
radius R, heights z ~ N(0, sigma)) each pull like a sphere on a flat in the
Derjaguin-Muller-Toporov model.  The flat law's interaction energy per area,

    W(h) = int_h^inf p_LJ = (adh_coef eps / 8) [(eps/h)^8 - 4 (eps/h)^2],   W(eps) = -dgamma,

gives a summit at the gap g = d - z > eps the Derjaguin sphere-flat force
F(g) = 2 pi R W(g); a summit compressed past the wall (g < eps, the same
summits that carry Hertz load above) keeps the pull-off F = -2 pi R dgamma:
in the DMT limit the attraction outside the contact does not depend on the
contact radius (Maugis, J. Colloid Interface Sci. 150:243, 1992, lambda -> 0).
Chen & Bogy's reference list (SCENE2-NOTES.md, section 2: Greenwood-Williamson,
Chang-Etsion-Bogy adhesion, DMT, Maugis-Dugdale) points to this family; DMT
rather than JKR or Maugis-Dugdale because the summits are hard and small:
Tabor's parameter (R dgamma^2 / (E'^2 eps^3))^(1/3) is 0.065 for chen_bogy2007
(R = 1 um, E' = 94 GPa, eps = 0.3 nm, dgamma = 0.008), inside the DMT range
(< 0.1), and 0.30 at dgamma = 0.08, where Maugis-Dugdale's pull-off is
somewhat below 2 pi R dgamma (DMT is then an upper bound).  Both laws share
dgamma and eps exactly (W is the flat law's own energy).  Per area, with
``summit_coef = 2 pi R eta_s`` [1/m], t = (d - eps) / sigma and
Q(t) = P(Z > t) = erfc(t / sqrt 2) / 2 (the fraction of summits past the wall),

    p_a(d) = summit_coef [-dgamma Q(t) + int_eps^inf W(h) phi_sigma(d - h) dh],
    dp_a/dd = -summit_coef int_eps^inf p_LJ(h) phi_sigma(d - h) dh = -summit_coef p_a^flat(d):

the boundary terms of the derivative cancel (dgamma phi(t) / sigma from Q,
W(eps) phi(t) / sigma from the integral) because F is continuous at eps.  So
p_a(d) = summit_coef int_d^inf p_a^flat: per summit the law is the flat law's
work of adhesion.  Limits: every summit compressed (t -> -inf),
p_a -> -summit_coef dgamma; smooth disk, p_a = summit_coef W(d) for d >= eps
and -summit_coef dgamma below (continuous with its slope, as p_LJ(eps) = 0);
far field, p_a -> -(4/3) summit_coef dgamma (eps/d)^2 (the flat law falls
like d^-3).

How the integrals are evaluated
-------------------------------
``F_{1/2}``, ``F_{3/2}`` come from piecewise Chebyshev series (degree
``CHEB_DEGREE`` on unit intervals) built once at import: of F_n itself on
[T_ASYMPTOTIC, 0] and of F_n / phi on [0, T_ZERO] (which keeps the relative
accuracy where F_n decays like phi(t) t^(-n-1)).  The nodal values come from
the substitution s - t = v^2,

    F_n(t) = int_-inf^inf |v|^(2n+1) phi(v^2 + t) dv,

whose integrand is smooth and decays like exp(-v^4 / 2), so the trapezoidal
rule converges geometrically (step 0.01: round-off level).  Below
T_ASYMPTOTIC the expansion F_n(t) = a^n sum_k binom(n, 2k) (2k-1)!! a^(-2k),
a = -t, (exponentially small remainder) is used, and above T_ZERO,
phi(t) underflows and F_n = 0.  Measured: relative error < 2e-14 everywhere.

The adhesion integral, in t = (d - eps) / sigma:

* t >= N_SIGMA (the whole distribution beyond the wall, sigma / d < 1/8.5):
  10-point Gauss-Hermite, p_a = E[p_LJ(d - sigma Z)];
* TAU_NO_ADHESION <= t < N_SIGMA: composite 12-point Gauss-Legendre panels
  in h from eps to d + sigma sqrt(min(t, 0)^2 + 2 GAUSS_TAIL) (where the
  Gaussian weight has fallen by exp(-GAUSS_TAIL) from its largest value on
  h >= eps), each panel at most PANEL_SIGMAS sigma wide (the Gaussian) and
  PANEL_GROWTH times its start h wide (the steep power laws near the wall);
* t < TAU_NO_ADHESION or d - N_SIGMA sigma > LJ_RANGE eps: |p_a| < 1e-12
  adh_coef, returned as 0.

The slope uses the same nodes with p_LJ'; the asperity law adds W at the
same nodes (one more power of u per node) and Q(t) by ``math.erfc``, with no
cut-off at LJ_RANGE (its far field falls only like d^-2; Gauss-Hermite
costs 10 nodes there).  For t < TAU_NO_ADHESION the summits outside the
wall (a fraction below 2.6e-12) are counted as pulling dgamma each, so p_a is
the bound -summit_coef dgamma.  Measured for the asperity law against quad in
z (sigma 1e-12 to 2e-9 m, t from -7.5 to 3000): p_a within 1e-10 relative;
with the contact pressure, 357 ns per cell near the wall against 313 for the
flat law (sigma = 0.2 nm), 83 against 55 ns where Gauss-Hermite applies.
For the flat law, measured against quad for sigma
from 1e-12 to 2e-9 m (eps = 0.3 nm): p_a within 3e-8 relative (within
7e-8 where |p_a| < 1e-10 adh_coef), dp_a/dd within 7e-8 of its largest
magnitude; 12 to 84 integrand evaluations per cell near the wall (mean 43
for sigma = 0.2 nm, 56 for 0.6 nm).  The panel edges do not move with d
(only the last one does), so the computed p_a is continuous in d except for
steps of the size of the quadrature error where the panel count changes
and at t = N_SIGMA.

The tables and quadrature nodes are module globals, which numba freezes
into the compiled code as constants (they are C-contiguous and small, so
the functions stay cacheable).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import chebyshev, hermite_e, legendre

from ..jit import njit
from .elementary import EXP_ARGUMENT_MAX, exp_minus

#: Degree of the Chebyshev series on each unit interval of t.
CHEB_DEGREE = 14
#: Below this t the large-negative-t expansion of F_n is used.
T_ASYMPTOTIC = -10.0
#: Above this t, F_n < phi(t) underflows: F_n = 0.
T_ZERO = 40.0
#: A cell's contact pressure (:func:`contact_pressure`) is taken as 0 from this t = (d - eps) / sigma on, where
#: F_3/2 and F_1/2 are 1.3e-34 and 1.1e-33 of their values at t = 0: below the round-off of any sum with a cell
#: that touches, and of the adhesion added to it cell by cell.  Most of a flying pad's candidate cells lie beyond
#: it (97 % of them on the default scene in flight: t from 7.7 to 155, median 39), and their Chebyshev pass cost
#: two thirds of a Newton iterate's surface forces.
T_NEGLIGIBLE = 12.0
#: Adhesion by Gauss-Hermite when the wall lies this many sigma below the mean plane (tail mass 1e-17).
N_SIGMA = 8.5
#: Near-wall panels end where the Gaussian weight has dropped by exp(-GAUSS_TAIL) from its largest value.
GAUSS_TAIL = 32.0
#: No adhesion below this t = (d - eps) / sigma: |p_a| < 0.385 adh_coef P(Z > -t) < 1e-12 adh_coef.
TAU_NO_ADHESION = -6.9
#: Near-wall adhesion panels: width <= PANEL_SIGMAS sigma and <= PANEL_GROWTH h.
PANEL_SIGMAS = 4.0
PANEL_GROWTH = 1.5
#: A remainder narrower than this fraction of the panel before it is merged into that panel.
PANEL_MERGE = 0.25
#: Beyond this many eps the LJ law is below 1e-12 of adh_coef: no adhesion.
LJ_RANGE = 1.0e4

#: :func:`generalized_forces`' adhesion cache: off, fill it, use it within CACHE_REACH max(sigma, eps) of its cells.
CACHE_OFF = 0
CACHE_FILL = 1
CACHE_USE = 2
CACHE_REACH = 1.0e-3

#: The contact damping's "no contact": omega_c^2 at or below this [1/s^2] (omega_c <= 1 rad/s, seven decades below
#: the suspension's modes).  A cell at t = 38.4 in the Greenwood-Williamson tail has p_c = 0 and a subnormal
#: stiffness (dp_c/dd = -1.3e-305 Pa/m); omega_c^2 = 6.5e-310 then overflowed 1 / (2 omega_c^2) (fastmath takes
#: the division as a reciprocal), and 0 x inf made the Jacobian nan: a stuck pad bouncing off the disk at zeta 0.1
#: failed there (studies/contact_damping.toml, track 4 at dt 0.05 us).
CONTACT_OMEGA2_FLOOR = 1.0

#: Adhesion law codes of the kernels (names in :data:`solver.surface.ADHESION_LAWS`).
ADHESION_FLAT = 0
ADHESION_ASPERITY = 1

_SQRT_2PI = math.sqrt(2.0 * math.pi)
_INV_SQRT2 = 1.0 / math.sqrt(2.0)
_ORDERS = (1.5, 0.5)


def _nodal_integrals(t: np.ndarray, scaled: bool) -> np.ndarray:
    """F_{3/2}, F_{1/2} (or F_n / phi when ``scaled``) at t by the trapezoidal rule in v; shape (2,) + t.shape."""
    step = 0.01
    v2 = (step * np.arange(1, 1400)) ** 2
    tt = np.asarray(t, dtype=float)[..., None]
    if scaled:
        weight = np.exp(-0.5 * v2 * (v2 + 2.0 * tt))
    else:
        weight = np.exp(-0.5 * (v2 + tt) ** 2) / _SQRT_2PI
    return np.stack([2.0 * step * np.sum(v2 ** (n + 0.5) * weight, axis=-1) for n in _ORDERS])


def _chebyshev_table(lo: float, hi: float, scaled: bool) -> np.ndarray:
    """Coefficients (n_intervals, 2, CHEB_DEGREE + 1) of F_{3/2}, F_{1/2} on the unit intervals of [lo, hi]."""
    starts = np.arange(lo, hi)
    x = np.cos(np.pi * (np.arange(CHEB_DEGREE + 1) + 0.5) / (CHEB_DEGREE + 1))
    values = _nodal_integrals(starts[:, None] + 0.5 * (x + 1.0), scaled)
    vandermonde = chebyshev.chebvander(x, CHEB_DEGREE)
    coefficients = [np.linalg.solve(vandermonde, values[k].T).T for k in range(2)]
    return np.ascontiguousarray(np.stack(coefficients, axis=1))


def _asymptotic_coefficients(n_terms: int) -> np.ndarray:
    """binom(n, 2k) (2k-1)!! for n = 3/2, 1/2 and k < n_terms; shape (2, n_terms)."""
    out = np.empty((2, n_terms))
    for row, n in enumerate(_ORDERS):
        binom = 1.0
        double_factorial = 1.0
        for k in range(n_terms):
            out[row, k] = binom * double_factorial
            binom *= (n - 2 * k) * (n - 2 * k - 1) / ((2 * k + 1) * (2 * k + 2))
            double_factorial *= 2 * k + 1
    return out


_CHEB_NEGATIVE = _chebyshev_table(T_ASYMPTOTIC, 0.0, scaled=False)
_CHEB_POSITIVE = _chebyshev_table(0.0, T_ZERO, scaled=True)
_ASYMPTOTIC = _asymptotic_coefficients(14)
_GL_NODES, _GL_WEIGHTS = legendre.leggauss(12)
_GH_NODES, _GH_WEIGHTS = hermite_e.hermegauss(10)
_GH_WEIGHTS = _GH_WEIGHTS / _SQRT_2PI


@njit(inline=True)
def _clenshaw_pair(table: np.ndarray, row: int, x: float) -> tuple[float, float]:
    """Both Chebyshev series of ``table[row]`` (2, degree + 1) at x in [-1, 1] (indexed, not sliced, so that a
    loop over cells that inlines it vectorizes)."""
    b1a = 0.0
    b2a = 0.0
    b1b = 0.0
    b2b = 0.0
    x2 = 2.0 * x
    for k in range(table.shape[2] - 1, 0, -1):
        b1a, b2a = x2 * b1a - b2a + table[row, 0, k], b1a
        b1b, b2b = x2 * b1b - b2b + table[row, 1, k], b1b
    return x * b1a - b2a + table[row, 0, 0], x * b1b - b2b + table[row, 1, 0]


@njit
def gw_integrals(t: float) -> tuple[float, float]:
    """F_{3/2}(t) and F_{1/2}(t), F_n(t) = int_t^inf (s - t)^n phi(s) ds; relative error < 2e-14."""
    if t < T_ASYMPTOTIC:
        inv_a2 = 1.0 / (t * t)
        sum32 = 0.0
        sum12 = 0.0
        for k in range(_ASYMPTOTIC.shape[1] - 1, -1, -1):
            sum32 = sum32 * inv_a2 + _ASYMPTOTIC[0, k]
            sum12 = sum12 * inv_a2 + _ASYMPTOTIC[1, k]
        root = math.sqrt(-t)
        return -t * root * sum32, root * sum12
    if t < 0.0:
        k = min(int(t - T_ASYMPTOTIC), _CHEB_NEGATIVE.shape[0] - 1)
        x = 2.0 * (t - T_ASYMPTOTIC - k) - 1.0
        return _clenshaw_pair(_CHEB_NEGATIVE, k, x)
    if t < T_ZERO:
        k = int(t)
        x = 2.0 * (t - k) - 1.0
        f32, f12 = _clenshaw_pair(_CHEB_POSITIVE, k, x)
        phi = math.exp(-0.5 * t * t) / _SQRT_2PI
        return f32 * phi, f12 * phi
    if t >= T_ZERO:
        return 0.0, 0.0
    return t, t  # nan in, nan out


#: Both tables in one, interval k on [T_ASYMPTOTIC + k, T_ASYMPTOTIC + k + 1): F_n below t = 0, F_n / phi above.
_CHEB_ALL = np.ascontiguousarray(np.concatenate([_CHEB_NEGATIVE, _CHEB_POSITIVE]))
_N_NEGATIVE = _CHEB_NEGATIVE.shape[0]


@njit(inline=True)
def gw_integrals_vectorizable(t: float) -> tuple[float, float]:
    """:func:`gw_integrals` for t >= T_ASYMPTOTIC (not nan) without branches or libm calls, so that a loop over cells
    vectorizes: the same intervals, abscissae and Clenshaw sums (the two tables as one, its coefficients gathered
    per cell), phi by :func:`solver.kernels.elementary.exp_minus`, and selects instead of the branches."""
    tt = min(t, T_ZERO)  # beyond T_ZERO the result is 0 (selected below); the index stays in the table
    positive = tt >= 0.0
    k_neg = min(int(tt - T_ASYMPTOTIC), _N_NEGATIVE - 1)
    k_pos = min(int(tt), _CHEB_POSITIVE.shape[0] - 1)
    x = 2.0 * (tt - k_pos) - 1.0 if positive else 2.0 * (tt - T_ASYMPTOTIC - k_neg) - 1.0
    k = k_pos + _N_NEGATIVE if positive else k_neg
    f32, f12 = _clenshaw_pair(_CHEB_ALL, k, x)
    y = 0.5 * tt * tt
    phi = exp_minus(y) / _SQRT_2PI
    f32 = f32 * phi if positive else f32
    f12 = f12 * phi if positive else f12
    zero = t >= T_ZERO or y > EXP_ARGUMENT_MAX  # exp_minus stops at exp(-708); libm's exp goes subnormal, then 0
    return 0.0 if zero else f32, 0.0 if zero else f12


@njit
def fill_contact_pressures(
    d: np.ndarray, sigma: np.ndarray, eps: float, gw_coef: float, pc: np.ndarray, dpc: np.ndarray
) -> None:
    """:func:`contact_pressure` at every cell into ``pc``, ``dpc``: one vectorized pass
    (:func:`gw_integrals_vectorizable`), then cell by cell where it does not apply (a smooth disk, t below
    T_ASYMPTOTIC, nan).  The values of :func:`contact_pressure`, to round-off.

    The cells at t >= T_NEGLIGIBLE, whose pressure is taken as 0 (most of a flying pad's candidates: 97 % on the
    default scene), are set first and left out of the Chebyshev pass, which runs over the others gathered.
    """
    n = d.size
    t_all = np.empty(n)
    for i in range(n):  # no branch: it vectorizes
        s = sigma[i] if sigma[i] > 0.0 else 1.0  # a smooth disk's cells are taken again below
        root = math.sqrt(s)
        t_all[i] = (d[i] - eps) / s
        pc[i] = gw_coef * s * root * 0.0  # F_n = 0 (contact_pressure's value beyond T_NEGLIGIBLE)
        dpc[i] = -1.5 * gw_coef * root * 0.0
    index, ts, redo = np.empty(n, dtype=np.int64), np.empty(n), np.empty(n, dtype=np.int64)
    m = r = 0
    for i in range(n):
        t = t_all[i]
        if not t >= T_NEGLIGIBLE:  # nan too: redone below
            index[m] = i
            ts[m] = t
            m += 1
        if not (sigma[i] > 0.0 and t >= T_ASYMPTOTIC):
            redo[r] = i
            r += 1
    f32s, f12s = np.empty(m), np.empty(m)
    for k in range(m):
        t = ts[k]
        f32s[k], f12s[k] = gw_integrals_vectorizable(t if t >= T_ASYMPTOTIC else T_ASYMPTOTIC)
    for k in range(m):
        i = index[k]
        s = sigma[i] if sigma[i] > 0.0 else 1.0
        root = math.sqrt(s)
        pc[i] = gw_coef * s * root * f32s[k]
        dpc[i] = -1.5 * gw_coef * root * f12s[k]
    for k in range(r):
        i = redo[k]
        pc[i], dpc[i] = contact_pressure(d[i], sigma[i], eps, gw_coef)


@njit
def lj_pressure(h: float, eps: float, adh_coef: float) -> tuple[float, float]:
    """Flat-flat Lennard-Jones pressure adh_coef [(eps/h)^9 - (eps/h)^3] [Pa] and its slope d/dh [Pa/m]."""
    inv_h = 1.0 / h  # one division for both (they dominate the cost of the adhesion quadratures)
    u = eps * inv_h
    u3 = u * u * u
    u9 = u3 * u3 * u3
    return adh_coef * (u9 - u3), adh_coef * (3.0 * u3 - 9.0 * u9) * inv_h


@njit
def lj_energy(h: float, eps: float, adh_coef: float) -> float:
    """Flat-flat energy per area W(h) = int_h^inf p_LJ = (adh_coef eps / 8) [(eps/h)^8 - 4 (eps/h)^2] [J/m2]."""
    u = eps / h
    u2 = u * u
    u4 = u2 * u2
    return 0.125 * adh_coef * eps * (u4 * u4 - 4.0 * u2)


@njit
def lj_curvature(h: float, eps: float, adh_coef: float) -> float:
    """d^2 p_LJ / dh^2 = adh_coef (90 (eps/h)^9 - 12 (eps/h)^3) / h^2 [Pa/m^2]."""
    inv_h = 1.0 / h
    u = eps * inv_h
    u3 = u * u * u
    return adh_coef * (90.0 * u3 * u3 * u3 - 12.0 * u3) * inv_h * inv_h


@njit
def contact_pressure(d: float, sigma: float, eps: float, gw_coef: float) -> tuple[float, float]:
    """Greenwood-Williamson pressure p_c [Pa] and dp_c/dd [Pa/m] of one cell."""
    if sigma > 0.0:
        t = (d - eps) / sigma
        f32, f12 = gw_integrals(t) if not t >= T_NEGLIGIBLE else (0.0, 0.0)
        root = math.sqrt(sigma)
        return gw_coef * sigma * root * f32, -1.5 * gw_coef * root * f12
    if d < eps:
        root = math.sqrt(eps - d)
        return gw_coef * (eps - d) * root, -1.5 * gw_coef * root
    return 0.0, 0.0


@njit
def _gap_expectations(
    d: float, sigma: float, eps: float, adh_coef: float, tau: float, energy: bool, curvature: bool = False
):
    """E[p_LJ], E[p_LJ'], (if ``energy``) E[W] and (if ``curvature``) E[p_LJ''] over the gaps h = d - sigma Z >= eps,
    sigma > 0 (module docstring)."""
    p = 0.0
    slope = 0.0
    work = 0.0
    curv = 0.0
    if tau >= N_SIGMA:
        for k in range(_GH_NODES.size):
            h = d - sigma * _GH_NODES[k]
            pk, sk = lj_pressure(h, eps, adh_coef)
            p += _GH_WEIGHTS[k] * pk
            slope += _GH_WEIGHTS[k] * sk
            if energy:
                work += _GH_WEIGHTS[k] * lj_energy(h, eps, adh_coef)
            if curvature:
                curv += _GH_WEIGHTS[k] * lj_curvature(h, eps, adh_coef)
        return p, slope, work, curv
    # beyond h_hi the Gaussian weight is below exp(-GAUSS_TAIL) of its largest value on h >= eps
    h_hi = d + sigma * math.sqrt(min(tau, 0.0) ** 2 + 2.0 * GAUSS_TAIL)
    start = eps
    inv_sigma = 1.0 / sigma
    while start < h_hi:
        end = start + min(PANEL_SIGMAS * sigma, PANEL_GROWTH * start)
        if end > h_hi - PANEL_MERGE * (end - start):
            end = h_hi
        half = 0.5 * (end - start)
        mid = 0.5 * (end + start)
        for k in range(_GL_NODES.size):
            h = mid + half * _GL_NODES[k]
            s = (d - h) * inv_sigma
            w = half * _GL_WEIGHTS[k] * math.exp(-0.5 * s * s)
            pk, sk = lj_pressure(h, eps, adh_coef)
            p += w * pk
            slope += w * sk
            if energy:
                work += w * lj_energy(h, eps, adh_coef)
            if curvature:
                curv += w * lj_curvature(h, eps, adh_coef)
        start = end
    norm = inv_sigma / _SQRT_2PI
    return p * norm, slope * norm, work * norm, curv * norm


@njit
def _flat_adhesion(d: float, sigma: float, eps: float, adh_coef: float, curvature: bool) -> tuple[float, float, float]:
    """Flat-law p_a, dp_a/dd and (if ``curvature``, else 0) d^2 p_a/dd^2: E[p_LJ''] plus the wall's term
    p_LJ'(eps) phi_sigma(d - eps), since p_a = E[p_LJ] over h >= eps and p_LJ(eps) = 0."""
    if sigma <= 0.0:
        if d < eps:
            return 0.0, 0.0, 0.0
        p, slope = lj_pressure(d, eps, adh_coef)
        return p, slope, lj_curvature(d, eps, adh_coef) if curvature else 0.0
    tau = (d - eps) / sigma
    if tau < TAU_NO_ADHESION or d - N_SIGMA * sigma > LJ_RANGE * eps:
        return 0.0, 0.0, 0.0
    p, slope, _, curv = _gap_expectations(d, sigma, eps, adh_coef, tau, False, curvature)
    if curvature:
        curv -= 6.0 * adh_coef / eps * math.exp(-0.5 * tau * tau) / (sigma * _SQRT_2PI)  # p_LJ'(eps) = -6 adh/eps
    return p, slope, curv


@njit
def adhesion_pressure(d: float, sigma: float, eps: float, adh_coef: float) -> tuple[float, float]:
    """Flat-law adhesion pressure p_a [Pa] (<= 0) and dp_a/dd [Pa/m] of one cell."""
    p, slope, _ = _flat_adhesion(d, sigma, eps, adh_coef, False)
    return p, slope


@njit
def _asperity_adhesion(
    d: float, sigma: float, eps: float, adh_coef: float, summit_coef: float
) -> tuple[float, float, float]:
    """DMT-summit p_a, dp_a/dd = -summit_coef E[p_LJ] and d^2 p_a/dd^2 = -summit_coef E[p_LJ'] (one quadrature)."""
    dgamma = 0.375 * adh_coef * eps  # adh_coef = 8 dgamma / (3 eps)
    if sigma <= 0.0:
        if d < eps:
            return -summit_coef * dgamma, 0.0, 0.0
        p, slope = lj_pressure(d, eps, adh_coef)
        return summit_coef * lj_energy(d, eps, adh_coef), -summit_coef * p, -summit_coef * slope
    tau = (d - eps) / sigma
    if tau < TAU_NO_ADHESION:  # the summits outside the wall (< 2.6e-12 of them) sit at it: every one pulls dgamma
        return -summit_coef * dgamma, 0.0, 0.0
    compressed = 0.5 * math.erfc(tau * _INV_SQRT2)  # fraction of summits past the wall
    p, slope, work, _ = _gap_expectations(d, sigma, eps, adh_coef, tau, True)
    return summit_coef * (work - dgamma * compressed), -summit_coef * p, -summit_coef * slope


@njit
def asperity_adhesion_pressure(
    d: float, sigma: float, eps: float, adh_coef: float, summit_coef: float
) -> tuple[float, float]:
    """DMT-summit adhesion pressure p_a [Pa] (<= 0) and dp_a/dd [Pa/m] of one cell; summit_coef = 2 pi R eta_s [1/m]."""
    p, slope, _ = _asperity_adhesion(d, sigma, eps, adh_coef, summit_coef)
    return p, slope


@njit
def adhesion_by_law(
    d: float, sigma: float, eps: float, adh_coef: float, law: int, summit_coef: float
) -> tuple[float, float]:
    """Adhesion pressure [Pa] and slope d/dd [Pa/m] of one cell by the law code (ADHESION_FLAT, ADHESION_ASPERITY)."""
    if law == ADHESION_ASPERITY:
        return asperity_adhesion_pressure(d, sigma, eps, adh_coef, summit_coef)
    return adhesion_pressure(d, sigma, eps, adh_coef)


@njit
def adhesion_with_curvature(
    d: float, sigma: float, eps: float, adh_coef: float, law: int, summit_coef: float
) -> tuple[float, float, float]:
    """:func:`adhesion_by_law`'s pressure and slope, and its curvature d^2 p_a / dd^2 [Pa/m^2], from the same
    quadrature (the asperity law's curvature costs nothing more; the flat law's one more sum)."""
    if law == ADHESION_ASPERITY:
        return _asperity_adhesion(d, sigma, eps, adh_coef, summit_coef)
    return _flat_adhesion(d, sigma, eps, adh_coef, True)


@njit
def contact_pressures(d: np.ndarray, sigma: np.ndarray, eps: float, gw_coef: float, out: np.ndarray) -> None:
    """Fill ``out`` (2, n) with the Greenwood-Williamson p_c and dp_c/dd per cell (:func:`contact_pressure`)."""
    for i in range(d.size):
        out[0, i], out[1, i] = contact_pressure(d[i], sigma[i], eps, gw_coef)


@njit
def surface_pressures(
    d: np.ndarray,
    sigma: np.ndarray,
    eps: float,
    gw_coef: float,
    adh_coef: float,
    adhesion_law: int,
    summit_coef: float,
    out: np.ndarray,
) -> None:
    """Fill ``out`` (4, n) with p_c, dp_c/dd, p_a, dp_a/dd per cell for separations d (n,) and roughness sigma (n,).

    ``adhesion_law`` is a law code (:func:`adhesion_by_law`); ``summit_coef`` = 2 pi R eta_s [1/m] (asperity law only).
    """
    for i in range(d.size):
        out[0, i], out[1, i] = contact_pressure(d[i], sigma[i], eps, gw_coef)
        out[2, i], out[3, i] = adhesion_by_law(d[i], sigma[i], eps, adh_coef, adhesion_law, summit_coef)


@njit(inline=True)
def flat_adhesion_far(d: float, sigma: float, eps: float, adh_coef: float) -> tuple[float, float, float]:
    """:func:`_flat_adhesion` with its curvature where Gauss-Hermite applies (t >= N_SIGMA), without branches or
    libm calls so that a loop over cells vectorizes: the same nodes, one division per node for p_LJ, p_LJ' and
    p_LJ'' together, and the wall's term by :func:`solver.kernels.elementary.exp_minus`."""
    p = slope = curv = 0.0
    for k in range(_GH_NODES.size):
        inv_h = 1.0 / (d - sigma * _GH_NODES[k])
        u = eps * inv_h
        u3 = u * u * u
        u9 = u3 * u3 * u3
        w = _GH_WEIGHTS[k] * adh_coef
        p += w * (u9 - u3)
        slope += w * (3.0 * u3 - 9.0 * u9) * inv_h
        curv += w * (90.0 * u9 - 12.0 * u3) * inv_h * inv_h
    tau = (d - eps) / sigma
    curv -= 6.0 * adh_coef / eps * exp_minus(0.5 * tau * tau) / (sigma * _SQRT_2PI)  # p_LJ'(eps) = -6 adh/eps
    return p, slope, curv


@njit
def near_wall_expectations(
    d: np.ndarray, sigma: np.ndarray, eps: float, adh_coef: float, energy: bool, curvature: bool, out: np.ndarray
) -> None:
    """:func:`_gap_expectations` near the wall (TAU_NO_ADHESION <= t < N_SIGMA) for many cells at once, into
    ``out`` (4, n): E[p_LJ], E[p_LJ'], E[W] (if ``energy``, else 0), E[p_LJ''] (if ``curvature``, else 0).

    The same panels and nodes as the cell-by-cell quadrature, taken panel by panel and node by node over the
    cells (sorted by their number of panels, so that the cells that have a panel m are a prefix), so that the
    innermost loop runs over cells without calls or branches and vectorizes; the Gaussian weight by
    :func:`solver.kernels.elementary.exp_minus`.  Every cell's sum is taken in the cell-by-cell order, so the
    values differ from :func:`_gap_expectations`' only by exp_minus' ulps against libm's exp.
    """
    n = d.size
    h_hi = np.empty(n)
    panels = np.empty(n, dtype=np.int64)
    for i in range(n):
        tau = (d[i] - eps) / sigma[i]
        h_hi[i] = d[i] + sigma[i] * math.sqrt(min(tau, 0.0) ** 2 + 2.0 * GAUSS_TAIL)
        start, m = eps, 0
        while start < h_hi[i]:
            end = start + min(PANEL_SIGMAS * sigma[i], PANEL_GROWTH * start)
            if end > h_hi[i] - PANEL_MERGE * (end - start):
                end = h_hi[i]
            start = end
            m += 1
        panels[i] = m
    order = np.argsort(-panels, kind="mergesort")  # most panels first
    count = panels[order[0]] if n > 0 else 0
    active = np.zeros(count, dtype=np.int64)  # cells that have a panel m: the first active[m] in this order
    ds, inv_sigma = np.empty(n), np.empty(n)
    half, mid = np.zeros((count, n)), np.full((count, n), eps)
    for r in range(n):
        i = order[r]
        ds[r] = d[i]
        inv_sigma[r] = 1.0 / sigma[i]
        start, m = eps, 0
        while start < h_hi[i]:
            end = start + min(PANEL_SIGMAS * sigma[i], PANEL_GROWTH * start)
            if end > h_hi[i] - PANEL_MERGE * (end - start):
                end = h_hi[i]
            half[m, r] = 0.5 * (end - start)
            mid[m, r] = 0.5 * (end + start)
            active[m] = r + 1
            start = end
            m += 1
    p, slope, work, curv = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)  # one array each: no aliasing
    energy_coef = 0.125 * adh_coef * eps
    for m in range(count):
        half_m, mid_m = half[m].copy(), mid[m].copy()
        n_m = active[m]
        for k in range(_GL_NODES.size):
            node, weight = _GL_NODES[k], _GL_WEIGHTS[k]
            if energy:
                for i in range(n_m):
                    h = mid_m[i] + half_m[i] * node
                    s = (ds[i] - h) * inv_sigma[i]
                    w = half_m[i] * weight * exp_minus(0.5 * s * s)
                    inv_h = 1.0 / h  # lj_pressure's and lj_energy's arithmetic, operation for operation
                    u = eps * inv_h
                    u3 = u * u * u
                    u9 = u3 * u3 * u3
                    p[i] += w * (adh_coef * (u9 - u3))
                    slope[i] += w * (adh_coef * (3.0 * u3 - 9.0 * u9) * inv_h)
                    v = eps / h
                    v2 = v * v
                    v4 = v2 * v2
                    work[i] += w * (energy_coef * (v4 * v4 - 4.0 * v2))
            if curvature:
                for i in range(n_m):
                    h = mid_m[i] + half_m[i] * node
                    s = (ds[i] - h) * inv_sigma[i]
                    w = half_m[i] * weight * exp_minus(0.5 * s * s)
                    inv_h = 1.0 / h  # lj_pressure's and lj_curvature's
                    u = eps * inv_h
                    u3 = u * u * u
                    u9 = u3 * u3 * u3
                    if not energy:
                        p[i] += w * (adh_coef * (u9 - u3))
                        slope[i] += w * (adh_coef * (3.0 * u3 - 9.0 * u9) * inv_h)
                    curv[i] += w * (adh_coef * (90.0 * u3 * u3 * u3 - 12.0 * u3) * inv_h * inv_h)
            if not energy and not curvature:
                for i in range(n_m):
                    h = mid_m[i] + half_m[i] * node
                    s = (ds[i] - h) * inv_sigma[i]
                    w = half_m[i] * weight * exp_minus(0.5 * s * s)
                    inv_h = 1.0 / h
                    u = eps * inv_h
                    u3 = u * u * u
                    u9 = u3 * u3 * u3
                    p[i] += w * (adh_coef * (u9 - u3))
                    slope[i] += w * (adh_coef * (3.0 * u3 - 9.0 * u9) * inv_h)
    for r in range(n):
        norm = inv_sigma[r] / _SQRT_2PI
        i = order[r]
        out[0, i] = p[r] * norm
        out[1, i] = slope[r] * norm
        out[2, i] = work[r] * norm
        out[3, i] = curv[r] * norm


@njit
def _near_wall_at(
    d: np.ndarray, sigma: np.ndarray, near: np.ndarray, eps: float, adh_coef: float, energy: bool, curvature: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`near_wall_expectations` at the cells ``near``: their separations, roughness and the (4, k) sums."""
    d_near, s_near = np.empty(near.size), np.empty(near.size)
    for k in range(near.size):
        d_near[k], s_near[k] = d[near[k]], sigma[near[k]]
    out = np.empty((4, near.size))
    near_wall_expectations(d_near, s_near, eps, adh_coef, energy, curvature, out)
    return d_near, s_near, out


@njit
def fill_flat_adhesion(d_cells: np.ndarray, sigma: np.ndarray, eps: float, adh_coef: float, cache: tuple) -> None:
    """The flat law's adhesion with its curvature at every cell (separations ``d_cells``), into ``cache`` = (d, p_a,
    p_a', p_a'').

    One pass of :func:`flat_adhesion_far` over all cells (it vectorizes); the cells near the wall again by
    :func:`near_wall_expectations` (it vectorizes too: a pad held on the disk has every cell there), the rest
    (a smooth disk, no adhesion, beyond LJ_RANGE) by :func:`_flat_adhesion`: the values of
    :func:`adhesion_with_curvature` cell by cell, to round-off.
    """
    cache_d, cache_p, cache_dp, cache_d2p = cache
    for i in range(d_cells.size):
        d = d_cells[i]
        cache_d[i] = d
        s = sigma[i] if sigma[i] > 0.0 else eps  # a smooth disk's cells are taken again below
        cache_p[i], cache_dp[i], cache_d2p[i] = flat_adhesion_far(d, s, eps, adh_coef)
    near = np.empty(d_cells.size, dtype=np.int64)
    n_near = 0
    for i in range(d_cells.size):
        d, s = cache_d[i], sigma[i]
        if s <= 0.0 or (d - eps) / s < N_SIGMA or d - N_SIGMA * s > LJ_RANGE * eps:
            if s > 0.0 and (d - eps) / s >= TAU_NO_ADHESION and d - N_SIGMA * s <= LJ_RANGE * eps:
                near[n_near] = i
                n_near += 1
            else:
                cache_p[i], cache_dp[i], cache_d2p[i] = _flat_adhesion(d, s, eps, adh_coef, True)
    if n_near == 0:
        return
    d_near, s_near, out = _near_wall_at(cache_d, sigma, near[:n_near], eps, adh_coef, False, True)
    for k in range(n_near):
        i = near[k]
        d, s = d_near[k], s_near[k]
        tau = (d - eps) / s
        cache_p[i], cache_dp[i] = out[0, k], out[1, k]
        cache_d2p[i] = out[3, k] - 6.0 * adh_coef / eps * math.exp(-0.5 * tau * tau) / (s * _SQRT_2PI)


@njit(inline=True)
def asperity_adhesion_far(d: float, sigma: float, eps: float, adh_coef: float) -> tuple[float, float, float]:
    """E[p_LJ], E[p_LJ'] and E[W] by Gauss-Hermite (t >= N_SIGMA; :func:`_gap_expectations`' nodes) without
    branches or libm calls, so that a loop over cells vectorizes: the asperity law's sums."""
    p = slope = work = 0.0
    energy_coef = 0.125 * adh_coef * eps
    for k in range(_GH_NODES.size):
        h = d - sigma * _GH_NODES[k]
        inv_h = 1.0 / h
        u = eps * inv_h
        u2 = u * u
        u3 = u2 * u
        u9 = u3 * u3 * u3
        w = _GH_WEIGHTS[k]
        p += w * (adh_coef * (u9 - u3))
        slope += w * (adh_coef * (3.0 * u3 - 9.0 * u9) * inv_h)
        u4 = u2 * u2
        work += w * (energy_coef * (u4 * u4 - 4.0 * u2))
    return p, slope, work


@njit
def fill_asperity_adhesion(
    d_cells: np.ndarray, sigma: np.ndarray, eps: float, adh_coef: float, summit_coef: float, cache: tuple
) -> None:
    """The asperity law's adhesion with its curvature at every cell (separations ``d_cells``), into ``cache`` =
    (d, p_a, p_a', p_a'').

    As :func:`fill_flat_adhesion`: one vectorized Gauss-Hermite pass (:func:`asperity_adhesion_far`), the cells
    near the wall again by :func:`near_wall_expectations`, a smooth disk's and the fully compressed cells by
    :func:`_asperity_adhesion`; the compressed fraction Q(t) by ``math.erfc`` in a loop of its own.  The values of
    :func:`adhesion_with_curvature` cell by cell, to round-off.
    """
    cache_d, cache_p, cache_dp, cache_d2p = cache
    n = d_cells.size
    dgamma = 0.375 * adh_coef * eps
    work = np.empty(n)
    for i in range(n):
        d = d_cells[i]
        cache_d[i] = d
        s = sigma[i] if sigma[i] > 0.0 else eps  # a smooth disk's cells are taken again below
        cache_dp[i], cache_d2p[i], work[i] = asperity_adhesion_far(d, s, eps, adh_coef)
    near = np.empty(n, dtype=np.int64)
    n_near = 0
    for i in range(n):
        d, s = cache_d[i], sigma[i]
        if s <= 0.0 or (d - eps) / s < TAU_NO_ADHESION:
            cache_p[i], cache_dp[i], cache_d2p[i] = _asperity_adhesion(d, s, eps, adh_coef, summit_coef)
            continue
        tau = (d - eps) / s
        if tau < N_SIGMA:
            near[n_near] = i
            n_near += 1
        compressed = 0.5 * math.erfc(tau * _INV_SQRT2)  # fraction of summits past the wall
        cache_p[i] = summit_coef * (work[i] - dgamma * compressed)
        cache_dp[i], cache_d2p[i] = -summit_coef * cache_dp[i], -summit_coef * cache_d2p[i]
    if n_near == 0:
        return
    d_near, s_near, out = _near_wall_at(cache_d, sigma, near[:n_near], eps, adh_coef, True, False)
    for k in range(n_near):
        i = near[k]
        tau = (d_near[k] - eps) / s_near[k]
        compressed = 0.5 * math.erfc(tau * _INV_SQRT2)
        cache_p[i] = summit_coef * (out[2, k] - dgamma * compressed)
        cache_dp[i], cache_d2p[i] = -summit_coef * out[0, k], -summit_coef * out[1, k]


@njit
def fill_adhesion(
    d_cells: np.ndarray, sigma: np.ndarray, eps: float, adh_coef: float, law: int, summit_coef: float, cache: tuple
) -> None:
    """:func:`fill_flat_adhesion` or :func:`fill_asperity_adhesion` by the law code."""
    if law == ADHESION_ASPERITY:
        fill_asperity_adhesion(d_cells, sigma, eps, adh_coef, summit_coef, cache)
    else:
        fill_flat_adhesion(d_cells, sigma, eps, adh_coef, cache)


@njit
def refresh_adhesion(
    d_cells: np.ndarray, sigma: np.ndarray, eps: float, adh_coef: float, law: int, summit_coef: float, cache: tuple
) -> int:
    """Evaluate again, in one vectorized :func:`fill_adhesion` pass, the cached cells whose separation moved by more
    than CACHE_REACH max(sigma_i, eps) from the kept one (or is not finite); returns their number.

    A Newton iterate moves many cells at once past that reach (at the default scene's step, about a third of a
    step's solves): taken cell by cell by :func:`adhesion_with_curvature` they cost two to six times the
    vectorized pass, whose values equal it to round-off (``tests/test_adhesion.py``).
    """
    cache_d, cache_p, cache_dp, cache_d2p = cache
    n = d_cells.size
    stale = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        if not abs(d_cells[i] - cache_d[i]) <= CACHE_REACH * max(sigma[i], eps):
            stale[m] = i
            m += 1
    if m == 0:
        return 0
    d_sub, s_sub = np.empty(m), np.empty(m)
    for k in range(m):
        d_sub[k], s_sub[k] = d_cells[stale[k]], sigma[stale[k]]
    sub = (np.empty(m), np.empty(m), np.empty(m), np.empty(m))
    fill_adhesion(d_sub, s_sub, eps, adh_coef, law, summit_coef, sub)
    for k in range(m):
        i = stale[k]
        cache_d[i], cache_p[i], cache_dp[i], cache_d2p[i] = sub[0][k], sub[1][k], sub[2][k], sub[3][k]
    return m


@njit
def generalized_forces(
    offset: np.ndarray,
    sigma: np.ndarray,
    b: np.ndarray,
    area: np.ndarray,
    q: np.ndarray,
    eps: float,
    gw_coef: float,
    adh_coef: float,
    adhesion_law: int,
    summit_coef: float,
    mu: float,
    arm: np.ndarray,
    reach: float,
    reach_sigmas: float,
    f: np.ndarray,
    dfdq: np.ndarray,
    cache: tuple,
    mode: int,
) -> tuple[float, float, int]:
    """Generalized surface force f (3,) and its Jacobian dfdq (3, 3) at attitude q over k cells, in place.

    Cell i has the separation d_i = offset_i + b_i . q [m] (b_i (3,) = d d_i / dq), roughness sigma_i [m]
    and area A_i [m2]; with the Greenwood-Williamson contact p_c and adhesion p_a (:func:`contact_pressure`,
    :func:`adhesion_by_law` by ``adhesion_law``, ``summit_coef`` = 2 pi R eta_s) and Coulomb friction mu p_c
    acting through the lever ``arm`` (3,),

        f = sum_i A_i (p_c + p_a) b_i + mu (sum_i A_i p_c) arm,
        dfdq = sum_i A_i (p_c' + p_a') b_i b_i^T + mu arm (sum_i A_i p_c' b_i)^T.

    Returns the contact and adhesion forces [N] and the number of cells within reach
    (d_i < reach + reach_sigmas sigma_i).

    ``cache`` = (d, p_a, p_a', p_a'') (k,) each, with ``mode``: CACHE_FILL evaluates the adhesion with its
    curvature (:func:`adhesion_with_curvature`) and keeps it; CACHE_USE takes p_a and p_a' of a cell whose
    separation moved by at most CACHE_REACH max(sigma_i, eps) from the kept one from their Taylor expansion
    (relative error below CACHE_REACH^3 / 6 of the pressure's own scale); the others are evaluated again, all in
    one vectorized pass (:func:`refresh_adhesion`), and kept.  CACHE_OFF evaluates every cell cell by cell.  The
    adhesion quadrature, most of the cost, is then paid about once per step.
    """
    cache_d, cache_p, cache_dp, cache_d2p = cache
    q0, q1, q2 = q[0], q[1], q[2]
    n = offset.size
    seps, pcs, dpcs = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        seps[i] = offset[i] + b[0, i] * q0 + b[1, i] * q1 + b[2, i] * q2
    if mode == CACHE_FILL:
        fill_adhesion(seps, sigma, eps, adh_coef, adhesion_law, summit_coef, cache)
    elif mode == CACHE_USE:
        refresh_adhesion(seps, sigma, eps, adh_coef, adhesion_law, summit_coef, cache)
    f0 = f1 = f2 = 0.0  # scalar accumulators: f, the upper triangle of the symmetric part, the friction row
    j00 = j01 = j02 = j11 = j12 = j22 = 0.0
    w0 = w1 = w2 = 0.0
    contact = 0.0
    adhesion = 0.0
    in_reach = 0
    fill_contact_pressures(seps, sigma, eps, gw_coef, pcs, dpcs)  # vectorized: the loop below has branches
    for i in range(n):
        b0, b1, b2 = b[0, i], b[1, i], b[2, i]
        d = seps[i]
        s = sigma[i]
        pc, dpc = pcs[i], dpcs[i]
        if mode == CACHE_OFF:
            pa, dpa = adhesion_by_law(d, s, eps, adh_coef, adhesion_law, summit_coef)
        else:  # every cell within reach of its kept values (filled or refreshed above): their Taylor expansion
            delta = d - cache_d[i]
            dpa = cache_dp[i] + delta * cache_d2p[i]
            pa = cache_p[i] + delta * (cache_dp[i] + 0.5 * delta * cache_d2p[i])
        fc = pc * area[i]
        fa = pa * area[i]
        w = dpc * area[i]
        wn = w + dpa * area[i]
        contact += fc
        adhesion += fa
        if d < reach + reach_sigmas * s:
            in_reach += 1
        fn = fc + fa
        f0 += fn * b0
        f1 += fn * b1
        f2 += fn * b2
        w0 += w * b0
        w1 += w * b1
        w2 += w * b2
        j00 += wn * b0 * b0
        j01 += wn * b0 * b1
        j02 += wn * b0 * b2
        j11 += wn * b1 * b1
        j12 += wn * b1 * b2
        j22 += wn * b2 * b2
    f[0], f[1], f[2] = f0, f1, f2
    dfdq[0, 0], dfdq[0, 1], dfdq[0, 2] = j00, j01, j02
    dfdq[1, 0], dfdq[1, 1], dfdq[1, 2] = j01, j11, j12
    dfdq[2, 0], dfdq[2, 1], dfdq[2, 2] = j02, j12, j22
    friction = (w0, w1, w2)
    for r in range(3):
        f[r] += mu * contact * arm[r]
        for c in range(3):
            dfdq[r, c] += mu * arm[r] * friction[c]
    return contact, adhesion, in_reach


@njit
def contact_curvature(d: float, sigma: float, eps: float, gw_coef: float) -> float:
    """d^2 p_c / dd^2 [Pa/m^2] of the Greenwood-Williamson law: exact on a smooth disk, else central differences.

    The rough law's slope is smooth in d (:func:`gw_integrals`); its differences over 1e-4 sigma are
    accurate to about 1e-8 relative, far below what Newton's method needs of a Jacobian.
    """
    if sigma > 0.0:
        step = 1e-4 * sigma
        return (
            contact_pressure(d + step, sigma, eps, gw_coef)[1] - contact_pressure(d - step, sigma, eps, gw_coef)[1]
        ) / (2.0 * step)
    if d < eps:
        return 0.75 * gw_coef / math.sqrt(eps - d)
    return 0.0


@njit
def contact_damping(
    offset: np.ndarray,
    sigma: np.ndarray,
    b: np.ndarray,
    area: np.ndarray,
    q: np.ndarray,
    v: np.ndarray,
    disk_rate: np.ndarray,
    eps: float,
    gw_coef: float,
    m_inv: np.ndarray,
    zeta: float,
    mu: float,
    arm: np.ndarray,
    f: np.ndarray,
    dfdq: np.ndarray,
    damping: np.ndarray,
) -> float:
    """Add the contact damping's force to f (3,) and its d/dq to dfdq (3, 3), write -df/dv; return its normal force.

    Every cell is a Kelvin-Voigt element whose coefficient is proportional to its Greenwood-Williamson
    stiffness k_i = -dp_c/dd (per area) at the cell's separation d_i = offset_i + b_i . q,

        c_i = 2 zeta k_i / omega_c,   omega_c^2 = sum_i A_i k_i b_i^T M^-1 b_i   (``m_inv`` = M^-1),

    so that a contact on one patch (effective mass m*_i = 1 / b_i^T M^-1 b_i) has the damping ratio
    zeta exactly, c = 2 zeta sqrt(k m*); a contact spread over the face is damped in proportion to its
    stiffness, mode j with zeta omega_j / omega_c, the stiffest at least zeta / sqrt(3).  The damping acts
    on the spacing rate relative to the resolved disk surface, r_i = b_i . v - ``disk_rate``_i, as the
    pressure p_d = -c_i r_i, part of the normal force on which Coulomb friction acts (mu, lever ``arm`` as
    in :func:`generalized_forces`; l_i = b_i + mu arm).  A contact cannot pull: where a separating cell's
    p_c + p_d would be negative, p_d = -p_c (the cell's contact pressure is zero; adhesion is its own law).
    With F the free cells' and Z the clamped ones,

        F_d = -sum_F A_i c_i r_i - sum_Z A_i p_c,i,   f_d = -sum_F A_i c_i r_i l_i - sum_Z A_i p_c,i l_i,
        damping = -df_d/dv = sum_F A_i c_i l_i b_i^T,
        df_d/dq = -(2 zeta / omega_c) sum_F A_i k_i' r_i l_i b_i^T - f_F u^T / (2 omega_c^2)
                  - sum_Z A_i p_c,i' l_i b_i^T,

    with f_F the free cells' part of f_d, k_i' = dk_i/dd (:func:`contact_curvature`) and
    u = d omega_c^2 / dq = sum_i A_i k_i' g_i b_i.  No contact (omega_c^2 <= CONTACT_OMEGA2_FLOOR): no force, a
    zero matrix.
    """
    for r in range(3):
        for c in range(3):
            damping[r, c] = 0.0
    omega2 = 0.0
    u0 = u1 = u2 = 0.0
    n = offset.size
    pcs, dpcs, curvatures = np.zeros(n), np.zeros(n), np.zeros(n)  # p_c, dp_c/dd, d^2p_c/dd^2 of every cell
    for i in range(n):
        b0, b1, b2 = b[0, i], b[1, i], b[2, i]
        d = offset[i] + b0 * q[0] + b1 * q[1] + b2 * q[2]
        pcs[i], dpcs[i] = contact_pressure(d, sigma[i], eps, gw_coef)
        if dpcs[i] == 0.0:
            continue
        curvatures[i] = contact_curvature(d, sigma[i], eps, gw_coef)
        g = 0.0
        for r in range(3):
            g += b[r, i] * (m_inv[r, 0] * b0 + m_inv[r, 1] * b1 + m_inv[r, 2] * b2)
        omega2 += -dpcs[i] * area[i] * g
        kg = -curvatures[i] * area[i] * g
        u0 += kg * b0
        u1 += kg * b1
        u2 += kg * b2
    if omega2 <= CONTACT_OMEGA2_FLOOR:
        return 0.0
    scale = 2.0 * zeta / math.sqrt(omega2)
    normal = 0.0
    free = np.zeros(3)  # the free cells' damping force
    for i in range(n):
        pc, dpc = pcs[i], dpcs[i]
        if dpc == 0.0:
            continue
        b0, b1, b2 = b[0, i], b[1, i], b[2, i]
        w = -dpc * area[i] * scale  # A_i c_i [N s / m]
        rate = b0 * v[0] + b1 * v[1] + b2 * v[2] - disk_rate[i]
        fn = -w * rate
        if pc * area[i] + fn < 0.0:  # a separating cell would pull: its contact force is zero
            fn = -pc * area[i]
            normal += fn
            for r in range(3):
                lever = b[r, i] + mu * arm[r]
                f[r] += fn * lever
                for c in range(3):
                    dfdq[r, c] -= dpc * area[i] * lever * b[c, i]
            continue
        w_d = -curvatures[i] * area[i] * scale  # d(A_i c_i)/dd_i, scale held
        normal += fn
        for r in range(3):
            lever = b[r, i] + mu * arm[r]
            free[r] += fn * lever
            for c in range(3):
                damping[r, c] += w * lever * b[c, i]
                dfdq[r, c] -= w_d * rate * lever * b[c, i]
    u = (u0, u1, u2)
    for r in range(3):
        f[r] += free[r]
        for c in range(3):
            dfdq[r, c] -= free[r] * u[c] / (2.0 * omega2)
    return normal


@njit
def near_cells(
    surface: np.ndarray,
    disk: np.ndarray,
    sigma: np.ndarray,
    b: np.ndarray,
    q: np.ndarray,
    reach: float,
    reach_sigmas: float,
    margin: float,
    index: np.ndarray,
) -> int:
    """The cells i with surface_i - disk_i + b_i . q < reach + reach_sigmas sigma_i + margin, in order, into ``index``.

    surface, disk, sigma : (n,) [m]; b : (3, n); q : (3,); index : (n,) int, filled from the start.
    Returns their number.
    """
    count = 0
    for i in range(surface.size):
        d = surface[i] - disk[i] + b[0, i] * q[0] + b[1, i] * q[1] + b[2, i] * q[2]
        if d < reach + reach_sigmas * sigma[i] + margin:
            index[count] = i
            count += 1
    return count


@njit
def candidate_cells(
    surface: np.ndarray, disk: np.ndarray, sigma: np.ndarray, b: np.ndarray, area: np.ndarray, q: np.ndarray,
    reach: float, reach_sigmas: float, margin: float, index: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """:func:`near_cells` and the cells' data in one call: (index, surface - disk, sigma, b (3, k), area) of them,
    new arrays (``index`` (n,) int is scratch)."""
    count = near_cells(surface, disk, sigma, b, q, reach, reach_sigmas, margin, index)
    near = index[:count].copy()
    base, s, bn, an = np.empty(count), np.empty(count), np.empty((3, count)), np.empty(count)
    for k in range(count):
        i = near[k]
        base[k] = surface[i] - disk[i]
        s[k] = sigma[i]
        bn[0, k], bn[1, k], bn[2, k] = b[0, i], b[1, i], b[2, i]
        an[k] = area[i]
    return near, base, s, bn, an
