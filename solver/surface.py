"""Pressures between the slider face and a rough disk: asperity contact and adhesion.

Sign convention: a positive pressure pushes the slider away from the disk
(repulsion); adhesion is negative.  Per cell of the slider face the inputs
are the separation d [m] from the local mean plane of the disk and the local
RMS roughness sigma [m] of the disk about that plane (0 for a smooth disk).

Contact laws (``CONTACT_LAWS``)
-------------------------------
``greenwood_williamson``: summit heights Gaussian with standard deviation
sigma about the mean plane, summit density eta_s [1/m^2], summit radius R
[m]; a repulsive wall at the intermolecular spacing eps [m] means a summit
of height z is compressed by delta = z - (d - eps) > 0, and Hertz
(P = (4/3) E' sqrt(R) delta^(3/2) per summit) gives

    p_c(d) = gw_coef sigma^(3/2) F_{3/2}((d - eps) / sigma),   gw_coef = (4/3) eta_s E' sqrt(R),
    F_n(t) = int_t^inf (s - t)^n phi(s) ds,   dF_{3/2}/dt = -(3/2) F_{1/2},

and for sigma = 0, p_c = gw_coef max(eps - d, 0)^(3/2).

``elastic``: the slider pressed on an elastic half-space, influence
coefficients and a linear complementarity problem (``solver.elastic``).

Adhesion (modified intermolecular-force model): the Lennard-Jones flat-flat
law

    p_LJ(h) = (8 dgamma / (3 eps)) [(eps/h)^9 - (eps/h)^3]

(zero at h = eps, work int_eps^inf p_LJ dh = -dgamma) acts on the part of the
disk farther than eps from the slider:

    p_a(d) = int_-inf^(d - eps) p_LJ(d - z) phi_sigma(z) dz <= 0,

which is p_LJ(d) for d >= eps (else 0) on a smooth disk.  On a smooth disk
p_c + p_a therefore vanishes exactly at d = eps.  Coulomb friction, mu p_c,
is left to the caller.

Adhesion laws (``ADHESION_LAWS``, ``models.adhesion`` of a scene)
------------------------------------------------------------------
``flat``: the law above, on the nominal area of the cell.

``asperity_dmt``: the Greenwood-Williamson summits of the contact law each
pull like a DMT sphere: 2 pi R W(g) at the gap g > eps (Derjaguin, with
W(g) = int_g^inf p_LJ the flat law's energy per area, W(eps) = -dgamma) and
the pull-off -2 pi R dgamma once compressed past eps, so

    p_a(d) = 2 pi R eta_s [-dgamma P(z > d - eps) + E[W(d - z); d - z > eps]],
    dp_a/dd = -2 pi R eta_s p_a^flat(d),

bounded by -2 pi R eta_s dgamma at contact and falling like d^-2 far away.
Both are proportional to dgamma.  The derivation and the choice of DMT are
in ``solver.kernels.surface``.

The numerics (tables, quadratures, accuracy) are in ``solver.kernels.surface``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .kernels import surface as kernels

CONTACT_LAWS = ("greenwood_williamson", "elastic")
#: Adhesion laws by name: the kernels' law codes.
ADHESION_LAWS = {"flat": kernels.ADHESION_FLAT, "asperity_dmt": kernels.ADHESION_ASPERITY}


class SurfacePressures(NamedTuple):
    """Pressures per cell [Pa] and their slopes with respect to the separation d [Pa/m]."""

    contact: np.ndarray
    contact_slope: np.ndarray
    adhesion: np.ndarray
    adhesion_slope: np.ndarray


def composite_modulus(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """Composite (contact) modulus E' [Pa]: 1/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2.

    This is Johnson's E*: a sphere of radius R pressed by delta carries the
    Hertz load P = (4/3) E' sqrt(R) delta^(3/2), and a pressure p on the
    surface moves the two surfaces together by w = (1/(pi E')) int p / r dA.
    """
    return 1.0 / ((1.0 - nu1**2) / e1 + (1.0 - nu2**2) / e2)


def gw_coefficient(summit_density: float, summit_radius: float, e_composite: float) -> float:
    """Greenwood-Williamson coefficient (4/3) eta_s E' sqrt(R) [Pa/m^(3/2)].

    Parameters
    ----------
    summit_density : float [1/m^2]
    summit_radius : float [m]
    e_composite : float [Pa], see ``composite_modulus``
    """
    return 4.0 / 3.0 * summit_density * e_composite * np.sqrt(summit_radius)


def adhesion_coefficient(dgamma: float, eps: float) -> float:
    """Amplitude 8 dgamma / (3 eps) [Pa] of the flat-flat Lennard-Jones law."""
    return 8.0 * dgamma / (3.0 * eps)


def summit_coefficient(summit_density: float, summit_radius: float) -> float:
    """Pull-off pressure per unit dgamma of a fully compressed summit population, 2 pi R eta_s [1/m]."""
    return 2.0 * np.pi * summit_radius * summit_density


def lj_pressure(h: ArrayLike, dgamma: float, eps: float) -> np.ndarray:
    """Flat-flat Lennard-Jones pressure (8 dgamma / (3 eps)) [(eps/h)^9 - (eps/h)^3] [Pa] at gaps h [m]."""
    u = eps / np.asarray(h, dtype=float)
    return adhesion_coefficient(dgamma, eps) * (u**9 - u**3)


def gw_integrals(t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Standardized Greenwood-Williamson integrals F_{3/2}(t), F_{1/2}(t) (relative error < 1e-13)."""
    t = np.asarray(t, dtype=float)
    f32 = np.empty(t.shape)
    f12 = np.empty(t.shape)
    for index, value in np.ndenumerate(t):
        f32[index], f12[index] = kernels.gw_integrals(float(value))
    return f32, f12


def surface_pressures(
    d: ArrayLike,
    sigma: ArrayLike,
    *,
    eps: float,
    gw_coef: float,
    dgamma: float,
    adhesion: str = "flat",
    summit_coef: float = 0.0,
    out: np.ndarray | None = None,
) -> SurfacePressures:
    """Greenwood-Williamson contact and adhesion pressures of n cells, with slopes d/dd.

    Parameters
    ----------
    d : array (n,) [m]
        separation between the slider face and the local mean plane of the disk.
    sigma : array (n,) or float [m]
        local RMS roughness of the disk (>= 0; 0 is a smooth disk).
    eps : float [m]
        intermolecular equilibrium spacing (repulsive wall of the contact, zero of the adhesion law).
    gw_coef : float [Pa/m^(3/2)]
        (4/3) eta_s E' sqrt(R), see ``gw_coefficient``.
    dgamma : float [J/m^2]
        surface-energy change; the adhesion work per unit area.
    adhesion : str
        adhesion law, a key of ``ADHESION_LAWS``.
    summit_coef : float [1/m]
        2 pi R eta_s, see ``summit_coefficient`` (law ``asperity_dmt``).
    out : array (4, n), optional
        storage for the result (no allocation in a time loop).

    Returns
    -------
    SurfacePressures of arrays (n,): p_c >= 0, dp_c/dd, p_a <= 0, dp_a/dd (rows of ``out``).
    """
    d = np.ascontiguousarray(d, dtype=float).reshape(-1)
    sigma = np.ascontiguousarray(np.broadcast_to(np.asarray(sigma, dtype=float), d.shape))
    if np.any(sigma < 0.0):
        raise ValueError("sigma must be >= 0")
    if eps <= 0.0:
        raise ValueError(f"eps must be > 0, got {eps}")
    if adhesion not in ADHESION_LAWS:
        raise ValueError(f"adhesion = {adhesion!r} is not a law: one of {', '.join(map(repr, ADHESION_LAWS))}")
    if out is None:
        out = np.empty((4, d.size))
    elif out.shape != (4, d.size) or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous float64 array of shape (4, {d.size})")
    adh_coef = adhesion_coefficient(dgamma, eps)
    kernels.surface_pressures(d, sigma, eps, gw_coef, adh_coef, ADHESION_LAWS[adhesion], summit_coef, out)
    return SurfacePressures(out[0], out[1], out[2], out[3])
