"""Poiseuille flow factors of the slip laws, evaluated on every cell face.

The generalized compressible Reynolds equation carries the pressure-driven
(Poiseuille) flux as

    d/dX( Dcoef dP/dX ),   Dcoef(P, H) = H^3 P phi(P, H),

in the scaled variables P = p/p0, H = h/h_ref, where phi = 1 is the
continuum (no-slip) law and phi > 1 accounts for gas rarefaction.  With the
ambient mean free path lambda0 and kn = lambda0/h_ref, the local Knudsen
number and the inverse Knudsen number of Fukui and Kaneko are

    Kn = lambda/h = kn/(P H),    D = (sqrt(pi)/2) P H / kn = (sqrt(pi)/2) / Kn.

Laws (``code``, index into :data:`SLIP_NAMES`):

* ``CONTINUUM`` (0):     phi = 1.
* ``FIRST_ORDER`` (1):   phi = 1 + 6 Kn                      (Burgdorfer 1959).
* ``SECOND_ORDER`` (2):  phi = 1 + 6 Kn + 6 Kn^2             (Hsia & Domoto 1983).
* ``FUKUI_KANEKO`` (3):  phi = Q_P(D) / Q_con(D) = 6 Q_P(D) / D
  (Fukui & Kaneko 1988, 1990), with Q_P from :func:`fk_flow_rate`, for
  films h = H h_ref >= h_switch.  In thinner films the bounded law of Wu &
  Bogy replaces it: the second-order factor phi_2 = 1 + 6 Kn + 6 Kn^2,
  scaled at the same pressure so that phi is continuous at h = h_switch,

      phi(P, H) = phi_FK(P, H_s) * phi_2(P, H) / phi_2(P, H_s),   H_s = h_switch/h_ref,

  so that Dcoef = H^3 P phi = c(P) (H^3 P + 6 kn H^2 + 6 kn^2 H / P) with
  c(P) = phi_FK(P, H_s)/phi_2(P, H_s): bounded, increasing in H and
  vanishing linearly as h -> 0 at fixed P.

Fukui-Kaneko Poiseuille flow rate: the widely used piecewise fit of the
Fukui-Kaneko database (linearized BGK equation, diffuse walls), with
Q_con = D/6 its continuum value:

    D >= 5:            Q = D/6 + 1.0162 + 1.0653/D - 2.1354/D^2
    0.15 <= D < 5:     Q = 0.13852 D + 1.25087 + 0.15653/D - 0.00969/D^2
    0.01 <= D < 0.15:  Q = -2.22919 D + 2.10673 + 0.01653/D - 0.0000694/D^2
    D < 0.01:          Q = Q(0.01) - ln(D/0.01)/sqrt(pi)

The last line is our continuation: the exact free-molecular asymptote of
the BGK flow rate, Q ~ -ln(D)/sqrt(pi), shifted to be continuous at 0.01
(extrapolated, the low-D polynomial peaks at D = 0.0083 and turns negative
below D = 0.003).  It stays
within 2 % of the linearized BGK solution down to D = 1e-8.  The
published fit is only piecewise continuous: Q jumps by +0.27 % at D = 0.15
and +0.14 % at D = 5 (``tests/test_slip.py`` measures them).

Every function returns phi and dphi/dP at fixed H (the Jacobian needs
dDcoef/dP = H^3 (phi + P dphi/dP)).  Written in x = 1/D, each piece is a
polynomial (phi = 6 Q x), so the continuum limit x -> 0 (kn = 0 included)
is exact and free of inf/inf.  P and H below ``TINY`` (zero and negative
included) are raised to ``TINY``: phi stays finite, and Dcoef = H^3 P phi -> 0.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from .elementary import log_positive

CONTINUUM = 0
FIRST_ORDER = 1
SECOND_ORDER = 2
FUKUI_KANEKO = 3
#: Names of the slip laws, indexed by their integer code.
SLIP_NAMES = ("continuum", "first_order", "second_order", "fukui_kaneko")

#: Floor for P, H and D: keeps phi finite at zero or negative arguments.
TINY = 1.0e-30
SQRT_PI = math.sqrt(math.pi)
INV_SQRT_PI = 1.0 / SQRT_PI
HALF_SQRT_PI = 0.5 * SQRT_PI

#: Breakpoints of the Fukui-Kaneko fit in the inverse Knudsen number.
FK_D_HIGH = 5.0
FK_D_MID = 0.15
FK_D_LOW = 0.01
# Q = A D + B + C/D + E/D^2 on each piece (high: A = 1/6).
FK_HIGH = (1.0 / 6.0, 1.0162, 1.0653, -2.1354)
FK_MID = (0.13852, 1.25087, 0.15653, -0.00969)
FK_LOW = (-2.22919, 2.10673, 0.01653, -0.0000694)
#: ln FK_D_LOW: the free-molecular piece's ln(x FK_D_LOW) is ln x + LN_FK_D_LOW.
LN_FK_D_LOW = math.log(FK_D_LOW)
#: Q at D = 0.01 (low piece), where the free-molecular continuation starts.
FK_Q_LOW = FK_LOW[0] * FK_D_LOW + FK_LOW[1] + FK_LOW[2] / FK_D_LOW + FK_LOW[3] / FK_D_LOW**2


def _piece(coefs: tuple[float, float, float, float], D: float) -> float:
    a, b, c, e = coefs
    return a * D + b + c / D + e / (D * D)


# The published fit jumps by +0.27 % at D = 0.15 and +0.14 % at D = 5.  A jump in the flux coefficient
# stalls Newton's method on the steady film at the jump's size, so the middle piece carries a correction
# a + b ln D that closes both gaps (at most 0.27 %, inside the fit's own 1 % accuracy): Q is continuous.
_JUMP_LOW = _piece(FK_LOW, FK_D_MID) - _piece(FK_MID, FK_D_MID)
_JUMP_HIGH = _piece(FK_HIGH, FK_D_HIGH) - _piece(FK_MID, FK_D_HIGH)
FK_GLUE_B = (_JUMP_HIGH - _JUMP_LOW) / math.log(FK_D_HIGH / FK_D_MID)
FK_GLUE_A = _JUMP_LOW - FK_GLUE_B * math.log(FK_D_MID)


@njit
def fk_flow_rate(D: float) -> tuple[float, float]:
    """Fukui-Kaneko Poiseuille flow rate Q_P(D) and dQ_P/dD (piecewise fit, module docstring)."""
    D = max(D, TINY)
    if D >= FK_D_HIGH:
        a, b, c, e = FK_HIGH
    elif D >= FK_D_MID:
        a, b, c, e = FK_MID
        x = 1.0 / D
        glue = FK_GLUE_A + FK_GLUE_B * math.log(D)
        return a * D + b + x * (c + x * e) + glue, a - x * x * (c + 2.0 * e * x) + FK_GLUE_B * x
    elif D >= FK_D_LOW:
        a, b, c, e = FK_LOW
    else:
        return FK_Q_LOW - math.log(D / FK_D_LOW) * INV_SQRT_PI, -INV_SQRT_PI / D
    x = 1.0 / D
    return a * D + b + x * (c + x * e), a - x * x * (c + 2.0 * e * x)


@njit
def fk_factor(P: float, H: float, kn: float) -> tuple[float, float]:
    """phi = 6 Q_P(D)/D and dphi/dP of the Fukui-Kaneko law, D = (sqrt(pi)/2) P H / kn.

    With x = 1/D and Q = a D + b + c x + e x^2: phi = 6 (a + x (b + x (c + x e)))
    and, since dx/dP = -x/P, dphi/dP = -(6 x / P) (b + x (2 c + 3 e x)).
    """
    P = max(P, TINY)
    x = kn / (HALF_SQRT_PI * P * max(H, TINY))
    if x <= 1.0 / FK_D_HIGH:
        a, b, c, e = FK_HIGH
    elif x <= 1.0 / FK_D_MID:
        a, b, c, e = FK_MID
        glue = FK_GLUE_A - FK_GLUE_B * math.log(x)  # the continuity correction of fk_flow_rate
        return (
            6.0 * (a + x * (b + glue + x * (c + x * e))),
            -6.0 * x * (b + glue - FK_GLUE_B + x * (2.0 * c + 3.0 * e * x)) / P,
        )
    elif x <= 1.0 / FK_D_LOW:
        a, b, c, e = FK_LOW
    else:
        q = FK_Q_LOW + math.log(x * FK_D_LOW) * INV_SQRT_PI
        return 6.0 * q * x, -6.0 * x * (q + INV_SQRT_PI) / P
    return 6.0 * (a + x * (b + x * (c + x * e))), -6.0 * x * (b + x * (2.0 * c + 3.0 * e * x)) / P


@njit(inline=True)
def fk_factor_vectorizable(P: float, H: float, kn: float) -> tuple[float, float]:
    """:func:`fk_factor` without branches or libm calls, so that a loop over faces vectorizes.

    Every piece's coefficients are selected rather than branched to, and ln x, which the middle piece's
    continuity correction and the free-molecular piece need, comes from
    :func:`solver.kernels.elementary.log_positive` on every face.  Within a few ulp of :func:`fk_factor`
    (``tests/test_elementary.py``).
    """
    P = max(P, TINY)
    H = max(H, TINY)
    x = kn / (HALF_SQRT_PI * P * H)
    inv_p = x * (HALF_SQRT_PI * H) / kn
    log_x = log_positive(x)
    high = x <= 1.0 / FK_D_HIGH
    mid = x <= 1.0 / FK_D_MID and not high
    polynomial = x <= 1.0 / FK_D_LOW
    a = FK_HIGH[0] if high else (FK_MID[0] if mid else FK_LOW[0])
    b = FK_HIGH[1] if high else (FK_MID[1] if mid else FK_LOW[1])
    c = FK_HIGH[2] if high else (FK_MID[2] if mid else FK_LOW[2])
    e = FK_HIGH[3] if high else (FK_MID[3] if mid else FK_LOW[3])
    glue = FK_GLUE_A - FK_GLUE_B * log_x if mid else 0.0
    glue_slope = FK_GLUE_B if mid else 0.0
    phi = 6.0 * (a + x * (b + glue + x * (c + x * e)))
    dphi = -6.0 * x * (b + glue - glue_slope + x * (2.0 * c + 3.0 * e * x)) * inv_p
    q = FK_Q_LOW + (log_x + LN_FK_D_LOW) * INV_SQRT_PI  # the free-molecular continuation, x > 1 / FK_D_LOW
    return (phi if polynomial else 6.0 * q * x), (dphi if polynomial else -6.0 * x * (q + INV_SQRT_PI) * inv_p)


@njit
def second_order_factor(P: float, H: float, kn: float) -> tuple[float, float]:
    """phi = 1 + 6 Kn + 6 Kn^2 and dphi/dP, Kn = kn/(P H) (Hsia-Domoto)."""
    P = max(P, TINY)
    knudsen = kn / (P * max(H, TINY))
    return 1.0 + 6.0 * knudsen * (1.0 + knudsen), -6.0 * knudsen * (1.0 + 2.0 * knudsen) / P


@njit
def flow_factor(code: int, P: float, H: float, kn: float, h_ref: float, h_switch: float) -> tuple[float, float]:
    """Poiseuille flow factor phi(P, H) and dphi/dP at fixed H for slip law ``code``.

    Parameters
    ----------
    code : int
        Slip law, index into :data:`SLIP_NAMES`.
    P, H : float
        Scaled pressure p/p0 and spacing h/h_ref at the face [-].
    kn : float
        lambda0 / h_ref, ambient mean free path over the spacing scale [-].
    h_ref : float
        Spacing scale [m].
    h_switch : float
        Films thinner than this use the bounded second-order law (``FUKUI_KANEKO`` only) [m].

    Returns
    -------
    phi, dphi_dP : float
        The face diffusion coefficient is H^3 P phi; its P-derivative is H^3 (phi + P dphi_dP).
    """
    if code == FIRST_ORDER:
        P = max(P, TINY)
        slip = 6.0 * kn / (P * max(H, TINY))
        return 1.0 + slip, -slip / P
    if code == SECOND_ORDER:
        return second_order_factor(P, H, kn)
    if code == FUKUI_KANEKO:
        if H * h_ref >= h_switch:
            return fk_factor(P, H, kn)
        h_s = h_switch / h_ref
        phi_s, dphi_s = fk_factor(P, h_s, kn)
        phi2, dphi2 = second_order_factor(P, H, kn)
        phi2_s, dphi2_s = second_order_factor(P, h_s, kn)
        phi = phi_s * phi2 / phi2_s
        return phi, phi * (dphi_s / phi_s + dphi2 / phi2 - dphi2_s / phi2_s)
    return 1.0, 0.0


@njit
def fk_flow_rate_array(D: np.ndarray, Q: np.ndarray, dQ: np.ndarray) -> None:
    """:func:`fk_flow_rate` over flat arrays: fills Q and dQ (same length as D)."""
    for i in range(D.size):
        Q[i], dQ[i] = fk_flow_rate(D[i])


@njit
def flow_factor_array(
    code: int,
    P: np.ndarray,
    H: np.ndarray,
    kn: float,
    h_ref: float,
    h_switch: float,
    phi: np.ndarray,
    dphi_dP: np.ndarray,
) -> None:
    """:func:`flow_factor` over flat arrays of equal length: fills phi and dphi_dP."""
    for i in range(P.size):
        phi[i], dphi_dP[i] = flow_factor(code, P[i], H[i], kn, h_ref, h_switch)
