"""Time integration: free flight, the bouncing point mass, equilibrium, observed order, run contract.

The film-free scenes (``models.air_bearing = 'none'``) have closed-form
solutions: uniform motion, and a mass dropped under a constant preload
onto a restitution stop (impact times and impulses in closed form, an
accumulation point of infinitely many impacts).  Scene-1 runs use the
small grid.
"""

from __future__ import annotations

import dataclasses
import math

import mpmath
import numpy as np
import pytest
from conftest import EPS, SMALL_GRID, TAPER_LENGTH, rigid_scene, small_scene, with_preload

from solver.kernels import motion as km
from solver.params import ParameterError
from solver.rails.dynamics import mass_matrix, suspension_forces
from solver.rails.geometry import CORNERS, corner_positions, corner_spacings
from solver.rails.integrate import simulate
from solver.rails.params import Calibration, Contact, Initial, Models, Numerics, Scene, Slider
from solver.rails.steady import fly

PRELOAD = 0.0932  # N, the source's preload


# ---------------------------------------------------------------------------- event roots


def exact_first_crossing(gap0, rate, curvature, s_max):
    """Reference root of gap0 + rate s + curvature s^2 / 2 in high precision (downward crossings only)."""
    with mpmath.workdps(50):
        a, b, c = mpmath.mpf(curvature) / 2, mpmath.mpf(rate), mpmath.mpf(gap0)
        if a == 0:
            roots = [-c / b]
        else:
            disc = b * b - 4 * a * c
            roots = [] if disc < 0 else [(-b - mpmath.sqrt(disc)) / (2 * a), (-b + mpmath.sqrt(disc)) / (2 * a)]
        downward = [float(r) for r in roots if 0 < r <= s_max and b + 2 * a * r < 0]
    return min(downward, default=math.inf)


@pytest.mark.jitless
@pytest.mark.parametrize(
    ("gap0", "rate", "curvature"),
    [
        (65e-9, -1e-2, 0.0),  # falling at constant speed
        (65e-9, 0.0, -1313.0),  # dropped from rest under the preload (F/m)
        (65e-9, -1e-5, -1313.0),  # small speed, large curvature: the stable quadratic formula matters
        (65e-9, -3e-2, 1e4),  # decelerating but still crossing
        (0.0, 1e-2, -1313.0),  # just bounced: the next downward crossing, not s = 0
        (65e-9, -1e-3, 1e5),  # turns around before reaching the asperities: no root
        (65e-9, 1e-3, 0.0),  # receding: no root
    ],
)
def test_first_crossing_is_the_exact_downward_root(gap0, rate, curvature):
    s_max = 1e-4
    s = km.first_crossing(gap0, rate, curvature, s_max)
    expected = exact_first_crossing(gap0, rate, curvature, s_max)
    if math.isinf(expected):
        assert math.isinf(s)
    else:
        assert s == pytest.approx(expected, rel=8 * EPS, abs=0)
        # the spacing at the root is zero to round-off of its terms
        terms = abs(gap0) + abs(rate * s) + abs(0.5 * curvature * s * s)
        assert abs(gap0 + rate * s + 0.5 * curvature * s * s) <= 8 * EPS * terms


@pytest.mark.jitless
def test_first_crossing_respects_the_step():
    assert math.isinf(km.first_crossing(1.0, -1.0, 0.0, 0.5))
    assert km.first_crossing(1.0, -1.0, 0.0, 1.0) == 1.0


@pytest.mark.jitless
def test_first_event_picks_the_earliest_corner():
    normals = np.array([[1.0, -x1, -x2] for x1, x2 in corner_positions(Slider())])
    q = np.array([0.115e-6, 13.5e-6, 0.0])
    v = np.array([-0.01, 5.0, 10.0])
    acc = np.zeros(3)
    h0 = 0.05e-6
    s, corner = km.first_event(normals, q, v, acc, h0, 1e-3)
    gaps, rates = normals @ q - h0, normals @ v
    times = np.where(rates < 0, -gaps / np.where(rates < 0, rates, -1.0), np.inf)
    assert corner == int(np.argmin(times))
    assert s == pytest.approx(times.min(), rel=8 * EPS, abs=0)
    assert km.first_event(normals, q, v, acc, h0, 0.5 * times.min()) == (math.inf, -1)


# ---------------------------------------------------------------------------- free flight


@pytest.mark.jitless
def test_free_flight_is_uniform_motion():
    # no film, no preload, no suspension moments: q(t) = q0 + v0 t, v constant, with the real
    # (coupled) mass matrix; the velocities keep every corner away from the disk
    scene = Scene(
        models=Models(air_bearing="none"),
        slider=Slider(taper_length=TAPER_LENGTH),
        initial=Initial(zdot=0.05, pitch_rate=5.0, roll_rate=-10.0),
        numerics=Numerics(t_end=50e-6, **SMALL_GRID),
    )
    steady = fly(scene)
    np.testing.assert_array_equal(suspension_forces(steady.suspension, steady.q), 0.0)
    r = simulate(scene, steady)
    assert r.status == 0 and r.impacts == []
    v0 = np.array([0.05, 5.0, -10.0])
    np.testing.assert_array_equal(r.v, np.broadcast_to(v0, r.v.shape))
    exact = steady.q + r.t[:, None] * v0
    # each step adds s v to q: round-off of one ulp of |q| per step
    bound = r.work["steps"] * EPS * np.abs(exact).max(axis=0)
    assert np.all(np.abs(r.q - exact) <= bound)
    np.testing.assert_allclose(r.t, np.arange(r.t.size) * scene.numerics.output_interval, rtol=1e-12)
    np.testing.assert_allclose(r.corner_spacing[-1], corner_spacings(r.q[-1], corner_positions(scene.slider)))


# ---------------------------------------------------------------------------- bouncing point mass


def bouncing_mass(t_end, alpha=0.5, max_impacts=2000, rest_velocity=1e-4, **numerics):
    scene = rigid_scene(t_end=t_end, alpha=alpha, max_impacts=max_impacts, rest_velocity=rest_velocity, **numerics)
    steady = with_preload(fly(scene), PRELOAD)
    return scene, steady


def analytic_bounces(scene, steady, count):
    """Impact times, approach speeds and impulses of a point mass falling under F onto h0."""
    m, alpha = scene.slider.mass, scene.contact.alpha
    acc = PRELOAD / m
    gap = steady.z - scene.disk.asperity_height
    t = np.sqrt(2.0 * gap / acc)
    u = acc * t
    times, speeds = [], []
    for _ in range(count):
        times.append(t)
        speeds.append(u)
        t += 2.0 * alpha * u / acc  # flight up and down at alpha u
        u *= alpha
    speeds = np.array(speeds)
    return np.array(times), speeds, (1.0 + alpha) * m * speeds


@pytest.mark.jitless
def test_bouncing_point_mass_impact_times_and_impulses():
    scene, steady = bouncing_mass(t_end=29e-6)
    r = simulate(scene, steady)
    count = 5
    times, speeds, impulses = analytic_bounces(scene, steady, count)
    # all four corners touch together and share one impact: four equal impulses at each bounce
    # (the least-norm split of a level slider), summing to the point mass's (1 + alpha) m u
    bounces = [r.impacts[4 * k : 4 * k + 4] for k in range(count)]
    assert all(sorted(i.corner for i in b) == [0, 1, 2, 3] and len({i.time for i in b}) == 1 for b in bounces)
    got_times = np.array([b[0].time for b in bounces])
    # round-off: the position carries ~EPS z0 of error, which moves the k-th approach speed by
    # (F/m) EPS z0 / u_k^2 <= 5e-14 relative for k <= 5; 1e-12 is 20 times that
    np.testing.assert_allclose(got_times, times, rtol=1e-12)
    np.testing.assert_allclose([sum(i.impulse for i in b) for b in bounces], impulses, rtol=1e-12)
    np.testing.assert_allclose([i.impulse for b in bounces for i in b], np.repeat(impulses / 4, 4), rtol=1e-12)
    np.testing.assert_allclose([b[0].approach_before for b in bounces], speeds, rtol=1e-12)
    np.testing.assert_allclose([b[0].approach_after for b in bounces], -scene.contact.alpha * speeds, rtol=1e-12)
    # free fall before the first impact: z = z0 - (F/m) t^2 / 2 at every stored sample
    falling = r.t < times[0]
    acc = PRELOAD / scene.slider.mass
    expected = steady.z - 0.5 * acc * r.t[falling] ** 2
    assert np.all(np.abs(r.q[falling, 0] - expected) <= 64 * EPS * steady.z)


@pytest.mark.jitless
def test_chattering_without_the_rule_stops_on_the_impact_limit():
    # alpha < 1 under a constant load: infinitely many impacts before
    # t_inf = t1 + 2 u1 alpha / ((1 - alpha) F/m); with the chattering rule off
    # (rest_velocity = 0) the run must stop with status 1
    # (four corners share each bounce: 20 impacts are 5 bounces)
    scene, steady = bouncing_mass(t_end=60e-6, max_impacts=20, rest_velocity=0.0)
    r = simulate(scene, steady)
    times, _, _ = analytic_bounces(scene, steady, 5)
    assert r.status == 1
    assert "max_impacts" in r.message
    assert len(r.impacts) == 20 == r.work["impacts"]
    assert r.impacts[-1].time == pytest.approx(times[-1], rel=1e-12, abs=0)

    scene, steady = bouncing_mass(t_end=60e-6, rest_velocity=0.0)
    r = simulate(scene, steady)
    times, speeds, _ = analytic_bounces(scene, steady, 1)
    acc = PRELOAD / scene.slider.mass
    alpha = scene.contact.alpha
    t_inf = times[0] + 2.0 * speeds[0] * alpha / ((1.0 - alpha) * acc)
    assert r.status in (-1, 1)  # the impact limit, or stalled events reported as a failure
    assert max(imp.time for imp in r.impacts) <= t_inf * (1.0 + 1e-12)


@pytest.mark.jitless
def test_output_samples_are_uniform_when_an_impact_lands_just_before_a_sample():
    # The driver promises samples on the uniform grid t = k * output_interval.  Put the first
    # impact 5e-4 dt before the 100th grid instant: the sample there must still be stored.
    scene, steady = bouncing_mass(t_end=12e-6)
    times, _, _ = analytic_bounces(scene, steady, 1)
    dt = times[0] / (100.0 - 5e-4)
    scene = rigid_scene(t_end=12e-6, dt=dt, output_interval=dt)
    r = simulate(scene, steady)
    assert r.impacts[0].time == pytest.approx(times[0], rel=1e-12, abs=0)
    n_grid = int(round(scene.numerics.t_end / dt))
    missing = sorted(set(range(n_grid + 1)) - set(np.round(r.t / dt).astype(int).tolist()))
    assert missing == [], f"no sample at t = k dt for k in {missing}"
    np.testing.assert_allclose(r.t, np.arange(n_grid + 1) * dt, rtol=1e-12)


@pytest.mark.jitless
def test_output_interval_is_honoured_or_rejected():
    # numerics.output_interval is "the sampling interval of stored time series": a value that is
    # not a multiple of dt must either be rejected or give samples that far apart
    try:
        scene = rigid_scene(t_end=3e-6, dt=0.1e-6, output_interval=0.25e-6)
    except ParameterError:
        return
    r = simulate(scene, with_preload(fly(scene), 0.0))
    np.testing.assert_allclose(np.diff(r.t), scene.numerics.output_interval, rtol=1e-9)


# ---------------------------------------------------------------------------- scene 1


@pytest.mark.jitless
def test_steady_flight_is_an_equilibrium_of_the_integrator(scene1):
    # zero disturbance: film and suspension balance, so the slider stays put.  The steady
    # pressure is converged to steady_tol p0, which bounds the force imbalance and hence the drift.
    scene = dataclasses.replace(
        scene1,
        initial=Initial(zdot=0.0, pitch_rate=0.0, roll_rate=0.0),
        numerics=dataclasses.replace(scene1.numerics, t_end=20e-6),
    )
    r = simulate(scene)
    assert r.status == 0 and r.impacts == []
    s = scene.slider
    area = 2.0 * s.rail_width * s.length
    force = scene.numerics.steady_tol * scene.air.ambient_pressure * area
    imbalance = np.array([force, force * s.length, force * s.width / 2])
    acc = np.abs(np.linalg.inv(mass_matrix(s))) @ imbalance
    t_end = scene.numerics.t_end
    assert np.all(np.abs(r.q - r.q[0]) <= 0.5 * acc * t_end**2 + 4 * EPS * np.abs(r.q[0]))
    assert np.all(np.abs(r.v) <= acc * t_end)


@pytest.mark.jitless
def test_fly_balances_the_printed_suspension():
    # calibration 'none': Newton on the attitude with the printed preload and no gimbal moments
    scene = small_scene(calibration=Calibration(mode="none"))
    st = fly(scene)
    assert st.force_residual < 100 * scene.numerics.steady_tol
    assert st.load == pytest.approx(scene.suspension.preload, rel=100 * scene.numerics.steady_tol, abs=0)
    # no suspension moments: the centre of pressure sits under the gimbal
    assert abs(st.centre_of_pressure[0]) < 100 * scene.numerics.steady_tol * np.ptp(st.x1)
    assert abs(st.roll) < 1e-9 * st.pitch
    assert st.min_spacing == pytest.approx(
        st.z - scene.slider.flat_rear * st.pitch - scene.slider.width / 2 * abs(st.roll)
    )


@pytest.fixture(scope="module")
def scene1_run(scene1):
    scene = dataclasses.replace(
        scene1,
        contact=Contact(mu=0.5, alpha=0.8),
        numerics=dataclasses.replace(scene1.numerics, t_end=30e-6),
    )
    return scene, simulate(scene)


@pytest.mark.jitless
def test_scene1_impacts(scene1_run):
    scene, r = scene1_run
    assert r.status == 0, r.message
    assert len(r.impacts) >= 2
    times = np.array([imp.time for imp in r.impacts])
    assert np.all(np.diff(times) > 0.0)
    assert 0.0 < times[0] and times[-1] <= scene.numerics.t_end
    for imp in r.impacts:
        assert imp.corner_letter in CORNERS
        assert imp.impulse > 0.0
        assert imp.approach_before > 0.0
        # restitution acts on the relative normal velocity U + eps V (wedging included)
        assert imp.approach_after == pytest.approx(-scene.contact.alpha * imp.approach_before, rel=1e-12, abs=0)
    # between impacts the corners stay at or above the asperities
    assert r.min_spacing.min() >= scene.disk.asperity_height * (1.0 - 1e-9)


@pytest.mark.jitless
def test_scene1_work_counters(scene1_run):
    scene, r = scene1_run
    num = scene.numerics
    n_grid = int(round(num.t_end / num.dt))
    assert num.newton_max_iter == 1
    assert r.work["newton_iterations"] == r.work["steps"]
    # one extra (event) step per impact at most, plus the steady solve
    assert n_grid <= r.work["steps"] <= n_grid + 2 * r.work["impacts"]
    assert r.work["impacts"] == len(r.impacts)
    assert r.work["reynolds_solves"] == r.work["steps"] + r.steady.reynolds_solves
    assert r.work["rejected_steps"] == 0
    out_every = int(round(num.output_interval / num.dt))
    assert r.t.size == n_grid // out_every + 1
    assert r.q.shape == r.v.shape == r.air_force.shape == (r.t.size, 3)
    assert r.corner_spacing.shape == (r.t.size, 4)


def test_integrator_is_second_order_through_impacts(scene1):
    # the default disturbance hits the rear corners twice in 10 us; event roots are exact on
    # the discrete trajectory, so states, impact times and impulses all converge at order 2
    base = dataclasses.replace(scene1, numerics=dataclasses.replace(scene1.numerics, t_end=10e-6))
    steady = fly(base)
    samples = []
    for dt in (0.2e-6, 0.1e-6, 0.05e-6, 0.025e-6):
        scene = dataclasses.replace(base, numerics=dataclasses.replace(base.numerics, dt=dt, output_interval=0.4e-6))
        r = simulate(scene, steady)
        assert r.status == 0
        assert [imp.corner_letter for imp in r.impacts] == ["D", "B"]
        samples.append(
            np.concatenate([r.q[-1], r.v[-1], [imp.time for imp in r.impacts], [imp.impulse for imp in r.impacts]])
        )
    differences = np.abs(np.diff(np.array(samples), axis=0))
    orders = np.log2(differences[:-1] / differences[1:])
    assert np.all(np.abs(orders - 2.0) < 0.1), orders
