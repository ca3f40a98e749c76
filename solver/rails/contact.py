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

alpha is the coefficient of the restitution law ``contact.restitution``
(:mod:`solver.rails.restitution`): ``contact.alpha`` itself, or ``contact.alpha``
times Thornton's e_T of the approach speed U + eps V over the yield velocity of
the corner's effective mass 1 / G.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from solver.errors import ContactError
from solver.rails.dynamics import mass_matrix
from solver.rails.geometry import CORNERS, corner_is_front, corner_positions
from solver.rails.params import Scene
from solver.rails.restitution import restitution

#: Relative approach velocities below this fraction of the corners' speed scale are round-off, not approaches
#: (a plastic impact leaves 0 +- round-off; counting that as an approach struck the corner again).
APPROACH_ROUND_OFF = 1e-10
#: At most this many passes of simultaneous impacts, while an impulse makes another touching corner approach.
MAX_IMPACT_PASSES = 8
#: Passes to settle which corners of one impact are held (a hold changes the others' rebound once).
HOLD_ATTEMPTS = 2
#: Relative singular-value cut-off of the least-norm impulses (dependent corners of a rigid plane).
LSTSQ_RCOND = 1e-12
#: Least-norm impulses more negative than this fraction of the largest are pulls: solved again by NNLS.
PULL_TOLERANCE = 1e-12
#: Impulses below this fraction of the largest of their impact are round-off and not recorded as impacts.
IMPULSE_FLOOR = 1e-12
#: Guard against division by zero in relative scales [the scale's units].
TINY = 1e-300
#: Held corners whose rates stay more negative than this fraction of the rate scale cannot be held: an error.
HOLD_VIOLATION = 1e-6
#: A held corner separating faster than this fraction of the rate scale is released.
RELEASE_RATE = 1e-9
#: Velocity projection: a held corner is released only when it separates faster than this fraction of
#: ``contact.rest_velocity`` (round-off of a corner at rest does not release it).
RELEASE_VELOCITY = 1e-6


@dataclass(frozen=True)
class Impact:
    """One impact: time [s], corner index (0..3 = A..D), impulse [N s], approach velocities [m/s].

    ``approach_before`` is the speed U + eps V the restitution law reads; ``alpha`` the coefficient applied
    (0 where the chattering rule's target, zero normal velocity, replaced restitution: a plastic impact);
    ``yield_velocity`` Thornton's V_y of the corner [m/s] (NaN under the constant law); ``held``: the corner is
    held on the asperities after the impact (:class:`SustainedContact`).
    """

    time: float
    corner: int
    impulse: float
    approach_before: float
    approach_after: float
    normal_velocity_before: float
    normal_velocity_after: float
    alpha: float
    yield_velocity: float
    held: bool

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
    alpha = float(restitution(scene.contact, np.array([relative]), np.array([G]))[0][0])
    impulse = (1.0 + alpha) * relative / G
    return v + response * impulse, impulse


CONTACT_LAWS = {"restitution": restitution_impact}


def impact_map(q: np.ndarray, v: np.ndarray, corner: int, scene: Scene, minv: np.ndarray | None = None):
    """The contact law named by ``scene.models.contact``: (v_after, impulse)."""
    return CONTACT_LAWS[scene.models.contact](q, v, corner, scene, minv)


class SustainedContact:
    """The chattering rule: corners held on the asperities instead of an unbounded train of impacts.

    A corner whose restitution rebound would leave it slower than
    ``contact.rest_velocity`` (its spacing rate after the impact) while the
    other forces press it onto the asperities (its spacing acceleration is
    negative) would bounce again after a time that shrinks geometrically
    with alpha: infinitely many impacts in finite time.  Instead the impact
    is made plastic (the corner's normal velocity becomes zero; no wedging,
    the corner does not leave the asperity tips) and the corner is *held*:
    its spacing stays at h0 under a normal contact force lambda >= 0 with
    the Coulomb friction mu lambda at the disk surface (generalized
    direction g as for an impulse).  For the held set H the forces solve

        n_h . (a_free + sum_k M^-1 g_k lambda_k) = 0,   h in H,

    and a corner is released when its lambda would be negative (the film
    lifts it).  With rest_velocity = 0 the rule is off.
    """

    def __init__(self, scene: Scene, normals: np.ndarray, minv: np.ndarray, h0: float) -> None:
        self.v_rest = scene.contact.rest_velocity
        self.normals = normals
        self.h0 = h0
        mu, e = scene.contact.mu, scene.slider.friction_lever
        self.response = np.array([minv @ impulse_direction(x1, x2, mu, e) for x1, x2 in corner_positions(scene.slider)])
        self.held = np.zeros(len(normals), dtype=bool)
        self.lam = np.zeros(len(normals))
        self.since = np.zeros(len(normals))
        self.intervals: list[tuple[float, float, int]] = []

    @property
    def free(self) -> np.ndarray:
        return ~self.held

    @property
    def any_held(self) -> bool:
        return bool(self.held.any())

    def _multipliers(self, rates: np.ndarray, t: float, release_floor: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Non-negative multipliers x on the held corners so that none of them approaches.

        Minimises |n_h . (rate + sum_k r_k x_k)| over x >= 0 (NNLS: four corners
        of a rigid plane are dependent, and a corner whose rate stays positive
        with x = 0 is released).  Returns (held indices, x).
        """
        idx = np.flatnonzero(self.held)
        A = self.normals[idx] @ self.response[idx].T
        b = rates[idx]
        x, _ = nnls(A, -b)
        after = A @ x + b
        scale = float(np.abs(rates).max()) + TINY
        if after.min() < -HOLD_VIOLATION * scale:
            raise ContactError(f"held corners {idx.tolist()} cannot be kept on the asperities (rates {after.tolist()})")
        for k in np.flatnonzero(after > RELEASE_RATE * scale + release_floor):
            self._release(int(idx[k]), t)
        return idx, x

    def _correction(self, residual: np.ndarray) -> np.ndarray:
        """Least-norm generalized correction that zeroes ``residual`` on the held corners."""
        idx = np.flatnonzero(self.held)
        A = self.normals[idx] @ self.response[idx].T
        x = np.linalg.lstsq(A, -residual[idx], rcond=LSTSQ_RCOND)[0]
        return self.response[idx].T @ x

    def should_hold(self, corner: int, v_after: np.ndarray, acc: np.ndarray) -> bool:
        if self.v_rest <= 0.0:
            return False
        n = self.normals[corner]
        return float(n @ v_after) < self.v_rest and float(n @ acc) < 0.0

    def _release(self, corner: int, t: float) -> None:
        self.held[corner] = False
        self.lam[corner] = 0.0
        self.intervals.append((float(self.since[corner]), float(t), int(corner)))

    def project_velocity(self, v: np.ndarray, t: float) -> np.ndarray:
        """Stop the held corners approaching (releasing those that separate)."""
        if not self.any_held:
            return v
        idx, x = self._multipliers(self.normals @ v, t, RELEASE_VELOCITY * self.v_rest)
        return v + self.response[idx].T @ x

    def apply_forces(self, acc: np.ndarray, t: float = 0.0) -> None:
        """Add the held corners' contact forces to the free acceleration ``acc`` (in place)."""
        self.lam[:] = 0.0
        if not self.any_held:
            return
        idx, x = self._multipliers(self.normals @ acc, t)
        self.lam[idx] = x
        acc += self.response[idx].T @ x

    def constrain(self, s: float, t: float, q: np.ndarray, v: np.ndarray, acc: np.ndarray) -> None:
        """After a step ending at t: contact forces into the closing half kick, then back onto the constraints."""
        before = acc.copy()
        self.apply_forces(acc, t)
        v += 0.5 * s * (acc - before)
        if self.any_held:
            q += self._correction(self.normals @ q - self.h0)
            v += self._correction(self.normals @ v)

    def save(self) -> None:
        self._saved = (self.held.copy(), self.lam.copy(), self.since.copy(), len(self.intervals))

    def restore(self) -> None:
        held, lam, since, n = self._saved
        self.held[:], self.lam[:], self.since[:] = held, lam, since
        del self.intervals[n:]

    def finish(self, t: float) -> None:
        for c in np.flatnonzero(self.held):
            self._release(int(c), t)


def resolve_impacts(
    scene: Scene,
    q: np.ndarray,
    v: np.ndarray,
    t: float,
    contact: SustainedContact,
    acc: np.ndarray,
    impacts: list[Impact],
    touch_tol: float,
) -> np.ndarray:
    """Impacts at every free corner touching the asperities and approaching them, resolved together.

    The run's contact law at an instant t (used by :func:`solver.rails.integrate.simulate`).

    Corners that touch at once (the rear pair at zero roll) share one impact:
    the impulses p >= 0 solve A p = (1 + alpha) w over the approaching set,
    w_c = -n_c . v + eps_c V the relative approach velocities and
    A_cd = n_c . M^-1 g_d (least-norm when the corners are dependent, as the
    four corners of a level slider; corners whose impulse would pull are
    dropped by NNLS).  Symmetric contacts thus get symmetric impulses, and a
    lone corner gets the single-corner law :func:`restitution_impact`
    (A = G, p = (1 + alpha) w / G; tests/test_contact.py checks it against
    :func:`impact_map`).  A corner whose rebound would be slower than
    ``contact.rest_velocity`` while pressed on is held instead
    (:class:`SustainedContact`): its target is zero normal velocity.
    Approach velocities below :data:`APPROACH_ROUND_OFF` of the corners'
    speed scale are round-off, not approaches.  Passes repeat (at most
    :data:`MAX_IMPACT_PASSES`) while an impulse makes another touching corner
    approach.

    Parameters
    ----------
    scene : Scene
    q : ndarray (3,)
        Attitude (z [m], pitch, roll [rad]) at the instant; unchanged.
    v : ndarray (3,)
        Generalized velocities before the impacts [m/s, rad/s, rad/s].
    t : float
        The instant [s], recorded in the impacts and the holds.
    contact : SustainedContact
        The held set (updated in place: new holds, releases) and the corners' normals and responses.
    acc : ndarray (3,)
        Generalized accelerations without contact forces (whether a corner is pressed on).
    impacts : list of Impact
        Every impulse above :data:`IMPULSE_FLOOR` of its impact's largest is appended, one per corner.
    touch_tol : float
        A corner touches when its spacing is within this of the asperity height [m].

    Returns
    -------
    ndarray (3,)
        Generalized velocities after the impacts (projected onto the held corners' constraints).
    """
    mu, V = scene.contact.mu, scene.disk.speed
    normals = contact.normals
    touching = np.flatnonzero((np.abs(normals @ q - scene.disk.asperity_height) <= touch_tol) & contact.free)
    if touching.size == 0:
        return v
    slopes = np.array([surface_slope(scene, int(c), float(q[1])) for c in range(len(normals))])
    response = contact.response
    for _ in range(MAX_IMPACT_PASSES):
        gap_rates = normals @ v
        w = -gap_rates + slopes * V
        scale = float(np.abs(gap_rates).max() + np.abs(slopes).max() * V) + TINY
        active = [int(c) for c in touching if w[c] > APPROACH_ROUND_OFF * scale and not contact.held[c]]
        pressed = [int(c) for c in touching if not contact.held[c] and w[c] <= APPROACH_ROUND_OFF * scale]
        grazing = [c for c in pressed if contact.should_hold(c, v, acc) and gap_rates[c] <= 0.0]
        if not active and not grazing:
            break
        hold = set(grazing)
        for _attempt in range(HOLD_ATTEMPTS):
            idx = np.array(active + sorted(hold - set(active)), dtype=int)
            A = normals[idx] @ response[idx].T
            for G in np.diag(A):
                if G <= 0.0:
                    raise ContactError(
                        f"friction mu = {mu} makes the impact indeterminate (n . M^-1 g = {G:.3g} <= 0, "
                        "Painleve's paradox)"
                    )
            alpha, v_yield = restitution(scene.contact, w[idx], np.diag(A))
            held = np.isin(idx, list(hold))
            target = np.where(held, -gap_rates[idx], (1.0 + alpha) * w[idx])
            p = np.linalg.lstsq(A, target, rcond=LSTSQ_RCOND)[0]
            if p.min() < -PULL_TOLERANCE * max(float(np.abs(p).max()), TINY):
                p = nnls(A, target)[0]
            v_new = v + response[idx].T @ p
            newly = {int(c) for c in idx if c not in hold and contact.should_hold(int(c), v_new, acc)}
            if not newly:
                break
            hold |= newly
        p_floor = IMPULSE_FLOOR * max(float(p.max()), TINY)
        for c, pc, alpha_c, v_yield_c, plastic in zip(idx, p, alpha, v_yield, held, strict=True):
            c = int(c)
            if c in hold:
                contact.held[c] = True
                contact.since[c] = t
            if pc > p_floor:
                u_before = -float(gap_rates[c])
                u_after = -float(normals[c] @ v_new)
                wedge = slopes[c] * V
                applied = 0.0 if plastic else float(alpha_c)
                impacts.append(
                    Impact(t, c, float(pc), u_before + wedge, u_after + wedge, u_before, u_after, applied,
                           float(v_yield_c), c in hold)
                )  # fmt: skip
        v = v_new
        if contact.any_held:
            v = contact.project_velocity(v, t)
    return v
