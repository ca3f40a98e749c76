"""Contact damping of scene kind "abs" (``contact.damping_ratio``, :func:`solver.kernels.surface.contact_damping`).

References: the law's own definition on one patch (c = 2 zeta sqrt(k m*)),
the damping matrix as the derivative of the force with respect to the
velocities (exact: the force is linear in them), the modal damping ratios
of stiffness-proportional damping (zeta_j = zeta omega_j / omega_c, with
omega_c^2 the sum of the contact's squared frequencies), and a flat face's
landing, a one-degree-of-freedom damped Hertzian impact whose rebound
speed an independent ODE solve (scipy's solve_ivp) gives.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import drop_scene, start_at
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

from solver.abs.dynamics import mass_matrix
from solver.abs.face import abs_grid
from solver.abs.forces import SurfaceModel
from solver.abs.integrate import simulate_abs
from solver.abs.params import AbsScene
from solver.kernels import surface as ksurf
from solver.kinds import scene_from_dict
from solver.params import ParameterError

EPS = 0.3e-9
GW_COEF = 4.0 / 3.0 * 1e14 * 94e9 * math.sqrt(1e-6)


def mass() -> np.ndarray:
    """A slider's mass matrix about a pivot off its mass centre (full, not diagonal)."""
    m, dx = 0.58e-6, 0.1e-3
    return np.array([[m, -m * dx, 0.0], [-m * dx, 4.0e-14 + m * dx * dx, 0.0], [0.0, 0.0, 2.5e-14]])


def cells(n: int, seed: int):
    """n contact patches on a 0.1-mm pad at the trailing edge, all in contact (d < eps), smooth (sigma 0)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.3e-3, 0.4e-3, n)
    y = rng.uniform(-0.05e-3, 0.05e-3, n)
    b = np.ascontiguousarray(np.stack([np.ones(n), -x, -y]))
    offset = EPS - rng.uniform(0.1e-9, 1.0e-9, n)  # the spacing at q = 0: 0.1-1 nm into the wall
    return offset, np.zeros(n), b, np.full(n, 25e-12)


def damping(offset, sigma, b, area, v, rate, zeta, mu=0.0, arm=(0.0, -0.23e-3, 0.0), q=(0.0, 0.0, 0.0), jac=False):
    """The kernel's damping normal force, generalized force and -df/dv (and df/dq with ``jac``)."""
    f, dfdq, C = np.zeros(3), np.zeros((3, 3)), np.empty((3, 3))
    normal = ksurf.contact_damping(
        offset, sigma, b, area, np.asarray(q, float), np.asarray(v, float), np.asarray(rate, float), EPS, GW_COEF,
        np.linalg.inv(mass()), zeta, mu, np.asarray(arm, float), f, dfdq, C,
    )  # fmt: skip
    return (normal, f, C, dfdq) if jac else (normal, f, C)


@pytest.mark.jitless
def test_one_patch_has_the_damping_ratio_of_its_effective_mass():
    """One patch: F = -2 zeta sqrt(k m*) (b . v - disk rate), m* = 1 / (b^T M^-1 b); none if it moves with the disk."""
    offset, sigma, b, area = cells(1, 0)
    k = -ksurf.contact_pressure(offset[0], 0.0, EPS, GW_COEF)[1] * area[0]  # [N/m]
    m_star = 1.0 / (b[:, 0] @ np.linalg.solve(mass(), b[:, 0]))
    v, rate = np.array([-2e-3, 0.5, -0.3]), np.array([4e-4])
    normal, f, _ = damping(offset, sigma, b, area, v, rate, 0.05)
    expected = -2.0 * 0.05 * math.sqrt(k * m_star) * (b[:, 0] @ v - rate[0])
    assert normal == pytest.approx(expected, rel=1e-12)
    assert f == pytest.approx(expected * b[:, 0], rel=1e-12)
    normal, f, _ = damping(offset, sigma, b, area, v, [b[:, 0] @ v], 0.05)  # moving with the disk: no damping
    assert abs(normal) < 1e-12 * abs(expected) and np.all(f == 0.0)
    # separating fast, the damping would out-pull the elastic pressure: the contact force is zero, not tensile
    pc = ksurf.contact_pressure(offset[0], 0.0, EPS, GW_COEF)[0] * area[0]
    separating = np.array([0.5, 0.0, 0.0])
    assert 2.0 * 0.05 * math.sqrt(k * m_star) * (b[:, 0] @ separating) > pc
    normal, f, C = damping(offset, sigma, b, area, separating, [0.0], 0.05)
    assert normal == pytest.approx(-pc, rel=1e-12) and f == pytest.approx(-pc * b[:, 0], rel=1e-12)
    assert np.all(C == 0.0)


def clamped_cells(offset, b, area, v, rate, zeta, q=(0.0, 0.0, 0.0)):
    """How many of the (smooth) cells would pull, p_c + p_d < 0, computed here from the law's definition."""
    d = offset + np.asarray(q) @ b
    pc, dpc = np.vectorize(lambda x: ksurf.contact_pressure(x, 0.0, EPS, GW_COEF))(d)
    g = np.einsum("in,ij,jn->n", b, np.linalg.inv(mass()), b)
    c = 2.0 * zeta * (-dpc) / math.sqrt(np.sum(-dpc * area * g))
    return int(np.count_nonzero(pc - c * (v @ b - rate) < 0.0))


#: Velocities at which all twelve cells approach the disk, and at which some separate fast enough to be clamped.
VELOCITIES = {"approaching": np.array([-1e-3, 0.2, 0.1]), "mixed": np.array([0.05, 20.0, 0.1])}


def twelve_cells(motion: str):
    """Twelve smooth cells in contact, their disk rates and the face's velocities of ``motion``."""
    return (*cells(12, 1), np.random.default_rng(2).uniform(-1e-3, 1e-3, 12), VELOCITIES[motion])


@pytest.mark.jitless
@pytest.mark.parametrize("mu", [0.0, 0.4])
@pytest.mark.parametrize("motion", list(VELOCITIES))
def test_damping_matrix_is_minus_the_velocity_derivative(mu, motion):
    """The matrix returned with the force is -df/dv, with the friction of the damping force's normal part."""
    offset, sigma, b, area, rate, v = twelve_cells(motion)
    clamped = clamped_cells(offset, b, area, v, rate, 0.07)
    assert clamped == 0 if motion == "approaching" else 0 < clamped < 12
    _, f0, C = damping(offset, sigma, b, area, v, rate, 0.07, mu)
    for k in range(3):
        dv = np.zeros(3)
        dv[k] = 1e-3 * max(abs(v[k]), 1.0)
        _, f1, _ = damping(offset, sigma, b, area, v + dv, rate, 0.07, mu)
        # linear in v: the difference quotient is exact up to round-off
        assert (f1 - f0) / dv[k] == pytest.approx(-C[:, k], rel=1e-8, abs=1e-10 * np.abs(C).max())


@pytest.mark.jitless
@pytest.mark.parametrize("sigma", [0.0, 0.3e-9], ids=["smooth", "rough"])
@pytest.mark.parametrize("motion", list(VELOCITIES))
def test_attitude_derivative_matches_central_differences(sigma, motion):
    """df/dq (the coefficients' change with the spacing, omega_c's included; clamped cells) against differences."""
    offset, _, b, area = cells(12, 4)
    rough = np.full(12, sigma)
    rate = np.random.default_rng(5).uniform(-1e-3, 1e-3, 12)
    v, q = VELOCITIES[motion], np.array([0.05e-9, 0.0, 0.0])
    if sigma == 0.0:
        clamped = clamped_cells(offset, b, area, v, rate, 0.07, q)
        assert clamped == 0 if motion == "approaching" else 0 < clamped < 12
    _, _, _, dfdq = damping(offset, rough, b, area, v, rate, 0.07, 0.4, q=q, jac=True)
    for k, step in enumerate((1e-13, 1e-10, 1e-10)):  # [m], [rad]: the spacing moves by at most 0.04 pm
        dq = np.zeros(3)
        dq[k] = step
        _, plus, _ = damping(offset, rough, b, area, v, rate, 0.07, 0.4, q=q + dq)
        _, minus, _ = damping(offset, rough, b, area, v, rate, 0.07, 0.4, q=q - dq)
        assert (plus - minus) / (2 * step) == pytest.approx(dfdq[:, k], rel=1e-5, abs=1e-6 * np.abs(dfdq).max())


@pytest.mark.jitless
def test_a_patch_in_the_far_tail_is_no_contact():
    """A rough patch 38.4 sigma above the asperities' mean plane had no contact pressure (it underflows) but a
    subnormal stiffness: omega_c^2 ~ 1e-309, whose reciprocal overflowed (nan, and a run failed on it).  Beyond
    T_NEGLIGIBLE the law is 0 with its slope; just inside it (11.9 sigma) the stiffness is positive but omega_c^2
    lies below CONTACT_OMEGA2_FLOOR.  Both have no contact damping: zero force and finite zero matrices, while a
    patch one sigma above the plane is damped."""
    sigma = 0.0838e-9
    b = np.array([[1.0], [-0.35e-3], [0.0]])
    area = np.array([25e-12])
    for t, damped in ((38.36, False), (11.9, False), (1.0, True)):
        offset = np.array([EPS + t * sigma])
        pc, dpc = ksurf.contact_pressure(offset[0], sigma, EPS, GW_COEF)
        if t >= ksurf.T_NEGLIGIBLE:
            assert pc == 0.0 and dpc == 0.0
        else:
            assert (0.0 < pc and 0.0 < -dpc < 1e-10) if not damped else dpc < 0.0
        normal, f, C, dfdq = damping(offset, np.array([sigma]), b, area, (-1e-3, 0.0, 0.0), (0.0,), 0.1, jac=True)
        assert np.all(np.isfinite(f)) and np.all(np.isfinite(C)) and np.all(np.isfinite(dfdq))
        assert (normal != 0.0) == damped and (np.any(C != 0.0)) == damped


@pytest.mark.jitless
def test_modal_damping_ratios_of_a_spread_contact():
    """Spread over a pad, the damping is stiffness-proportional: zeta_j = zeta omega_j / omega_c.

    The stiffest mode gets at least zeta / sqrt(3): omega_c^2 is the trace of M^-1 K_c, the sum of the contact
    modes' squared frequencies.
    """
    zeta = 0.05
    offset, sigma, b, area = cells(40, 3)
    _, dpc = np.vectorize(lambda d: ksurf.contact_pressure(d, 0.0, EPS, GW_COEF))(offset)
    K = (b * (-dpc * area)) @ b.T
    _, _, C = damping(offset, sigma, b, area, np.zeros(3), np.zeros(40), zeta)
    omega2, modes = eigh(K, mass())
    ratios = np.array([modes[:, j] @ C @ modes[:, j] / (2.0 * math.sqrt(omega2[j])) for j in range(3)])
    omega_c = math.sqrt(omega2.sum())
    assert ratios == pytest.approx(zeta * np.sqrt(omega2) / omega_c, rel=1e-9)
    assert zeta / math.sqrt(3.0) <= ratios.max() <= zeta


def rebound(m: float, force, v0: float) -> float:
    """Rebound speed of m x'' = force(-x, x') from x = 0, x' = -v0 (x: the spacing above first touch)."""

    def rhs(_, y):
        return [y[1], force(max(-y[0], 0.0), y[1]) / m]

    def leaves(_, y):
        return y[0]

    leaves.terminal, leaves.direction = True, 1.0
    sol = solve_ivp(rhs, (0.0, 1e-4), [0.0, -v0], events=leaves, rtol=1e-11, atol=1e-20, first_step=1e-12)
    return float(sol.y_events[0][0][1])


def damped_hertz_rebound(m: float, stiffness: float, zeta_z: float, v0: float) -> float:
    """Rebound speed of m x'' = max(K delta^(3/2) - 2 zeta_z sqrt(k m) x', 0), k = 3/2 K delta^(1/2), from x' = -v0."""

    def force(delta, rate):
        k = 1.5 * stiffness * math.sqrt(delta)
        return max(stiffness * delta**1.5 - 2.0 * zeta_z * math.sqrt(k * m) * rate, 0.0)  # a contact cannot pull

    return rebound(m, force, v0)


def test_flat_landing_is_the_damped_hertz_impact():
    """A flat face landing on a smooth GW wall with zeta = 0.1: the rebound speed of the 1-DOF damped Hertz impact.

    All patches share the spacing, so the face is one Hertzian spring K delta^(3/2) with damping
    sum_i A_i c_i = 2 zeta K_c / omega_c, omega_c^2 = sum_i A_i k b_i^T M^-1 b_i: a 1-DOF damping ratio
    zeta_z = zeta sqrt(K_c / m) / omega_c (0.059 here); the contact force is never tensile (the damping
    would pull at the end of the rebound, where it outgrows the elastic force).  The ODE's restitution does
    not depend on the landing speed (1 and 3 mm/s: equal to 1e-8): c grows like delta^(1/4) and the impact has
    no scale.  Measured, trapezoidal rule, rebound speed against the ODE's: +7.5e-4 and +3.0e-4 at dt 0.05 us,
    -1.0e-4 and -8.8e-5 at 0.0125 us (the clamp's kink, met between samples, keeps it from second order).
    """
    zeta = 0.1
    restitution = []
    for v0 in (1e-3, 3e-3):
        errors = []
        for dt in (0.05e-6, 0.0125e-6):
            scene = drop_scene(dt, rho=1.0)
            scene = dataclasses.replace(
                scene,
                contact=dataclasses.replace(scene.contact, damping_ratio=zeta),
                initial=dataclasses.replace(scene.initial, zdot=-v0),
            )
            surface = SurfaceModel(scene, abs_grid(scene))
            g = np.einsum("in,ij,jn->n", surface.b, np.linalg.inv(mass_matrix(scene)), surface.b)  # 1 / m*
            zeta_z = zeta * math.sqrt(surface.area.sum() / (scene.slider.mass * (surface.area * g).sum()))
            expected = damped_hertz_rebound(scene.slider.mass, surface.area.sum() * surface.gw_coef, zeta_z, v0)
            # 2.01 nm: a step that ends exactly at first touch puts Newton's root where c' is infinite
            result = simulate_abs(scene, start_at(scene, [scene.contact.equilibrium_spacing + 2.01e-9, 0.0, 0.0]))
            assert result.status == 0, result.message
            assert result.series["contact_force"].max() > 0.0 and result.series["contact_force"][-1] == 0.0
            errors.append(result.v[-1, 0] / expected - 1.0)
        assert abs(errors[0]) < 1e-3 and abs(errors[1]) < min(2e-4, abs(errors[0])), errors
        restitution.append(expected / v0)
    assert restitution[0] == pytest.approx(restitution[1], rel=1e-8)
    assert 0.75 < restitution[0] < 0.9  # and it damps: a linear spring with zeta_z 0.059 would give 0.83


@pytest.mark.jitless
def test_damping_ratio_is_checked():
    base = {"kind": "abs", "contact": {"damping_ratio": 0.05}}
    assert scene_from_dict(base).contact.damping_ratio == 0.05
    with pytest.raises(ParameterError, match=r"contact.damping_ratio = -0.1"):
        scene_from_dict({"kind": "abs", "contact": {"damping_ratio": -0.1}})
    assert scene_from_dict(base | {"models": {"contact": "elastic"}}).contact.damping_ratio == 0.05
    with pytest.raises(
        ParameterError, match=r"contact.damping_ratio = 0.05 is not allowed with models.contact = 'none'"
    ):
        scene_from_dict(base | {"models": {"contact": "none"}})


# ----------------------------------------------------------------------------- the elastic law's damping


def elastic_drop(dt: float, zeta: float, v0: float = 1e-3, mu: float = 0.0) -> AbsScene:
    """:func:`drop_scene` on elastic half-spaces of 1 GPa (a flat punch of k ~ 4e5 N/m: 3.8-us impacts)."""
    scene = drop_scene(dt, rho=1.0, mu=mu)
    contact = dataclasses.replace(scene.contact, damping_ratio=zeta, slider_modulus=1e9, disk_modulus=1e9)
    return dataclasses.replace(scene, contact=contact, models=dataclasses.replace(scene.models, contact="elastic"),
                               initial=dataclasses.replace(scene.initial, zdot=-v0))  # fmt: skip


@pytest.mark.jitless
@pytest.mark.parametrize("mu", [0.0, 0.4])
@pytest.mark.parametrize("motion", list(VELOCITIES))
def test_elastic_damping_on_uncoupled_cells_is_the_greenwood_williamson_law(mu, motion):
    """With a diagonal stiffness (no elastic coupling) the elastic law's damping is the GW kernel's, clamps and all."""
    offset, sigma, b, area, rate, v = twelve_cells(motion)
    pc, dpc = np.vectorize(lambda d: ksurf.contact_pressure(d, 0.0, EPS, GW_COEF))(offset)
    surface = SurfaceModel(elastic_drop(0.05e-6, 0.07, mu=mu), abs_grid(elastic_drop(0.05e-6, 0.07)))
    surface.friction_arm = np.array([0.0, -0.23e-3, 0.0])
    pd, c_d = surface._elastic_damping(pc, np.diag(dpc), area, b, (0.07, np.linalg.inv(mass()), v, rate))
    normal, f, C = damping(offset, sigma, b, area, v, rate, 0.07, mu)
    assert (pd * area).sum() == pytest.approx(normal, rel=1e-12)
    lever = b + mu * surface.friction_arm[:, None]
    assert lever @ (pd * area) == pytest.approx(f, rel=1e-12, abs=1e-12 * np.abs(f).max())
    assert c_d == pytest.approx(C, rel=1e-12, abs=1e-12 * np.abs(C).max())


@pytest.mark.jitless
@pytest.mark.parametrize("motion", list(VELOCITIES))
def test_elastic_damping_matrix_is_minus_the_velocity_derivative(motion):
    """On a pitched face pressed into the half-spaces (coupled cells, some clamped when separating): -df/dv."""
    scene = elastic_drop(0.05e-6, 0.07, mu=0.3)
    surface = SurfaceModel(scene, abs_grid(scene))
    q = np.array([EPS - 0.4e-9, 1.5e-6, 0.2e-6])  # the trailing edge about 0.5 nm in, the leading edge out
    disk, sigma = np.zeros(surface.grid.shape), np.zeros(surface.grid.shape)
    cells_ = surface.candidates(disk, sigma, q, 0.0)
    rate = np.random.default_rng(6).uniform(-1e-4, 1e-4, cells_.index.size)
    v = {"approaching": np.array([-1e-3, 0.2, 0.1]), "mixed": np.array([2e-4, 3.0, 0.5])}[motion]
    m_inv = np.linalg.inv(mass_matrix(scene))
    base = surface.forces_on(cells_, q, (0.07, m_inv, v, rate))
    undamped = surface.forces_on(cells_, q)
    assert base.contact != pytest.approx(undamped.contact, rel=1e-3)  # the damping acts
    assert undamped.contact > 0.0 and base.contact >= 0.0
    for k in range(3):
        dv = np.zeros(3)
        dv[k] = 1e-3 * max(abs(v[k]), 1e-3)
        moved = surface.forces_on(cells_, q, (0.07, m_inv, v + dv, rate))
        assert (moved.f - base.f) / dv[k] == pytest.approx(-base.damping[:, k], rel=1e-6,
                                                           abs=1e-9 * np.abs(base.damping).max())  # fmt: skip


def damped_linear_rebound(m: float, k: float, c: float, v0: float) -> float:
    """Rebound speed of m x'' = max(k delta - c x', 0) (delta = -x in contact, no force outside; a contact cannot
    pull) from x' = -v0."""
    return rebound(m, lambda delta, rate: max(k * delta - c * rate, 0.0) if delta > 0.0 else 0.0, v0)


def test_flat_elastic_landing_is_the_damped_linear_impact():
    """A flat face landing on elastic half-spaces: every cell in contact shares the penetration, so the face is one
    linear spring k = 1^T (A C^-1) 1 (a flat punch) with the damping c = 2 zeta k_zz / omega_c: the rebound of
    the 1-DOF spring-dashpot that cannot pull.  Undamped, the landing is elastic (restitution 1).  Measured
    (11 x 11 cells, trapezoidal rule), rebound against the ODE's: zeta 0: +2.8e-5 at dt 0.04 us; zeta 0.1:
    +8.2e-4 at 0.04 us, -3.0e-5 at 0.02 us (restitution 0.882)."""

    def landing(dt: float, zeta: float) -> tuple[float, float]:
        scene = elastic_drop(dt, zeta)
        scene = dataclasses.replace(scene, numerics=dataclasses.replace(scene.numerics, t_end=6e-6, nx=11, ny=11))
        surface = SurfaceModel(scene, abs_grid(scene))
        m_inv = np.linalg.inv(mass_matrix(scene))
        q_in = np.array([EPS - 0.5e-9, 0.0, 0.0])
        cells_ = surface.candidates(np.zeros(surface.grid.shape), np.zeros(surface.grid.shape), q_in, 0.0)
        pressed = surface.forces_on(cells_, q_in, (max(zeta, 1e-12), m_inv, np.zeros(3), np.zeros(cells_.index.size)))
        k = -pressed.dfdq[0, 0]
        assert pressed.contact == pytest.approx(k * 0.5e-9, rel=1e-9)  # linear: a flat punch
        c = pressed.damping[0, 0] * (zeta / max(zeta, 1e-12))
        expected = damped_linear_rebound(scene.slider.mass, k, c, 1e-3)
        result = simulate_abs(scene, start_at(scene, [EPS + 1.01e-9, 0.0, 0.0]))
        assert result.status == 0, result.message
        assert result.series["contact_force"].max() > 0.0 and result.series["contact_force"][-1] == 0.0
        return result.v[-1, 0] / expected - 1.0, expected

    error, expected = landing(0.04e-6, 0.0)
    assert expected == pytest.approx(1e-3, rel=1e-6) and abs(error) < 1e-4
    coarse, expected = landing(0.04e-6, 0.1)
    fine, _ = landing(0.02e-6, 0.1)
    assert abs(coarse) < 2e-3 and abs(fine) < abs(coarse) / 4, (coarse, fine)
    assert expected / 1e-3 < 0.9  # it damps
