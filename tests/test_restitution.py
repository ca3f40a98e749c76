"""Restitution laws (``contact.restitution``): Thornton's elastic-perfectly-plastic coefficient against its own
contact mechanics, the published values, its limits, and the effective mass the impact map gives it.

The references are computed here, independently of :mod:`solver.rails.restitution`: the loading work (Hertz, then
the pressure capped at p_y) and the unloading work (Hertz with the enlarged radius) by quadrature, and a Thornton
contact force integrated in time on the rigid slider.  Tolerances are in units of the stated accuracy: 1e-6 for
the quadratures and the time integration, half a unit of the last printed digit for the published values.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import SCENE1_ATTITUDE, thornton_e
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from solver.rails.contact import corner_normal, impact_map, impulse_direction, surface_slope
from solver.rails.dynamics import mass_matrix
from solver.rails.geometry import CORNERS, corner_positions
from solver.rails.params import RESTITUTION_MODELS, Contact, Scene
from solver.rails.restitution import RESTITUTION_LAWS, thornton_coefficient, thornton_law, yield_velocity

pytestmark = pytest.mark.jitless

#: The accuracy the law must have against the contact mechanics computed here.
MECHANICS_TOLERANCE = 1e-6
#: Relative accuracy of the quadratures and root searches below (well under MECHANICS_TOLERANCE).
QUAD_RTOL = 1e-12
#: Materials and masses: the scene file's (R 10 um, E* 94 GPa, p_y 3.2 GPa, a corner of 20 mg), a small hard
#: contact and a large soft one.
MATERIALS = [(10e-6, 94e9, 3.2e9, 20e-6), (1e-6, 200e9, 8e9, 5e-6), (100e-6, 60e9, 2e9, 1e-3)]
#: Thornton (1997) as quoted in ../shared/SCENE2-NOTES.md section 6: V / V_y -> e_T, to four digits.
PUBLISHED = [(1.5, 0.9712), (2.0, 0.9306), (5.0, 0.7733), (10.0, 0.6586), (100.0, 0.3743)]


class HertzPlastic:
    """Thornton's contact of radius R: Hertz until the peak pressure reaches p_y, then the pressure capped at p_y."""

    def __init__(self, radius: float, modulus: float, yield_pressure: float) -> None:
        self.R, self.E, self.py = radius, modulus, yield_pressure
        # yield where Hertz's peak pressure 2 E* a / (pi R), a = sqrt(R d), reaches p_y (found, not solved for)
        self.d_y = brentq(lambda d: 2 * modulus * math.sqrt(radius * d) / (math.pi * radius) - yield_pressure,
                          0.0, radius, xtol=1e-30, rtol=QUAD_RTOL)  # fmt: skip
        self.F_y = self.hertz(self.d_y, radius)

    def hertz(self, d: float, radius: float) -> float:
        return 4.0 / 3.0 * self.E * math.sqrt(radius) * max(d, 0.0) ** 1.5

    def loading(self, d: float) -> float:
        """Force on the loading branch [N]: Hertz, then F_y + pi p_y R (d - d_y) (the capped pressure)."""
        return self.hertz(d, self.R) if d <= self.d_y else self.F_y + math.pi * self.py * self.R * (d - self.d_y)

    def loading_work(self, d: float) -> float:
        elastic = quad(lambda x: self.hertz(x, self.R), 0.0, min(d, self.d_y), epsabs=0.0, epsrel=QUAD_RTOL)[0]
        if d <= self.d_y:
            return elastic
        return elastic + quad(self.loading, self.d_y, d, epsabs=0.0, epsrel=QUAD_RTOL)[0]

    def unloading(self, d_max: float) -> tuple[float, float]:
        """The unloading branch from d_max: (enlarged radius R_p, indentation d_r where the force vanishes)."""
        a = math.sqrt(self.R * d_max)
        radius_p = 4.0 * self.E * a**3 / (3.0 * self.loading(d_max))
        return radius_p, d_max - a * a / radius_p

    def rebound(self, mass: float, speed: float) -> float:
        """Restitution from the energies: the deepest indentation stores m V^2 / 2, the unloading returns part."""
        energy = 0.5 * mass * speed**2
        d_max = brentq(lambda d: self.loading_work(d) - energy, 0.0, 1e6 * self.d_y, xtol=1e-30, rtol=QUAD_RTOL)
        radius_p, d_r = self.unloading(d_max)
        returned = quad(lambda d: self.hertz(d - d_r, radius_p), d_r, d_max, epsabs=0.0, epsrel=QUAD_RTOL)[0]
        return math.sqrt(returned / energy)


@pytest.mark.parametrize(("radius", "modulus", "yield_pressure", "mass"), MATERIALS)
def test_yield_velocity_stores_the_elastic_energy_at_first_yield(radius, modulus, yield_pressure, mass):
    contact = HertzPlastic(radius, modulus, yield_pressure)
    v_y = math.sqrt(2.0 * contact.loading_work(contact.d_y) / mass)
    assert abs(yield_velocity(radius, modulus, yield_pressure, mass) / v_y - 1.0) <= MECHANICS_TOLERANCE


@pytest.mark.parametrize(("radius", "modulus", "yield_pressure", "mass"), MATERIALS)
@pytest.mark.parametrize("ratio", [0.5, 1.0, 1.001, 1.5, 2.0, 5.0, 10.0, 100.0, 1000.0])
def test_thornton_coefficient_is_the_energy_of_loading_and_unloading(radius, modulus, yield_pressure, mass, ratio):
    # e_T^2 = (work returned by the Hertzian unloading at the enlarged radius) / (m V^2 / 2), integrated here;
    # a ratio at or below 1 never yields and returns everything
    contact = HertzPlastic(radius, modulus, yield_pressure)
    v_y = math.sqrt(2.0 * contact.loading_work(contact.d_y) / mass)
    expected = contact.rebound(mass, ratio * v_y)
    got = thornton_coefficient(ratio * v_y, yield_velocity(radius, modulus, yield_pressure, mass))
    assert abs(got - expected) <= MECHANICS_TOLERANCE


@pytest.mark.parametrize(("ratio", "published"), PUBLISHED)
def test_published_values(ratio, published):
    assert abs(thornton_coefficient(ratio * 2e-3, 2e-3) - published) <= 0.5e-4


@pytest.mark.parametrize("ratio", [1.2, 3.0, 30.0, 3000.0])
def test_the_notes_closed_form(ratio):
    assert thornton_coefficient(ratio, 1.0) == pytest.approx(float(thornton_e(ratio, 1.0)), rel=1e-14, abs=0)


def thornton_contact(alpha: float = 0.9, **keys) -> Contact:
    return Contact(restitution="thornton", alpha=alpha, **keys)


@pytest.mark.parametrize("ratio", [0.0, 0.3, 0.999, 1.0])
def test_below_the_yield_velocity_the_applied_coefficient_is_contact_alpha(ratio):
    contact = thornton_contact()
    response = np.array([1.0 / 20e-6])  # a corner of 20 mg
    v_y = yield_velocity(contact.corner_radius, contact.contact_modulus, contact.yield_pressure, 20e-6)
    alpha, v_yield = thornton_law(contact, np.array([ratio * v_y]), response)
    assert alpha[0] == contact.alpha
    assert v_yield[0] == pytest.approx(v_y, rel=1e-14)


def test_the_coefficient_is_continuous_at_the_yield_velocity_and_falls_with_speed():
    assert 1.0 - thornton_coefficient(1.0 + 1e-9, 1.0) <= 1e-8
    speeds = np.geomspace(1.0, 1e6, 200)
    e = np.array([thornton_coefficient(v, 1.0) for v in speeds])
    assert np.all(np.diff(e) < 0.0) and 0.0 < e[-1]


def test_far_above_the_yield_velocity_the_coefficient_goes_as_the_quarter_power():
    # e_T -> C r^(1/4), r = V_y / V, with C = (6 sqrt(3)/5)^(1/2) (2 (6/5)^(1/2))^(-1/4) from the closed form;
    # the first correction is -r / (8 (6/5)^(1/2)), the next one of order r^2
    constant = (6 * math.sqrt(3) / 5) ** 0.5 * (2 * math.sqrt(6 / 5)) ** -0.25
    assert abs(constant - 1.185) <= 0.5e-3  # the notes' rounded value
    contact = thornton_contact(alpha=0.85)
    response = np.array([1.0 / 20e-6])  # a corner of 20 mg
    v_y = thornton_law(contact, np.array([0.0]), response)[1][0]
    for r in (1e-2, 1e-3, 1e-4, 1e-5, 1e-6):
        alpha = thornton_law(contact, np.array([v_y / r]), response)[0][0]
        relative = alpha / (contact.alpha * constant * r**0.25) - 1.0
        assert abs(relative / r + 1.0 / (8.0 * math.sqrt(6 / 5))) <= 0.05 * r


def test_the_registry_is_the_choice_list():
    assert tuple(RESTITUTION_LAWS) == RESTITUTION_MODELS


@pytest.mark.parametrize("law", RESTITUTION_MODELS)
def test_every_law_applies_at_most_contact_alpha(law):
    contact = Contact(restitution=law, alpha=0.85, corner_radius=5e-6)
    speeds = np.geomspace(1e-6, 1.0, 50)
    alpha, v_yield = RESTITUTION_LAWS[law](contact, speeds, np.full(50, 5e4))
    assert np.all((0.0 < alpha) & (alpha <= contact.alpha))
    assert np.all(np.isnan(v_yield)) if law == "constant" else np.all(v_yield > 0.0)


# ---------------------------------------------------------------------------- the effective mass


def rebound_on_the_rigid_slider(scene: Scene, corner: int, v: np.ndarray) -> np.ndarray:
    """Generalized velocities after a Thornton contact force F(d), integrated in time at ``corner``.

    The force acts along g = (1, -(x1 + e mu), -x2) (normal force and its sliding friction), so M v' = g F;
    the indentation grows at the approach speed d' = -n . v + eps V.  Loading until d' = 0, then the Hertzian
    unloading of :class:`HertzPlastic` until the force vanishes.
    """
    c = scene.contact
    contact = HertzPlastic(c.corner_radius, c.contact_modulus, c.yield_pressure)
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    accel = np.linalg.solve(mass_matrix(scene.slider), impulse_direction(x1, x2, c.mu, scene.slider.friction_lever))
    wedge = surface_slope(scene, corner, float(SCENE1_ATTITUDE[1])) * scene.disk.speed
    speed = -n @ v + wedge
    scale = np.array([contact.d_y, *np.abs(v)]) + 1e-300

    def integrate(force, y0, stop):
        stop.terminal, stop.direction = True, -1
        sol = solve_ivp(lambda t, y: [-n @ y[1:] + wedge, *(accel * force(y[0]))], (0.0, 1.0), y0, method="DOP853",
                        rtol=1e-13, atol=1e-16 * scale, events=stop)  # fmt: skip
        assert sol.status == 1
        return sol.y_events[0][0]

    turned = integrate(contact.loading, np.array([0.0, *v]), lambda t, y: -n @ y[1:] + wedge)
    radius_p, d_r = contact.unloading(turned[0])
    released = integrate(lambda d: contact.hertz(d - d_r, radius_p), turned, lambda t, y: y[0] - d_r)
    assert speed > 0.0
    return released[1:]


@pytest.mark.parametrize("corner", range(len(CORNERS)))
@pytest.mark.parametrize("mu", [0.0, 0.5, 1.0])
@pytest.mark.parametrize("radius", [3e-6, 30e-6])
def test_the_impact_map_is_thornton_s_contact_on_the_rigid_slider(corner, mu, radius):
    # with alpha = 1 the map must give what the contact force itself gives, integrated in time on the slider with
    # its friction: the corner's effective mass is 1 / (n . M^-1 g), friction included
    scene = Scene(contact=Contact(restitution="thornton", alpha=1.0, mu=mu, corner_radius=radius))
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    wedge = surface_slope(scene, corner, float(SCENE1_ATTITUDE[1])) * scene.disk.speed
    rng = np.random.default_rng(100 * corner + int(10 * mu))
    for target in (0.002, 0.02, 0.05):  # approach speeds [m/s] from about V_y to far above it
        v = rng.normal(0.0, [0.005, 5.0, 10.0])
        v[0] += (-n @ v + wedge) - target  # sets -n . v + eps V to the target speed
        expected = rebound_on_the_rigid_slider(scene, corner, v)
        v_after, _ = impact_map(SCENE1_ATTITUDE, v, corner, scene)
        e_expected = -(-n @ expected + wedge) / target
        e_map = -(-n @ v_after + wedge) / target
        assert abs(e_map - e_expected) <= MECHANICS_TOLERANCE
        np.testing.assert_allclose(v_after - v, expected - v, rtol=MECHANICS_TOLERANCE, atol=0)
