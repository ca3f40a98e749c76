"""Partial-contact dynamics of scene kind "abs" (:mod:`solver.abs.integrate`).

References: steady flight as a fixed point of the time integrator; the
bounce of a flat slider on a Greenwood-Williamson wall, a one-degree-of-
freedom impact whose rebound speed, penetration and contact time are known
in closed form (m z'' = k delta^(3/2): delta_max = (5 m v0^2 / (4 k))^(2/5),
t_c = 2 (delta_max / v0) int_0^1 du / sqrt(1 - u^(5/2))); the discrete
energy and impulse balances of Newmark's average-acceleration rule; central
differences for the surface forces' Jacobian; a sinusoid for the run
summary; the moving track as a rigid shift of the disk profile.

Starting a run from a chosen attitude needs a hand-built ``AbsSteady``
(:func:`start_at`): ``simulate_abs`` takes the initial velocity from
``scene.initial`` and the attitude only from a full steady-flight record.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import LENGTH, WIDTH, chen_bogy, drop_scene, start_at
from scipy.integrate import quad

from solver.abs.dynamics import mass_matrix
from solver.abs.face import abs_grid
from solver.abs.film import AbsFilm
from solver.abs.forces import SurfaceModel
from solver.abs.integrate import AbsResult, contact_splits_needed, simulate_abs, summarize
from solver.abs.params import ADHESION_LAWS, AbsScene
from solver.abs.steady import fly_start
from solver.abs.track import Track
from solver.surface import surface_pressures

#: The coarsest grid that resolves every region of chen_bogy2007.
COARSE = {"numerics.nx": 41, "numerics.ny": 31, "numerics.refine_nodes": 2}

# steady flight ---------------------------------------------------------------------------------------------


def test_steady_flight_stays_steady():
    """Smooth disk, no adhesion, pad flying 1.9 nm above the disk: 100 us from steady flight change nothing.

    No contact, bouncing 3-sigma and flying-height drift far below 1e-3 nm
    (measured 3.5e-15 m and 1.4e-14 m at dt 0.2 us), and bounded work: at most 6 Newton iterations and 3 film
    steps per time step.
    """
    scene = chen_bogy(
        COARSE
        | {
            "slider.trailing_pad_width": 120e-6,
            "disk.rms": 0.0,
            "contact.delta_gamma": 0.0,
            "numerics.t_end": 100e-6,
            "numerics.settle_time": 0.0,
        }
    )
    steady = fly_start(scene)
    # measured 1.499 nm at the pad's exact corner (1.86 nm at the nearest node, 41 x 31 nodes; 3.57 nm before the
    # fitted faces)
    assert steady.min_spacing > 1.2e-9
    result = simulate_abs(scene, steady)
    assert result.status == 0, result.message
    summary = summarize(result, scene)
    assert np.max(np.abs(result.series["contact_force"])) <= 1e-12
    assert np.max(np.abs(result.series["adhesion_force"])) == 0.0
    assert summary["bouncing_3sigma"] < 1e-12
    assert np.max(np.abs(result.series["flying_height"] - steady.element_spacing)) < 1e-12
    steps = result.work["steps"]
    assert steps == round(scene.numerics.t_end / scene.numerics.dt)
    assert result.work["newton_iterations"] <= 6 * steps
    assert result.work["reynolds_solves"] <= 3 * steps


# energy and momentum of a bounce ---------------------------------------------------------------------------


def energies(scene: AbsScene, result: AbsResult) -> np.ndarray:
    """Kinetic energy 1/2 v^T M v of every sample [J]."""
    return 0.5 * np.einsum("ni,ij,nj->n", result.v, mass_matrix(scene), result.v)


def drop(dt: float, *, pitch: float = 0.0, mu: float = 0.0, rho: float | None = None, t_end: float = 10e-6):
    """Drop the flat slider from 2 nm above contact at its trailing edge; returns scene, result, kinetic energy."""
    scene = drop_scene(dt, mu=mu, rho=rho, t_end=t_end)
    eps = scene.contact.equilibrium_spacing
    q0 = [eps + 2e-9 + (LENGTH - scene.slider.pivot_x) * pitch, pitch, 0.0]
    result = simulate_abs(scene, start_at(scene, q0))
    assert result.status == 0, result.message
    assert result.work.get("step_halvings", 0) == 0  # every step recorded: the discrete balances hold sample by sample
    contact = result.series["contact_force"]
    assert contact[0] == 0.0 and contact[-1] == 0.0  # starts and ends out of contact: all energy is kinetic
    return scene, result, energies(scene, result)


@pytest.mark.jitless
def test_flat_bounce_is_the_analytic_hertz_impact():
    """A flat face hitting a GW wall is a 1-DOF Hertzian impact: penetration, contact time, rebound speed v0.

    k = A (4/3) eta_s E' sqrt(R) over the whole face, trapezoidal rule
    (rho_infinity = 1), dt = 0.05 us.  Measured: sampled penetration 5.8e-4
    below the analytic 1.0006 nm (the samples straddle the maximum: at most
    a dt^2 / 8 = 4e-4), contact time within one step, rebound speed 1.5e-5
    above v0, no spin (< 1e-15 rad/s).
    """
    dt, v0 = 0.05e-6, 1e-3
    scene, result, _ = drop(dt, rho=1.0)
    c, s = scene.contact, scene.slider
    e_composite = 1.0 / ((1 - c.slider_poisson**2) / c.slider_modulus + (1 - c.disk_poisson**2) / c.disk_modulus)
    k = LENGTH * WIDTH * 4.0 / 3.0 * c.summit_density * e_composite * math.sqrt(c.summit_radius)
    penetration = (5.0 * s.mass * v0**2 / (4.0 * k)) ** 0.4
    duration = 2.0 * penetration / v0 * quad(lambda u: 1.0 / math.sqrt(1.0 - u**2.5), 0.0, 1.0)[0]
    measured = c.equilibrium_spacing - np.min(result.series["clearance"])
    assert measured == pytest.approx(penetration, rel=1e-3)
    touching = result.t[result.series["contact_force"] > 0]
    assert abs(touching[-1] - touching[0] - duration) <= 2 * dt
    assert result.v[-1, 0] == pytest.approx(v0, rel=1e-4)
    assert np.max(np.abs(result.v[:, 1:])) < 1e-12


@pytest.mark.jitless
@pytest.mark.parametrize("rho", [1.0, 0.0, None], ids=["trapezoidal", "rho0", "default"])
def test_contact_energy_error_shrinks_with_dt(rho):
    """The rebound kinetic energy tends to the approach one as dt -> 0; rho_infinity = 0 never creates energy.

    The trapezoidal rule (rho_infinity = 1) conserves energy exactly for
    linear springs; on the Hertzian GW wall its error is the trapezoidal
    rule's on the contact work.  Measured (E_after - E_before) / E_before at
    dt = 0.4, 0.2, 0.1, 0.05 us: trapezoidal +1.05e-2, +1.9e-3, +3.2e-4,
    +3.0e-5 (fitted order 2.8); rho_infinity = 0: -0.119, -2.8e-2, -4.1e-3,
    -6.0e-4 (fitted order 2.6); the default rho_infinity = 0.9: +1.05e-2,
    +1.9e-3, +3.2e-4, +3.0e-5 (order 2.8, within 1 % of the trapezoidal
    rule's: on this hardening contact it creates a little energy); 0.5, the
    default until November 2026: +2.0e-3, +3.2e-4, +1.5e-4, +4.0e-6.  Fixed
    steps (``drop_scene``): with contact substeps the 0.4-us step splits.
    """
    steps = [0.4e-6, 0.2e-6, 0.1e-6, 0.05e-6]
    changes = []
    for dt in steps:
        _, _, kinetic = drop(dt, rho=rho)
        changes.append(kinetic[-1] / kinetic[0] - 1.0)
    order = np.polyfit(np.log(steps), np.log(np.abs(changes)), 1)[0]
    assert abs(changes[-1]) < 1e-3 and order > 1.8, (changes, order)
    if rho == 0.0:
        assert max(changes) <= 1e-12, changes


LANDING = {
    "models.air_bearing": "none",
    "contact.delta_gamma": 0.0,
    "contact.mu": 0.0,
    "disk.rms": 0.0,
    "suspension.preload": 0.0,
    "suspension.vertical_stiffness": 0.0,
    "suspension.pitch_stiffness": 0.0,
    "suspension.roll_stiffness": 0.0,
    "suspension.vertical_damping": 0.0,
    "suspension.pitch_damping": 0.0,
    "suspension.roll_damping": 0.0,
    "initial.zdot": -1e-3,
    "numerics.t_end": 20e-6,
    "numerics.settle_time": 0.0,
}


def landing(overrides: dict) -> tuple[AbsResult, float]:
    """chen_bogy2007 landing at 1 mm/s on its asperities (no air, no suspension): the result, E_after / E_before."""
    scene = chen_bogy(COARSE | LANDING | overrides)
    film = AbsFilm(scene)
    film.set_disk(np.zeros(film.shape))
    q = np.array([0.0, 100e-6, 0.0])
    q[0] = scene.contact.equilibrium_spacing + 2e-9 - film.spacing(q).min()
    result = simulate_abs(scene, start_at(scene, q))
    assert result.status == 0, result.message
    kinetic = energies(scene, result)
    return result, kinetic[-1] / kinetic[0]


FIXED = {"numerics.contact_omega_dt": 0.0}


@pytest.mark.jitless
@pytest.mark.parametrize(
    ("numerics", "steps", "finer_loses_less"),
    [
        (FIXED | {"numerics.rho_infinity": 0.0}, (0.2e-6, 0.1e-6, 0.05e-6), True),
        (FIXED | {"numerics.rho_infinity": 0.5}, (0.1e-6, 0.05e-6, 0.025e-6), True),
        ({}, (0.1e-6, 0.05e-6, 0.025e-6), False),
        ({"numerics.rho_infinity": 0.0}, (0.1e-6, 0.05e-6, 0.025e-6), False),
    ],
    ids=["rho0 fixed", "rho0.5 fixed", "default", "rho0 split"],
)
def test_stiff_landing_creates_no_energy(numerics, steps, finer_loses_less):
    """chen_bogy2007's trailing pad landing at 1 mm/s on real asperities (no air, no suspension): no energy created.

    The contact (1e14 summits/m2) lasts about one step of 0.2 us.  With fixed steps a dissipative generalized-alpha
    step (rho_infinity < 1) dissipates what it cannot resolve.  Measured E_after / E_before with fixed steps:
    rho_infinity = 0: 0.84, 0.86, 0.90, 0.96 at dt = 0.2, 0.1, 0.05, 0.025 us; rho_infinity = 0.5 (the default
    until November 2026): 1.41 (it created 41 % at 0.2 us), 0.965, 0.986, 0.996; rho 0.9: 0.977 at 0.1 us, 1.007 at
    0.05 us; the trapezoidal rule (rho_infinity = 1): 1.75, 0.992, 0.998, 1.0002.  The default (rho 0.9, contact
    substeps to omega_c h <= 0.5, at most 8, rho 0 in the substeps that are still too coarse): 0.99962, 0.99962,
    0.99372 at 0.1, 0.05, 0.025 us (0.928 at 0.2 us; with at most 4 substeps 0.928, 0.99962, 0.99372 and 0.870 at
    0.2 us; 0.99934 at 0.1 us and 1.0071 at 0.2 us with rho 0.9 in every substep).  Split with rho 0: 0.98645,
    0.98645, 0.97178 (at most 4 substeps: 0.938, 0.986, 0.972); before the substeps kept their size through a
    contact and restarted the acceleration at a change of size, 1.0236 and 1.0275 at 0.1 and 0.05 us.
    """
    ratios = []
    for dt in steps:
        result, ratio = landing(numerics | {"numerics.dt": dt, "numerics.output_interval": dt})
        contact = result.series["contact_force"]
        assert contact.max() > 0.0 and contact[-1] == 0.0
        ratios.append(ratio)
    assert max(ratios) <= 1.0 + 1e-12 and min(ratios) > 0.5, ratios
    if finer_loses_less:
        assert ratios[-1] > ratios[0], ratios


@pytest.mark.jitless
def test_the_default_resolves_the_stiff_landing_at_its_step():
    """At the scene's own step (0.2 us) the default's substeps resolve the landing: none falls back to the damping
    spectral radius, and the kinetic energy is kept to the level of the finer steps.

    With at most 4 substeps of 0.1 us (25 ns, the default until this test) the contact outran the finest one, 7
    substeps took rho_infinity_contact = 0 and the landing kept 0.928 of its energy; that damping also held the
    80-um trailing pad's sustained contact down (README, "Scene 2 results").  Measured with at most 8 of 0.1 us:
    0.99962, no damped substep (0.99962 at 0.05 us, 0.99372 at 0.025 us); with at most 16 of 0.2 us (12.5 ns, the
    default since 2026-12-07): 0.99997, 16 contact substeps, 1 redone, none damped.
    """
    result, ratio = landing({"numerics.output_interval": 0.2e-6})
    assert result.work["contact_damped"] == 0, result.work
    assert result.work["contact_substeps"] > 0
    assert 0.99 < ratio <= 1.0 + 1e-12, ratio


@pytest.mark.jitless
def test_contact_substeps_resolve_the_stiff_landing():
    """Steps split where the contact's frequency needs it (numerics.contact_omega_dt) create no energy at 0.2 us.

    With fixed steps of 0.2 us the landing leaves with 1.73 times its kinetic energy (rho_inf = 0.8); split to
    omega_c h <= 0.5 (at most dt / 8) it keeps 0.9993 of it, within 2e-3 of fixed steps of dt / 8 throughout, and
    only the steps in contact are split.  Measured: 1.7321; 0.99929 (8 substeps, 1 redone) against 0.99919.
    """
    base = {"numerics.rho_infinity": 0.8, "numerics.rho_infinity_contact": 0.8, "numerics.output_interval": 0.2e-6,
            "numerics.contact_splits": 3}  # fmt: skip
    fixed, ratio_fixed = landing(base | FIXED | {"numerics.dt": 0.2e-6})
    split, ratio_split = landing(base | {"numerics.dt": 0.2e-6, "numerics.contact_omega_dt": 0.5})
    fine, ratio_fine = landing(base | FIXED | {"numerics.dt": 0.025e-6})
    assert ratio_fixed > 1.5, ratio_fixed
    assert ratio_split <= 1.0 + 1e-4 and abs(ratio_split - ratio_fine) < 2e-3, (ratio_split, ratio_fine)
    work = split.work
    assert work["steps"] == fixed.work["steps"] == 100
    assert 0 < work["contact_substeps"] <= 16 and work["contact_redos"] >= 1, work
    np.testing.assert_allclose(split.t, fixed.t, rtol=0, atol=1e-18)  # the samples stay on the grid of dt
    # up to the fixed run's first step into contact (which the split run takes back) they are the same run
    first = int(np.argmax(fixed.series["contact_force"] > 0.0))
    assert first > 5
    np.testing.assert_array_equal(split.q[:first], fixed.q[:first])
    assert not np.array_equal(split.q[first], fixed.q[first])


@pytest.mark.jitless
def test_substeps_the_contact_outruns_take_the_damping_spectral_radius():
    """A substep still too coarse for the contact (omega_c h > limit at the finest size) takes rho_infinity_contact.

    With no halvings allowed (contact_splits 0) every step in contact is unresolved: the trapezoidal rule leaves the
    stiff landing at 0.2 us with 1.81 times its energy (contact substeps on, rho_infinity_contact 1), and 0.777 of
    it with rho_infinity_contact 0 (1.29 with 0.5): the step into the contact, taken with rho 1 from free flight,
    ends unresolved and is redone with rho 0, and so is the one after.  Out of contact the steps keep rho 1.
    """
    base = {"numerics.dt": 0.2e-6, "numerics.output_interval": 0.2e-6, "numerics.contact_omega_dt": 0.5,
            "numerics.contact_splits": 0}  # fmt: skip
    trapezoidal, ratio_trapezoidal = landing(
        base | {"numerics.rho_infinity": 1.0, "numerics.rho_infinity_contact": 1.0}
    )
    damped, ratio_damped = landing(base | {"numerics.rho_infinity": 1.0, "numerics.rho_infinity_contact": 0.0})
    assert ratio_trapezoidal > 1.5 and ratio_damped < 1.0, (ratio_trapezoidal, ratio_damped)
    touching = damped.series["contact_force"] > 0.0
    assert damped.work["contact_damped"] == 2 and damped.work["contact_redos"] == 1, damped.work
    first = int(np.argmax(touching))
    np.testing.assert_array_equal(damped.q[:first], trapezoidal.q[:first])  # identical until the contact


def test_contact_splits_needed_is_the_fewest_halvings():
    """j = ceil(log2(omega dt / limit)) clipped to [0, most]; 0 out of contact."""
    assert contact_splits_needed(0.0, 0.2e-6, 0.5, 3) == 0
    assert contact_splits_needed(2.5e6, 0.2e-6, 0.5, 3) == 0  # omega dt = 0.5
    assert contact_splits_needed(2.6e6, 0.2e-6, 0.5, 3) == 1
    assert contact_splits_needed(1.0e7, 0.2e-6, 0.5, 3) == 2  # omega dt = 2: 4 substeps of 0.5
    assert contact_splits_needed(1.0e9, 0.2e-6, 0.5, 3) == 3


def friction_work(scene: AbsScene, result: AbsResult) -> float:
    """Work of the friction moments, trapezoidal in q: sum dq . (f_n + f_n+1) / 2, f = mu F_c (0, -t cos, -t sin)."""
    psi = math.radians(scene.disk.skew)
    arm = np.array([0.0, -scene.slider.thickness * math.cos(psi), -scene.slider.thickness * math.sin(psi)])
    friction = result.series["friction_force"]
    return float(np.sum(0.5 * (friction[1:] + friction[:-1]) * (np.diff(result.q, axis=0) @ arm)))


@pytest.mark.jitless
@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_pitched_bounce_energy_and_impulse_balance(mu):
    """Slider pitched 20 urad landing on its trailing edge (then its leading edge): energy and momentum balance.

    Trapezoidal rule (rho_infinity = 1), dt = 0.2 us.  Impulse-momentum:
    the trapezoidal integral of the contact force equals m (v_after -
    v_before) (exact for gamma = 1/2: measured 1e-14 relative; 3e-9 with the
    default rho_infinity = 0).  Energy: E_after - E_before = W_friction (the
    friction moments' work) up to the contact's trapezoidal error, measured
    3.8e-4 (mu = 0) and 2.6e-4 (mu = 0.3) of E_before.

    The friction moment mu F_c t (nose down) is driven by the disk, not by
    the slider: here it does positive work (measured W_friction = +0.24
    E_before; the slider leaves with 24 % more energy) because the
    trailing-edge contact turns the slider nose-down, the sense of the
    moment.  Friction does not dissipate the slider's energy in this rigid
    3-DOF model: the energy it dissipates is the disk's, at the sliding speed.
    """
    scene, result, kinetic = drop(0.2e-6, pitch=20e-6, mu=mu, rho=1.0, t_end=20e-6)
    impulse = np.trapezoid(result.series["contact_force"], result.t)
    momentum = scene.slider.mass * (result.v[-1, 0] - result.v[0, 0])
    assert impulse == pytest.approx(momentum, rel=1e-10)
    work = friction_work(scene, result)
    assert abs(kinetic[-1] - kinetic[0] - work) <= 1e-3 * kinetic[0]
    if mu == 0.0:
        assert work == 0.0
    else:
        assert work > 0.1 * kinetic[0]
    scene, result, kinetic = drop(0.2e-6, pitch=20e-6, mu=mu, t_end=20e-6)
    impulse = np.trapezoid(result.series["contact_force"], result.t)
    assert impulse == pytest.approx(scene.slider.mass * (result.v[-1, 0] - result.v[0, 0]), rel=1e-6)


# surface forces --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def coarse_flight():
    """chen_bogy2007 on the coarse grid: its film (for spacings), surface model and steady attitude."""
    scene = chen_bogy(COARSE)
    film = AbsFilm(scene)
    steady = fly_start(scene, film)
    film.set_disk(np.zeros(film.shape))
    return scene, film, SurfaceModel(scene, film.grid), steady.q


@pytest.mark.jitless
@pytest.mark.parametrize("adhesion", ADHESION_LAWS)
@pytest.mark.parametrize("sigma", [0.0, 0.2e-9, 0.6e-9])
@pytest.mark.parametrize("drop_by", [2.0e-9, 4.3e-9, 5.0e-9])
def test_surface_jacobian_matches_central_differences(coarse_flight, sigma, drop_by, adhesion):
    """SurfaceForces.dfdq = d f / d(z, pitch, roll) for GW contact + adhesion + friction (mu = 0.3, 6.65 deg skew).

    The slider is lowered by ``drop_by`` from steady flight (adhesion only,
    light and deep contact of the trailing pad).  Central differences,
    perturbing each cell's spacing by b . dq, with steps 1e-12, 1e-13,
    1e-14 m (over L for the angles): the error falls like the step squared
    (measured 2.0e-4, 2.2e-6, 2.2e-8 of the largest entry for the smooth
    disk in light contact, where sqrt(eps - d) is steep; at most 1.1e-5,
    1.1e-7, 2.4e-9 otherwise).  Each adhesion law (the scene's own: flat).
    """
    scene, film, surface, q_steady = coarse_flight
    if adhesion != scene.models.adhesion:
        scene = dataclasses.replace(scene, models=dataclasses.replace(scene.models, adhesion=adhesion))
        surface = SurfaceModel(scene, film.grid)
    q = q_steady - [drop_by, 0.0, 0.0]
    d = film.spacing(q)
    s = np.full(d.shape, sigma)
    forces = surface.forces(d, s)
    assert forces.cells > 0 and forces.adhesion < 0.0
    to_unit = np.outer([1.0, 1.0 / LENGTH, 1.0 / LENGTH], [1.0, LENGTH, LENGTH])  # entries in N/m
    scale = np.max(np.abs(forces.dfdq * to_unit))
    errors = []
    for step in (1e-12, 1e-13, 1e-14):
        jacobian = np.empty((3, 3))
        for k, unit in enumerate((1.0, 1.0 / LENGTH, 1.0 / LENGTH)):
            dq = np.zeros(3)
            dq[k] = step * unit
            shift = (dq @ surface.b).reshape(d.shape)
            plus, minus = surface.forces(d + shift, s), surface.forces(d - shift, s)
            assert plus.cells == minus.cells == forces.cells  # no cell crosses the reach
            jacobian[:, k] = (plus.f - minus.f) / (2.0 * dq[k])
        errors.append(np.max(np.abs((jacobian - forces.dfdq) * to_unit)) / scale)
    assert errors[-1] < 1e-6, errors
    assert errors[0] < 1e-6 or errors[1] < 0.03 * errors[0], errors


@pytest.mark.jitless
def test_adhesion_on_the_flying_pad_is_not_truncated(coarse_flight):
    """The adhesion at steady flight is the sum over all contact patches of p_a A, within 0.1 % of the preload."""
    scene, film, surface, q = coarse_flight
    d = film.spacing(q)
    model = surface.forces(d, np.full(d.shape, scene.disk.rms)).adhesion
    c = scene.contact
    full = surface_pressures(
        d.ravel(), scene.disk.rms, eps=c.equilibrium_spacing, gw_coef=surface.gw_coef, dgamma=c.delta_gamma
    ).adhesion
    reference = float(full @ film.grid.contact_area.ravel())
    assert reference < 0.0
    assert abs(model - reference) <= 1e-3 * scene.suspension.preload


def test_stiff_contact_keeps_the_implicit_step_stable():
    """A hard landing (zdot = -5 cm/s) on very stiff asperities (1e16 summits/m2) runs to t_end at the default dt.

    Every step sampled.  Measured (default 1e14 m-2 / 1e16 m-2) at dt 0.1 us
    with contact substeps: largest sampled contact force 0.076 / 0.46 N,
    1235 / 1116 sub-steps for 500 steps (862 / 710 contact substeps, 93 / 86
    redone, 301 / 283 with rho_infinity_contact; no halvings), 3.4 / 3.5
    Newton iterations per sub-step.  (With fixed steps of 0.2 us: 0.100 /
    0.096 N, 252 / 250 sub-steps for 250 steps, 2 / 0 halvings.)
    """
    run = {
        "numerics.t_end": 50e-6,
        "numerics.settle_time": 0.0,
        "numerics.output_interval": 0.2e-6,
        "initial.zdot": -0.05,
    }
    steady = fly_start(chen_bogy(COARSE | run))
    peaks = {}
    for density in (1e14, 1e16):
        scene = chen_bogy(COARSE | run | {"contact.summit_density": density})
        result = simulate_abs(scene, steady)
        assert result.status == 0, result.message
        peaks[density] = np.max(result.series["contact_force"])
        steps = result.work["steps"]
        substeps = result.work.get("substeps", steps)
        assert steps == round(scene.numerics.t_end / scene.numerics.dt)
        assert result.work["step_halvings"] <= 0.5 * steps
        assert substeps <= steps * 2**scene.numerics.contact_splits + result.work["contact_redos"]
        assert result.work["newton_iterations"] <= 12 * substeps
    assert min(peaks.values()) > scene.suspension.preload


# run summary -----------------------------------------------------------------------------------------------


def test_summary_of_a_sinusoidal_flight():
    """bouncing_3sigma = 3 A / sqrt(2) and the spectral peaks at the signals' frequencies (within one bin)."""
    scene = chen_bogy(
        COARSE | {"numerics.t_end": 1e-3, "numerics.settle_time": 0.2e-3, "numerics.output_interval": 1e-6}
    )
    t = np.arange(1001) * 1e-6
    amplitude, frequency = 0.4e-9, 53.3e3
    fh = 5e-9 + amplitude * np.sin(2 * np.pi * frequency * t)
    q = np.zeros((t.size, 3))
    q[:, 1] = 1e-6 * np.sin(2 * np.pi * 121.7e3 * t)
    q[:, 2] = 1e-7 * np.cos(2 * np.pi * 37.1e3 * t)
    contact = np.where(np.arange(t.size) % 4 == 0, 2 * scene.numerics.contact_threshold, 0.0)
    series = {
        "flying_height": fh,
        "clearance": fh - 1e-9,
        "contact_force": contact,
        "adhesion_force": np.zeros(t.size),
        "friction_force": 0.3 * contact,
        "air_force": np.zeros(t.size),
        "contact_cells": np.zeros(t.size),
    }
    result = AbsResult(t, q, np.zeros_like(q), series, start_at(scene, [0.0, 0.0, 0.0]), 0, "synthetic")
    summary = summarize(result, scene)
    window = 0.8e-3  # after the settling time
    bin_width = 1.0 / window
    assert summary["bouncing_3sigma"] == pytest.approx(3 * amplitude / math.sqrt(2), rel=2e-3)
    assert summary["mean_flying_height"] == pytest.approx(5e-9, rel=1e-3)
    assert abs(summary["fh_peak_frequency"] - frequency) <= bin_width
    assert abs(summary["pitch_peak_frequency"] - 121.7e3) <= bin_width
    assert abs(summary["roll_peak_frequency"] - 37.1e3) <= bin_width
    assert summary["contact_fraction"] == pytest.approx(0.25, abs=2e-3)
    assert summary["mean_friction_force"] == pytest.approx(0.3 * summary["mean_contact_force"], rel=1e-12)


# moving track ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def rough_track():
    """A Gaussian-correlated track (1 nm RMS, 8 um correlation length) under the coarse grid at zero skew."""
    scene = chen_bogy(
        COARSE
        | {
            "disk.skew": 0.0,
            "disk.rms": 1e-9,
            "disk.correlation_length": 8e-6,
            "disk.acf": "gaussian",
            "numerics.t_end": 20e-6,
            "numerics.settle_time": 0.0,
        }
    )
    grid = abs_grid(scene)
    return scene, grid, Track(scene, grid)


@pytest.mark.jitless
def test_track_moves_rigidly_with_the_disk(rough_track):
    """At zero skew the resolved disk under node k at t + (x_k - x_i)/V is the one under node i at t.

    Checked for every pair of nodes on the centre row with equal column
    width (same window filter): measured largest difference 8e-24 m for
    heights of 2 nm.
    """
    scene, grid, track = rough_track
    t0 = 3.7e-6
    before, _ = track.at(t0)
    j = grid.y.size // 2
    widths = np.round(np.diff(np.concatenate([[grid.x[0]], 0.5 * (grid.x[1:] + grid.x[:-1]), [grid.x[-1]]])), 12)
    checked = 0
    for i in range(grid.x.size):
        for k in range(i + 1, grid.x.size):
            if widths[k] != widths[i]:
                continue
            later, _ = track.at(t0 + (grid.x[k] - grid.x[i]) / scene.disk.speed)
            assert abs(later[k, j] - before[i, j]) <= 1e-12 * scene.disk.rms
            checked += 1
    assert checked >= 50  # measured 68 pairs (the fitted grid's spacing changes at every region edge)
    assert np.max(np.abs(before)) > scene.disk.rms  # a real profile, not zeros


def test_track_variance_is_resolved_plus_unresolved(rough_track):
    """Over one track period z_d^2 + sigma^2 averages to RMS^2 at every node.

    The window filter splits the variance between the resolved surface and
    the statistical roughness; the linear interpolation between profile
    samples removes a little (measured at most 3.8e-4 of RMS^2).
    """
    scene, grid, track = rough_track
    n = track.profile.heights.size
    total = np.zeros(grid.shape)
    for m in range(n):
        zd, sd = track.at(m * track.tables.spacing / scene.disk.speed)
        total += zd**2 + sd**2
    assert np.max(np.abs(total / n / scene.disk.rms**2 - 1.0)) < 1e-3
