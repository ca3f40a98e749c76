"""Contact laws, chosen by name (``models.contact``).

``restitution`` (Benson, Chiang & Talke 1989): a rigid impact at a flat
corner (x1, x2) with a coefficient of restitution, Coulomb friction and
wedging.  Signs derived from virtual work with h = z - x1 th1 - x2 th2:

* the normal impulse q > 0 pushes the corner away from the disk: generalized
  impulse q (1, -x1, -x2);
* the friction impulse mu q acts along +x1 (the disk drags the slider in
  its direction of motion) at the disk surface, a distance e below the
  gimbal: generalized impulse mu q (0, -e, 0).

Hence dv = M^-1 g q with g = (1, -(x1 + e mu), -x2), i.e. the source's
J = (I1 + m a (x1 + e mu)) / (m I1 - (m a)^2),
J1 = -(m a + m (x1 + e mu)) / (m I1 - (m a)^2), and J2 = -x2 / I2 (the
printed +x2 / I2 contradicts the roll equation I2 th2'' = -S2 Q).

Approach velocity of the corner toward the disk U = -n . v with
n = (1, -x1, -x2).  The asperity moving at V meets a surface inclined by
eps (eps = pitch at the rear corners, pitch + theta0 at the front corners,
which sit on the taper side of the juncture), so the normal relative
velocity is U + eps V (wedging).  Restitution reverses it:
(U + eps V)+ = -alpha (U + eps V)-, which gives

    q = (1 + alpha) (U + eps V) / G,   G = n . M^-1 g = J - x1 J1 - x2 J2.

G > 0 is required (otherwise friction would pull the corner into the disk,
Painleve's paradox); for the source's slider that holds for mu < 5.71 at the
front corners (the roll term x2^2/I2 included) and always at the rear ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dynamics import mass_matrix
from .geometry import CORNERS, corner_is_front, corner_positions
from .params import Scene


class ContactError(RuntimeError):
    """An impact that the contact law cannot resolve."""


@dataclass(frozen=True)
class Impact:
    """One impact: time [s], corner index (0..3 = A..D), impulse [N s], approach velocities [m/s]."""

    time: float
    corner: int
    impulse: float
    approach_before: float
    approach_after: float
    normal_velocity_before: float
    normal_velocity_after: float

    @property
    def corner_letter(self) -> str:
        return CORNERS[self.corner]


def corner_normal(x1: float, x2: float) -> np.ndarray:
    """n with h_corner = n . q (and corner approach velocity U = -n . v)."""
    return np.array([1.0, -x1, -x2])


def impulse_direction(x1: float, x2: float, mu: float, friction_lever: float) -> np.ndarray:
    """Generalized impulse per unit normal impulse: (1, -(x1 + e mu), -x2)."""
    return np.array([1.0, -(x1 + friction_lever * mu), -x2])


def surface_slope(scene: Scene, corner: int, pitch: float) -> float:
    """eps: slope of the slider surface met by the asperity at the corner [rad]."""
    if not scene.contact.wedging:
        return 0.0
    return pitch + scene.slider.taper_angle if corner_is_front(scene.slider)[corner] else pitch


def restitution_impact(
    q: np.ndarray, v: np.ndarray, corner: int, scene: Scene, minv: np.ndarray | None = None
) -> tuple[np.ndarray, float]:
    """Impact map: velocities before -> after and the normal impulse q [N s] at ``corner``.

    q : (3,) attitude (z [m], pitch, roll [rad]), unchanged by the impact;
    v : (3,) generalized velocities before the impact.
    """
    x1, x2 = corner_positions(scene.slider)[corner]
    minv = np.linalg.inv(mass_matrix(scene.slider)) if minv is None else minv
    n = corner_normal(x1, x2)
    g = impulse_direction(x1, x2, scene.contact.mu, scene.slider.friction_lever)
    response = minv @ g
    G = float(n @ response)
    if G <= 0.0:
        raise ContactError(
            f"corner {CORNERS[corner]}: friction mu = {scene.contact.mu} makes the impact indeterminate "
            f"(n . M^-1 g = {G:.3g} <= 0, Painleve's paradox)"
        )
    eps = surface_slope(scene, corner, float(q[1]))
    relative = -float(n @ v) + eps * scene.disk.speed
    if relative <= 0.0:
        return v.copy(), 0.0
    impulse = (1.0 + scene.contact.alpha) * relative / G
    return v + response * impulse, impulse


CONTACT_LAWS = {"restitution": restitution_impact}


def impact_map(q: np.ndarray, v: np.ndarray, corner: int, scene: Scene, minv: np.ndarray | None = None):
    """The contact law named by ``scene.models.contact``: (v_after, impulse)."""
    return CONTACT_LAWS[scene.models.contact](q, v, corner, scene, minv)
