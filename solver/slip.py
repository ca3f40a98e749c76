"""Gas-rarefaction (slip) laws of the generalized Reynolds equation: names, codes and array wrappers.

The Poiseuille (pressure-driven) flux of the compressible Reynolds equation
with rarefaction is

    d/dx( Qp * p h^3 dp/dx ) + ...,   Qp = phi = Q_P(D) / Q_con(D),   Q_con = D/6,

with the inverse Knudsen number (lambda0: mean free path at the ambient p0)

    D = (sqrt(pi)/2) p h / (p0 lambda0) = (sqrt(pi)/2) / Kn,   Kn = lambda0 p0 / (p h).

Slip laws, chosen by name (:data:`SLIP_LAWS`); the maths, the
Fukui-Kaneko fit and its continuation below D = 0.01 are in
:mod:`solver.kernels.slip`:

``continuum``      phi = 1 (no slip).
``first_order``    phi = 1 + 6 Kn (Maxwell slip; Burgdorfer 1959).
``second_order``   phi = 1 + 6 Kn + 6 Kn^2 (Hsia & Domoto 1983).
``fukui_kaneko``   phi = 6 Q_P(D)/D from the linearized-Boltzmann (BGK)
                   database of Fukui & Kaneko; below the film thickness
                   h_switch, the second-order factor scaled to be continuous
                   at h_switch, so that the flux coefficient p h^3 phi stays
                   bounded and vanishes as h -> 0 (Wu & Bogy).

References
----------
Burgdorfer, A. (1959). The influence of the molecular mean free path on the
    performance of hydrodynamic gas lubricated bearings. J. Basic Eng. 81, 94-100.
Hsia, Y.-T., Domoto, G. A. (1983). An experimental investigation of molecular
    rarefaction effects in gas lubricated bearings at ultra-low clearances.
    J. Lubr. Technol. 105, 120-130.
Fukui, S., Kaneko, R. (1988). Analysis of ultra-thin gas film lubrication
    based on linearized Boltzmann equation: first report. J. Tribol. 110, 253-262.
Fukui, S., Kaneko, R. (1990). A database for interpolation of Poiseuille flow
    rates for high Knudsen number lubrication problems. J. Tribol. 112, 78-83.
Wu, L., Bogy, D. B. Bounded slip law for near-contact films in the CML
    (UC Berkeley) air-bearing solvers; the exact form used here is stated in
    :mod:`solver.kernels.slip` (the original paper was not available to check it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SlipLaw:
    """A slip law: its integer code in the kernels, and the coefficients (c1, c2) of its polynomial flow
    factor D = H^3 P + c1 Kn H^2 + c2 Kn^2 H / P where it has one (the rails film uses that form; the
    Fukui-Kaneko law has none and runs on the "abs" film only)."""

    code: int
    coefficients: tuple[float, float] | None


#: The slip laws by name: the one registry (each kind's parameters offer the laws its film can run). The codes
#: are the kernels' (:data:`solver.kernels.slip.SLIP_NAMES`, checked by a test); the kernels are imported only
#: where an array is evaluated, so that reading parameters does not load numba.
SLIP_LAWS: dict[str, SlipLaw] = {
    "continuum": SlipLaw(0, (0.0, 0.0)),
    "first_order": SlipLaw(1, (6.0, 0.0)),
    "second_order": SlipLaw(2, (6.0, 6.0)),
    "fukui_kaneko": SlipLaw(3, None),
}
#: Names of the laws with a polynomial flow factor.
POLYNOMIAL_SLIP_LAWS = tuple(name for name, law in SLIP_LAWS.items() if law.coefficients is not None)

#: Spacing scale of the physical-unit wrapper [m]; phi does not depend on it.
_H_REF = 1.0e-9


def slip_code(name: str) -> int:
    """Integer code of the slip law ``name``; ValueError naming the allowed names if unknown."""
    try:
        return SLIP_LAWS[name].code
    except (KeyError, TypeError):
        raise ValueError(f"unknown slip law {name!r}; allowed: {', '.join(SLIP_LAWS)}") from None


def inverse_knudsen(p: np.ndarray | float, h: np.ndarray | float, p0: float, mean_free_path: float) -> np.ndarray:
    """Inverse Knudsen number D = (sqrt(pi)/2) p h / (p0 lambda0) [-].

    Parameters
    ----------
    p : array_like [Pa]
        Local pressure.
    h : array_like [m]
        Local spacing.
    p0 : float [Pa]
        Ambient pressure, at which the mean free path is ``mean_free_path``.
    mean_free_path : float [m]
        Mean free path lambda0 of the gas at p0.
    """
    return 0.5 * np.sqrt(np.pi) * np.asarray(p, dtype=float) * np.asarray(h, dtype=float) / (p0 * mean_free_path)


def poiseuille_flow_rate(
    D: np.ndarray | float, *, with_derivative: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Fukui-Kaneko Poiseuille flow rate Q_P(D) [-] (and dQ_P/dD with ``with_derivative``), any shape."""
    D = np.asarray(D, dtype=float)
    flat = np.ascontiguousarray(D).ravel()
    Q = np.empty_like(flat)
    dQ = np.empty_like(flat)
    from .kernels.slip import fk_flow_rate_array

    fk_flow_rate_array(flat, Q, dQ)
    if with_derivative:
        return Q.reshape(D.shape), dQ.reshape(D.shape)
    return Q.reshape(D.shape)


def flow_factor(
    name: str,
    p: np.ndarray | float,
    h: np.ndarray | float,
    p0: float,
    mean_free_path: float,
    h_switch: float = 0.3e-9,
    *,
    with_derivative: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Poiseuille flow factor phi = Q_P/Q_con of slip law ``name`` in physical units.

    Parameters
    ----------
    name : str
        One of :data:`SLIP_LAWS`.
    p : array_like [Pa]
        Local pressure (broadcast against ``h``).
    h : array_like [m]
        Local spacing.
    p0 : float [Pa]
        Ambient pressure.
    mean_free_path : float [m]
        Mean free path at p0.
    h_switch : float [m]
        Films thinner than this use the bounded second-order law (``fukui_kaneko`` only).
    with_derivative : bool
        Also return dphi/dp at fixed h [Pa^-1].

    Returns
    -------
    phi : ndarray [-]
        The Poiseuille flux coefficient is p h^3 phi (times 1/(12 eta)).
    """
    code = slip_code(name)
    p_b, h_b = np.broadcast_arrays(np.asarray(p, dtype=float), np.asarray(h, dtype=float))
    P = np.ascontiguousarray(p_b).ravel() / p0
    H = np.ascontiguousarray(h_b).ravel() / _H_REF
    phi = np.empty_like(P)
    dphi_dP = np.empty_like(P)
    from .kernels.slip import flow_factor_array

    flow_factor_array(code, P, H, mean_free_path / _H_REF, _H_REF, h_switch, phi, dphi_dP)
    if with_derivative:
        return phi.reshape(p_b.shape), (dphi_dP / p0).reshape(p_b.shape)
    return phi.reshape(p_b.shape)
