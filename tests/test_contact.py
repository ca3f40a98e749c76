"""Impact map at the rail corners: restitution, impulse-momentum balance, energy, wedging, friction.

Every test runs over the contact-law registry and the four corners.  The
maps are algebraic, so the tolerances are a few tens of machine epsilon of
the quantities compared.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import EPS, SCENE1_ATTITUDE, small_scene, thornton_e

from solver.jit import JIT_DISABLED
from solver.rails import contact as contact_module
from solver.rails import integrate
from solver.rails.contact import (
    CONTACT_LAWS,
    ContactError,
    SustainedContact,
    corner_normal,
    impact_map,
    impulse_direction,
    resolve_impacts,
    restitution_impact,
    surface_slope,
)
from solver.rails.dynamics import kinetic_energy, mass_matrix
from solver.rails.geometry import CORNERS, corner_is_front, corner_positions
from solver.rails.params import RESTITUTION_MODELS, Contact, Models, Scene, Slider
from solver.rails.restitution import yield_velocity

#: Fast enough to run a second time with the JIT off (HDI_DISABLE_JIT=1, .ci/run).
pytestmark = pytest.mark.jitless

CORNER_INDICES = list(range(len(CORNERS)))


def scene_with(law="restitution", **contact) -> Scene:
    return Scene(models=Models(contact=law), contact=Contact(**contact))


def approaching_velocities(rng, scene, corner, count=20):
    """Random generalized velocities whose corner approaches the disk (U = -n.v > 0), scene-1 magnitudes."""
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    out = []
    while len(out) < count:
        v = rng.normal(0.0, [0.02, 10.0, 20.0])
        if -n @ v > 1e-4:
            out.append(v)
    return out


def velocity_scale(scene, corner, v):
    """|n| |v| in m/s: the size of the terms that cancel in n . v."""
    x1, x2 = corner_positions(scene.slider)[corner]
    return float(np.abs(corner_normal(x1, x2)) @ np.abs(v))


@pytest.mark.parametrize("law", sorted(CONTACT_LAWS))
@pytest.mark.parametrize("corner", CORNER_INDICES)
@pytest.mark.parametrize("alpha", [0.0, 0.5, 0.85, 1.0])
def test_frictionless_impact_reverses_normal_velocity_by_alpha(law, corner, alpha):
    scene = scene_with(law, mu=0.0, alpha=alpha, wedging=False)
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    rng = np.random.default_rng(corner)
    for v in approaching_velocities(rng, scene, corner):
        v_after, impulse = impact_map(SCENE1_ATTITUDE, v, corner, scene)
        before, after = -n @ v, -n @ v_after
        assert impulse > 0.0
        assert abs(after + alpha * before) <= 16 * EPS * velocity_scale(scene, corner, v)


@pytest.mark.parametrize("law", sorted(CONTACT_LAWS))
@pytest.mark.parametrize("corner", CORNER_INDICES)
@pytest.mark.parametrize("mu", [0.0, 0.5, 1.5])
def test_impulse_momentum_balance(law, corner, mu):
    # M (v+ - v-) = q g with g = (1, -(x1 + e mu), -x2): normal impulse at the corner,
    # friction mu q along the disk motion a lever e below the gimbal
    scene = scene_with(law, mu=mu, alpha=0.8, wedging=True)
    x1, x2 = corner_positions(scene.slider)[corner]
    g = impulse_direction(x1, x2, mu, scene.slider.friction_lever)
    np.testing.assert_array_equal(g, [1.0, -(x1 + scene.slider.friction_lever * mu), -x2])
    M = mass_matrix(scene.slider)
    rng = np.random.default_rng(10 + corner)
    for v in approaching_velocities(rng, scene, corner):
        v_after, impulse = impact_map(SCENE1_ATTITUDE, v, corner, scene)
        assert impulse > 0.0
        momentum_change = M @ (v_after - v)
        scale = np.abs(M) @ (np.abs(v_after) + np.abs(v))
        assert np.all(np.abs(momentum_change - impulse * g) <= 16 * EPS * scale)


@pytest.mark.parametrize("corner", CORNER_INDICES)
def test_velocity_jumps_match_the_source_coefficients(corner):
    # the source's J, J1 (printed) and J2 = -x2/I2 (sign corrected, see solver.rails.contact)
    scene = scene_with(mu=0.5, alpha=0.8, wedging=False)
    s = scene.slider
    m, a, I1, I2, e, mu = s.mass, s.cg_offset, s.pitch_inertia, s.roll_inertia, s.friction_lever, 0.5
    x1, x2 = corner_positions(s)[corner]
    det = m * I1 - (m * a) ** 2
    J = (I1 + m * a * (x1 + e * mu)) / det
    J1 = -(m * a + m * (x1 + e * mu)) / det
    J2 = -x2 / I2
    v = approaching_velocities(np.random.default_rng(20 + corner), scene, corner, count=1)[0]
    v_after, impulse = restitution_impact(SCENE1_ATTITUDE, v, corner, scene)
    jump = (v_after - v) / impulse
    np.testing.assert_allclose(jump, [J, J1, J2], rtol=64 * EPS)
    U = -corner_normal(x1, x2) @ v
    assert impulse == pytest.approx((1 + 0.8) * U / (J - x1 * J1 - x2 * J2), rel=64 * EPS, abs=0)


@pytest.mark.parametrize("corner", CORNER_INDICES)
def test_impact_pushes_the_corner_away(corner):
    # physical sign check: whatever the friction (below the Painleve limit) and wedging,
    # an approaching corner gets q > 0 and leaves the disk
    for mu in (0.0, 0.3, 1.0, 2.0):
        scene = scene_with(mu=mu, alpha=0.6, wedging=True)
        x1, x2 = corner_positions(scene.slider)[corner]
        n = corner_normal(x1, x2)
        for v in approaching_velocities(np.random.default_rng(30 + corner), scene, corner):
            v_after, impulse = impact_map(SCENE1_ATTITUDE, v, corner, scene)
            assert impulse > 0.0
            assert -n @ v_after < 0.0


@pytest.mark.parametrize("corner", CORNER_INDICES)
def test_receding_corner_gets_no_impulse(corner):
    scene = scene_with(mu=0.5, alpha=0.8, wedging=False)
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    for v in approaching_velocities(np.random.default_rng(40 + corner), scene, corner):
        v_after, impulse = impact_map(SCENE1_ATTITUDE, -v, corner, scene)
        assert impulse == 0.0
        np.testing.assert_array_equal(v_after, -v)
        assert -n @ v_after < 0.0


@pytest.mark.parametrize("corner", CORNER_INDICES)
@pytest.mark.parametrize("alpha", [1.0, 0.8, 0.3, 0.0])
def test_frictionless_energy_loss(corner, alpha):
    # mu = 0: the impulse acts along n, so dT = -(1 - alpha^2) U^2 / (2 G), G = n.M^-1 n;
    # alpha = 1 conserves kinetic energy, alpha < 1 loses exactly that much
    scene = scene_with(mu=0.0, alpha=alpha, wedging=False)
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    G = n @ np.linalg.solve(mass_matrix(scene.slider), n)
    for v in approaching_velocities(np.random.default_rng(50 + corner), scene, corner):
        v_after, _ = impact_map(SCENE1_ATTITUDE, v, corner, scene)
        before = kinetic_energy(scene.slider, v)
        after = kinetic_energy(scene.slider, v_after)
        U = -n @ v
        expected_loss = (1.0 - alpha**2) * U**2 / (2.0 * G)
        assert abs((before - after) - expected_loss) <= 64 * EPS * before
        if alpha < 1.0:
            assert after < before


@pytest.mark.parametrize("corner", CORNER_INDICES)
def test_wedging_impulse_without_approach(corner):
    # U = 0 but the asperity, moving at V, meets a surface inclined by eps: q = (1 + alpha) eps V / G
    alpha, mu = 0.7, 0.4
    scene = scene_with(mu=mu, alpha=alpha, wedging=True)
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    g = impulse_direction(x1, x2, mu, scene.slider.friction_lever)
    G = n @ np.linalg.solve(mass_matrix(scene.slider), g)
    pitch = SCENE1_ATTITUDE[1]
    eps = pitch + scene.slider.taper_angle if corner_is_front(scene.slider)[corner] else pitch
    assert surface_slope(scene, corner, pitch) == eps
    # a velocity with no normal component at this corner: pure roll about the corner's x1 axis line
    v = np.array([x2 * 1.0, 0.0, 1.0])
    assert abs(n @ v) <= 4 * EPS * abs(x2)
    v_after, impulse = impact_map(SCENE1_ATTITUDE, v, corner, scene)
    expected = (1.0 + alpha) * eps * scene.disk.speed / G
    assert impulse > 0.0
    assert impulse == pytest.approx(expected, rel=64 * EPS, abs=0)
    # restitution holds on the relative normal velocity U + eps V
    wedge = eps * scene.disk.speed
    assert -n @ v_after + wedge == pytest.approx(-alpha * wedge, rel=1e3 * EPS, abs=0)
    # no wedging, no disk speed or no inclination: nothing happens
    for off in (
        dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, wedging=False)),
        dataclasses.replace(scene, disk=dataclasses.replace(scene.disk, speed=0.0)),
    ):
        assert impact_map(SCENE1_ATTITUDE, v, corner, off)[1] == 0.0


def normal_response(scene, corner: int) -> tuple[float, float]:
    """G(mu) = n . M^-1 g(mu) at a corner, linear in mu: its value at mu = 0 and its slope."""
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    minv = np.linalg.inv(mass_matrix(scene.slider))
    e = scene.slider.friction_lever
    G0 = n @ minv @ impulse_direction(x1, x2, 0.0, e)
    return G0, n @ minv @ (impulse_direction(x1, x2, 1.0, e) - impulse_direction(x1, x2, 0.0, e))


@pytest.mark.parametrize("corner", CORNER_INDICES)
def test_friction_beyond_the_painleve_limit_raises(corner):
    # G(mu) = n.M^-1 g(mu) is linear in mu; it reaches zero only at the front corners
    # (friction lifts the nose there) -- beyond that the impact is indeterminate
    base = scene_with(mu=0.0, alpha=0.8)
    G0, slope = normal_response(base, corner)
    assert G0 > 0.0
    v = approaching_velocities(np.random.default_rng(60 + corner), base, corner, count=1)[0]
    if corner_is_front(base.slider)[corner]:
        assert slope < 0.0
        limit = -G0 / slope
        impact_map(SCENE1_ATTITUDE, v, corner, scene_with(mu=0.99 * limit, alpha=0.8))
        with pytest.raises(ContactError, match=f"corner {CORNERS[corner]}"):
            impact_map(SCENE1_ATTITUDE, v, corner, scene_with(mu=1.01 * limit, alpha=0.8))
    else:
        assert slope > 0.0
        assert impact_map(SCENE1_ATTITUDE, v, corner, scene_with(mu=1e3, alpha=0.8))[1] > 0.0


# ---------------------------------------------------------------------------- the run's resolution


def touching_attitude(rng, scene, corner):
    """A random attitude (scene-1 magnitudes) whose ``corner`` sits exactly at the asperity height, the others above."""
    corners = corner_positions(scene.slider)
    h0 = scene.disk.asperity_height
    while True:
        pitch, roll = rng.normal(0.0, [100e-6, 50e-6])
        x1, x2 = corners[corner]
        q = np.array([h0 + x1 * pitch + x2 * roll, pitch, roll])
        others = np.delete(corners, corner, axis=0)
        if np.all(q[0] - others[:, 0] * pitch - others[:, 1] * roll > h0 + 1e-9):
            return q


def lone_corner_case(rng, scene, corner):
    """(q, v): ``corner`` touching and approaching (U + eps V > 1e-4 m/s), every other corner clear."""
    q = touching_attitude(rng, scene, corner)
    x1, x2 = corner_positions(scene.slider)[corner]
    eps = surface_slope(scene, corner, float(q[1]))
    while True:
        v = rng.normal(0.0, [0.02, 10.0, 20.0])
        if -corner_normal(x1, x2) @ v + eps * scene.disk.speed > 1e-4:
            return q, v


def free_contact(scene):
    normals = np.array([corner_normal(x1, x2) for x1, x2 in corner_positions(scene.slider)])
    minv = np.linalg.inv(mass_matrix(scene.slider))
    return SustainedContact(scene, normals, minv, scene.disk.asperity_height)


@pytest.mark.parametrize("corner", CORNER_INDICES)
@pytest.mark.parametrize(("mu", "alpha"), [(0.0, 0.85), (0.5, 0.85), (0.5, 0.0), (0.3, 1.0), (1.5, 0.5)])
@pytest.mark.parametrize("rule", ["on", "off"])
def test_lone_corner_resolution_is_the_impact_map(corner, mu, alpha, rule):
    # the run resolves impacts with resolve_impacts (several corners at once, holds); with one free corner
    # touching and approaching, and the chattering rule not applying (off, or the corner not pressed on),
    # it must be the single-corner law impact_map
    rest_velocity = 0.0 if rule == "off" else Contact().rest_velocity
    scene = scene_with(mu=mu, alpha=alpha, wedging=True, rest_velocity=rest_velocity)
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    rng = np.random.default_rng(1000 * corner + int(100 * mu) + int(10 * alpha))
    h0 = scene.disk.asperity_height
    touch_tol = 1e-9 * h0
    minv = np.linalg.inv(mass_matrix(scene.slider))
    for _ in range(20):
        q, v = lone_corner_case(rng, scene, corner)
        # the rule off: any acceleration; on: the film lifts the corner (n . a > 0), so it is not pressed on
        acc = rng.normal(0.0, [1e3, 1e6, 1e6])
        if rule == "on" and n @ acc <= 0.0:
            acc = -acc
        contact = free_contact(scene)
        impacts = []
        v_run = resolve_impacts(scene, q, v.copy(), 1e-6, contact, acc, impacts, touch_tol)
        v_map, impulse = impact_map(q, v, corner, scene, minv)
        assert impulse > 0.0
        assert [(i.time, i.corner) for i in impacts] == [(1e-6, corner)]
        assert impacts[0].impulse == pytest.approx(impulse, rel=1e-12, abs=0)
        np.testing.assert_allclose(v_run, v_map, rtol=0, atol=1e-12 * np.max(np.abs(v) + np.abs(v_map)))
        relative = -n @ v + surface_slope(scene, corner, float(q[1])) * scene.disk.speed
        assert impacts[0].approach_before == pytest.approx(relative, rel=1e-12, abs=0)
        assert not contact.any_held


def source_response(scene: Scene, corner: int) -> float:
    """G = J - x1 J1 - x2 J2 from the source's coefficients (J2 = -x2 / I2, sign corrected): 1 / the effective mass."""
    s, mu = scene.slider, scene.contact.mu
    m, a, I1, I2, e = s.mass, s.cg_offset, s.pitch_inertia, s.roll_inertia, s.friction_lever
    x1, x2 = corner_positions(s)[corner]
    det = m * I1 - (m * a) ** 2
    return (I1 + m * a * (x1 + e * mu)) / det + x1 * (m * a + m * (x1 + e * mu)) / det + x2 * x2 / I2


@pytest.mark.parametrize("law", RESTITUTION_MODELS)
@pytest.mark.parametrize("corner", CORNER_INDICES)
@pytest.mark.parametrize("mu", [0.0, 0.5, 1.5])
def test_lone_corner_impact_applies_and_records_its_law_s_coefficient(law, corner, mu):
    # the coefficient an impact records is the one it applied: the relative normal velocity U + eps V reverses by
    # it, the generalized momentum changes by the impulse along g, and under Thornton's law it is contact.alpha
    # e_T(V / V_y) with V_y of the corner's effective mass 1 / G (G from the source's J, J1, J2)
    scene = scene_with(mu=mu, alpha=0.9, wedging=True, restitution=law, corner_radius=50e-6)  # V_y ~ 17 mm/s
    x1, x2 = corner_positions(scene.slider)[corner]
    n = corner_normal(x1, x2)
    g = impulse_direction(x1, x2, mu, scene.slider.friction_lever)
    M = mass_matrix(scene.slider)
    c = scene.contact
    v_y = yield_velocity(c.corner_radius, c.contact_modulus, c.yield_pressure, 1.0 / source_response(scene, corner))
    rng = np.random.default_rng(2000 + 100 * corner + int(10 * mu))
    speeds = []
    for _ in range(20):
        q, v = lone_corner_case(rng, scene, corner)
        acc = rng.normal(0.0, [1e3, 1e6, 1e6])
        acc = acc if n @ acc > 0.0 else -acc  # lifted by the film: not pressed on, no hold
        impacts = []
        v_after = resolve_impacts(scene, q, v.copy(), 0.0, free_contact(scene), acc, impacts, 1e-9 * 50e-9)
        (imp,) = impacts
        speed = imp.approach_before
        speeds.append(speed / v_y)
        if law == "constant":
            assert imp.alpha == c.alpha and math.isnan(imp.yield_velocity)
        else:
            assert imp.yield_velocity == pytest.approx(v_y, rel=1e-12, abs=0)
            assert imp.alpha == pytest.approx(c.alpha * thornton_e(speed, v_y), rel=1e-14, abs=0)
        assert not imp.held
        assert imp.approach_after == pytest.approx(-imp.alpha * speed, rel=1e-10, abs=0)
        scale = np.abs(M) @ (np.abs(v_after) + np.abs(v))
        assert np.all(np.abs(M @ (v_after - v) - imp.impulse * g) <= 16 * EPS * scale)
    if law == "thornton":  # the random approaches cover the elastic and the plastic side of V_y
        assert min(speeds) < 1.0 < max(speeds)


def test_the_constant_law_is_the_source_s_formula_to_the_last_bit():
    # restitution = "constant" must keep every scene-1 result: the map's impulse is (1 + alpha) (U + eps V) / G
    # exactly as before the law could be chosen
    scene = scene_with(mu=0.5, alpha=0.85, wedging=True)
    assert scene.contact.restitution == "constant"
    minv = np.linalg.inv(mass_matrix(scene.slider))
    for corner in CORNER_INDICES:
        x1, x2 = corner_positions(scene.slider)[corner]
        n = corner_normal(x1, x2)
        response = minv @ impulse_direction(x1, x2, 0.5, scene.slider.friction_lever)
        for v in approaching_velocities(np.random.default_rng(80 + corner), scene, corner):
            v_after, impulse = impact_map(SCENE1_ATTITUDE, v, corner, scene, minv)
            relative = -float(n @ v) + surface_slope(scene, corner, float(SCENE1_ATTITUDE[1])) * scene.disk.speed
            expected = (1.0 + 0.85) * relative / float(n @ response)
            assert impulse == expected
            assert np.array_equal(v_after, v + response * expected)


@pytest.mark.parametrize("corner", [c for c in CORNER_INDICES if corner_is_front(Slider())[c]])
def test_lone_corner_resolution_shares_the_painleve_limit(corner):
    # beyond the limit (the front corners have one) both refuse the impact
    base = scene_with(mu=0.0, alpha=0.8)
    G0, slope = normal_response(base, corner)
    scene = scene_with(mu=-1.01 * G0 / slope, alpha=0.8)
    q, v = lone_corner_case(np.random.default_rng(70 + corner), scene, corner)
    with pytest.raises(ContactError):
        impact_map(q, v, corner, scene)
    with pytest.raises(ContactError, match="Painleve"):
        resolve_impacts(scene, q, v, 0.0, free_contact(scene), np.zeros(3), [], 1e-9 * scene.disk.asperity_height)


@pytest.mark.skipif(JIT_DISABLED, reason="a whole run: 40 s in pure Python; the JIT-off pass checks the laws")
def test_runs_resolve_every_impact_through_contact_resolve_impacts(monkeypatch):
    # the source case (mu 0.5, alpha 0.85) on the small grid: every impact the run records is one that
    # solver.rails.contact.resolve_impacts appended, through the name the integrator calls
    assert integrate.resolve_impacts is contact_module.resolve_impacts
    seen = []
    calls = []

    def counting(scene, q, v, t, contact, acc, impacts, touch_tol):
        n_before = len(impacts)
        out = contact_module.resolve_impacts(scene, q, v, t, contact, acc, impacts, touch_tol)
        calls.append(t)
        seen.extend(impacts[n_before:])
        return out

    monkeypatch.setattr(integrate, "resolve_impacts", counting)
    r = integrate.simulate(small_scene(contact=Contact(mu=0.5, alpha=0.85)))
    assert r.status == 0, r.message
    assert len(r.impacts) >= 5
    assert r.work["impacts"] == len(r.impacts) == len(seen)
    assert all(a is b for a, b in zip(seen, r.impacts, strict=True))
    assert len(calls) >= len({i.time for i in r.impacts})
