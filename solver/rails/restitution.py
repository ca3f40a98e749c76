"""Restitution laws, chosen by name (``contact.restitution``): the coefficient an impact applies.

``constant`` (Benson, Chiang & Talke 1989): alpha = ``contact.alpha`` at every impact.

``thornton``: alpha = ``contact.alpha`` e_T(V / V_y), with e_T Thornton's coefficient of an
elastic-perfectly-plastic sphere on a plane (C. Thornton, J. Appl. Mech. 64:383, 1997).  ``contact.alpha``
keeps its meaning as the coefficient of an elastic impact (the viscous loss of a few percent), and e_T adds
the plastic loss of a faster one.

Thornton's contact (radius R, composite modulus E*, limiting contact pressure p_y, a mass m* approaching at
V):

* loading is Hertzian, F = 4/3 E* R^(1/2) d^(3/2) (contact radius a^2 = R d), until the peak pressure
  2 E* a / (pi R) reaches p_y at d_y = (pi p_y / (2 E*))^2 R, F_y = 4/3 E* R^(1/2) d_y^(3/2);
* beyond it the pressure is capped at p_y and F = F_y + pi p_y R (d - d_y);
* unloading from (d*, F*) is Hertzian with the radius enlarged to R_p = 4 E* a*^3 / (3 F*),
  F = 4/3 E* R_p^(1/2) (d - d_r)^(3/2), d* - d_r = a*^2 / R_p;
* e_T^2 = (work of the unloading) / (m* V^2 / 2).

The elastic energy at d_y equals m* V_y^2 / 2 at the yield velocity

    V_y = [pi^5 p_y^5 R^3 / (30 E*^4 m*)]^(1/2);

below it the impact is elastic, e_T = 1, and above it, with r = V_y / V,

    e_T = (6 sqrt(3) / 5)^(1/2) (1 - r^2 / 6)^(1/2) [r / (r + 2 (6/5 - r^2/5)^(1/2))]^(1/4),

continuous at r = 1 and tending to (6 sqrt(3)/5)^(1/2) (5/24)^(1/8) r^(1/4) = 1.185 r^(1/4) for V >> V_y.

Which V and which m* (the rigid slider's corner, :mod:`solver.rails.contact`):

* V is the normal approach speed that enters the impulse, U + eps V_disk, wedging included;
* m* = 1 / G, G = n . M^-1 g the impact map's denominator: the corner's normal velocity changes by
  -G dq under a normal impulse dq carrying its friction mu dq.  The disk slides under the corner at
  V_disk (2 m/s), far faster than any velocity change of an impact, so the friction keeps its direction
  throughout and the corner's normal motion during the impact is exactly m* d'' = -F(d), the one-mass
  problem Thornton solved, with friction inside m*: it raises m* at the front corners (friction lifts the
  nose, G falls toward Painleve's limit) and lowers it at the rear ones.
* Corners struck together get each its own e_T from its own V and G (the diagonal of the impact matrix);
  their coupling through the shared rigid body does not enter V_y.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from solver.rails.params import Contact

#: (6 sqrt(3) / 5)^(1/2), the leading factor of Thornton's e_T.
THORNTON_FACTOR = math.sqrt(6.0 * math.sqrt(3.0) / 5.0)
#: e_T (V_y / V)^(-1/4) as V / V_y -> infinity: THORNTON_FACTOR (5/24)^(1/8).
THORNTON_ASYMPTOTE = THORNTON_FACTOR * (5.0 / 24.0) ** 0.125


def yield_velocity(radius: float, modulus: float, yield_pressure: float, mass: float) -> float:
    """Thornton's yield velocity V_y = [pi^5 p_y^5 R^3 / (30 E*^4 m*)]^(1/2) [m/s].

    radius R [m], modulus E* [Pa], yield_pressure p_y [Pa], mass m* [kg] (all > 0).
    """
    return math.sqrt(math.pi**5 * yield_pressure**5 * radius**3 / (30.0 * modulus**4 * mass))


def thornton_coefficient(velocity: float, yield_velocity: float) -> float:
    """Thornton's e_T for an approach speed ``velocity`` [m/s] and the yield velocity V_y [m/s] (> 0).

    1 at and below V_y (a receding or grazing corner included); the closed form of the module docstring above.
    """
    if velocity <= yield_velocity:
        return 1.0
    r = yield_velocity / velocity
    return THORNTON_FACTOR * math.sqrt(1.0 - r * r / 6.0) * (r / (r + 2.0 * math.sqrt(6.0 / 5.0 - r * r / 5.0))) ** 0.25


def constant_law(contact: Contact, velocities: np.ndarray, responses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``contact.alpha`` at every corner; no yield velocity (NaN)."""
    return np.full(len(velocities), contact.alpha), np.full(len(velocities), np.nan)


def thornton_law(contact: Contact, velocities: np.ndarray, responses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``contact.alpha`` e_T(V / V_y) per corner, with m* = 1 / G from each corner's normal response G."""
    v_yield = np.array(
        [
            yield_velocity(contact.corner_radius, contact.contact_modulus, contact.yield_pressure, 1.0 / float(g))
            for g in responses
        ]
    )
    e_t = np.array([thornton_coefficient(float(v), vy) for v, vy in zip(velocities, v_yield, strict=True)])
    return contact.alpha * e_t, v_yield


#: The laws by name: (contact, approach speeds V (n,) [m/s], normal responses G (n,) [1/kg]) ->
#: (coefficients applied (n,), yield velocities (n,) [m/s], NaN where the law has none).
RESTITUTION_LAWS: dict[str, Callable[[Contact, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]] = {
    "constant": constant_law,
    "thornton": thornton_law,
}


def restitution(contact: Contact, velocities: np.ndarray, responses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The law named by ``contact.restitution``: (coefficients applied, yield velocities [m/s]) per corner.

    velocities : ndarray (n,) [m/s]
        Normal approach speeds U + eps V of the corners (wedging included).
    responses : ndarray (n,) [1/kg]
        Each corner's G = n . M^-1 g (> 0), the inverse of its effective mass.
    """
    return RESTITUTION_LAWS[contact.restitution](contact, velocities, responses)
