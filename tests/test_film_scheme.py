"""The film's time scheme (``numerics.film_scheme``): the linearly implicit midpoint, BDF2 and trapezoidal steps.

What all must do (a steady film stays put, second order on a smooth path), what BDF2 and the trapezoid do better
(the mean film force over a rough track at a fixed attitude), and BDF2's bookkeeping (its history follows a step
taken back).  What the coupled runs show (BDF2's less damped slider, the trapezoid's as damped as the midpoint's)
is measured by ``bench/free_response.py`` and ``bench/rare_landings.py`` (README, "The film's time scheme").
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import chen_bogy

from solver.abs.film import AbsFilm
from solver.abs.forces import SurfaceModel
from solver.abs.integrate import AbsStepper
from solver.abs.steady import fly_start
from solver.abs.track import Track

#: The coarsest grid that resolves every region of chen_bogy2007, on a smooth disk.
COARSE = {"numerics.nx": 41, "numerics.ny": 31, "numerics.refine_nodes": 2, "disk.rms": 0.0}
#: The schemes, by name: numerics.film_scheme, and for the trapezoid the start flux (numerics.film_start_flux).
SCHEMES = ("midpoint", "bdf2", "trapezoid", "trapezoid evaluated")


def scheme_overrides(scheme: str) -> dict:
    """The scene overrides of a name of ``SCHEMES``."""
    name, _, start = scheme.partition(" ")
    return {"numerics.film_scheme": name} | ({"numerics.film_start_flux": start} if start else {})


def coarse_film(scheme: str, overrides: dict | None = None) -> tuple[AbsFilm, np.ndarray]:
    """A film of the coarse face with ``scheme`` (a name of ``SCHEMES``) at its steady flight: (film, attitude)."""
    scene = chen_bogy(COARSE | scheme_overrides(scheme) | (overrides or {}))
    film = AbsFilm(scene)
    return film, fly_start(scene, film).q


@pytest.mark.parametrize("scheme", SCHEMES)
def test_the_steady_film_is_a_fixed_point_of_the_film_step(scheme):
    """At the steady attitude over a smooth disk, R(P_steady) = 0 to a scaled residual of 1e-13: a step (backward
    Euler, the first of BDF2) and a second one (BDF2 over the first) leave P as it was, to 1e-9 of its largest value."""
    film, q = coarse_film(scheme)
    film.solve_steady(q, tol=1e-13)
    P0, disk, dt = film.P.copy(), np.zeros(film.shape), 0.1e-6
    for _ in range(2):
        assert film.step(q, q, disk, disk, dt)
        film.commit_step()
    assert np.max(np.abs(film.P - P0)) < 1e-9 * np.max(P0), np.max(np.abs(film.P - P0))


def path_orders(scheme: str, start: str, frequency: float, T: float) -> np.ndarray:
    """Observed orders of the film force at T, the attitude on a smooth path from steady flight (heave 1 nm, pitch
    0.2 urad, roll 0.3 urad at 1, 1.3 and 2 times ``frequency``), over film steps of 0.4 .. 0.0125 us: from the
    successive differences, no reference needed.  start "smooth": 1 - cos (at rest at t = 0); "abrupt": sin (the
    path sets off with a velocity that the steady film has not felt)."""
    film, q0 = coarse_film(scheme)
    film.solve_steady(q0, tol=1e-13)
    P0, disk, omega = film.P.copy(), np.zeros(film.shape), 2.0 * np.pi * frequency
    shape = (lambda x: 1.0 - np.cos(x)) if start == "smooth" else np.sin
    amplitude = np.array([1e-9, 0.2e-6, 0.3e-6])

    def forces_at_T(dt: float) -> float:
        film.P[:] = P0
        film.set_history((np.zeros_like(P0), 0.0))
        for k in range(int(round(T / dt))):
            qa, qb = (q0 + amplitude * shape(omega * t * np.array([1.0, 1.3, 2.0])) for t in (k * dt, (k + 1) * dt))
            assert film.step(qa, qb, disk, disk, dt)
            film.commit_step()
        return film.forces()[0]

    forces = np.array([forces_at_T(dt) for dt in (0.4e-6, 0.2e-6, 0.1e-6, 0.05e-6, 0.025e-6, 0.0125e-6)])
    differences = np.abs(np.diff(forces))
    return np.log2(differences[:-1] / differences[1:])


@pytest.mark.parametrize("scheme", SCHEMES)
def test_the_film_step_is_second_order_on_a_smooth_path(scheme):
    """From rest, along 1 - cos at 100 kHz for 8 us, every scheme converges at order 2 (measured: midpoint 1.99-2.00,
    trapezoid 1.98-2.00 with its start flux evaluated or carried; BDF2, whose first step is backward Euler, 1.73,
    1.89, 1.95, 1.98: its last two within 0.1 of 2)."""
    orders = path_orders(scheme, "smooth", 100e3, 8e-6)
    tail = orders if scheme != "bdf2" else orders[-2:]
    assert np.all(np.abs(tail - 2.0) < 0.1), orders


def test_the_midpoint_step_loses_its_order_where_bdf2_and_the_trapezoid_do_not():
    """Along sin at 200 kHz for 4 us, the path sets off with a velocity the steady film has not felt: the film's
    stiff modes are driven through coefficients (the spacings) that change within each step.  The midpoint rule,
    of stage order 1, loses its order there: its error at T jumps with the steps (measured orders 0.94, 2.20, 2.56,
    1.13).  BDF2 and the trapezoidal rule, of stage order 2, keep order 2 (measured 1.90, 2.03, 2.04, 2.03 and
    1.90, 1.92, 1.95, 1.97; with the trapezoid's start flux carried, 1.90, 1.91, 1.95, 1.97), though the trapezoid,
    like the midpoint, does not damp stiff modes (amplification -1): it is the stage order, not the damping.  The
    rough track drives the film so at every step (the next test)."""
    midpoint = path_orders("midpoint", "abrupt", 200e3, 4e-6)
    assert np.max(np.abs(midpoint - 2.0)) > 0.5, midpoint
    for scheme in ("bdf2", "trapezoid", "trapezoid evaluated"):
        orders = path_orders(scheme, "abrupt", 200e3, 4e-6)
        assert np.all(np.abs(orders[1:] - 2.0) < 0.1), (scheme, orders)


def test_bdf2s_and_the_trapezoids_mean_force_over_the_rough_track_is_far_closer_to_the_converged_one():
    """The film alone at the default flight's attitude over the moving rough track (default grid and track, as
    ``test_film_coupling.py::test_the_film_on_a_rough_track_converges_in_its_own_step``): 25 intervals of 0.4 us,
    the mean air force at their ends against the midpoint step at 6.25 ns.  Measured (``bench/film_time_error.py``,
    uN at 0.4, 0.2, 0.1, 0.05 us): midpoint 12.28, 7.87, 3.37, 1.04; BDF2 6.12, 0.28, 0.21, 0.11; trapezoid 0.55,
    0.06, 0.04, 0.03 with its start flux carried, 0.52, 0.08, 0.05, 0.03 evaluated.  BDF2 and the trapezoid at 0.2
    us are well within a quarter of the midpoint's error at 0.1 us, and all tend to the same limit."""
    runs = {}
    for scheme in SCHEMES:
        scene = chen_bogy({"numerics.t_end": 12e-6, "numerics.settle_time": 0.0} | scheme_overrides(scheme))
        film = AbsFilm(scene)
        q = fly_start(scene, film).q
        runs[scheme] = (film, q, Track(scene, film.grid), film.P.copy())
    H, n = 0.4e-6, 25

    def mean_force(scheme: str, m: int) -> float:
        film, q, track, P0 = runs[scheme]
        film.P[:] = P0
        film.set_history((np.zeros_like(P0), 0.0))
        forces = []
        for i in range(n):
            for k in range(m):
                t = i * H + k * H / m
                assert film.step(q, q, track.at(t)[0], track.at(t + H / m)[0], H / m)
                film.commit_step()
            forces.append(film.forces()[0])
        return float(np.mean(forces))

    reference = mean_force("midpoint", 64)
    midpoint_01 = abs(mean_force("midpoint", 4) - reference)
    for scheme in SCHEMES[1:]:
        errors = np.array([abs(mean_force(scheme, m) - reference) for m in (1, 2, 4, 8)])
        assert errors[1] < 0.25 * midpoint_01, (scheme, errors, midpoint_01)
        assert np.all(np.diff(errors) < 0.0), (scheme, errors)
        assert errors[-1] < 1e-4 * reference, (scheme, errors)  # 0.05 us: within 0.01 % of the mean force


@pytest.mark.parametrize("scheme", ("bdf2", "trapezoid"))
def test_a_step_taken_back_restores_the_films_history(scheme):
    """On the rough track, a step from a snapshot, taken back (:meth:`AbsStepper.restore`) and taken again, is the
    same step to the bit: the film's history (BDF2's m = P H at the last step's start and its size, the
    trapezoid's carried start flux) is part of the snapshot.  The same step without the history (BDF2: backward
    Euler; the trapezoid: its start flux evaluated) differs."""
    scene = chen_bogy(COARSE | scheme_overrides(scheme) | {"disk.rms": 0.2e-9})
    film = AbsFilm(scene)
    steady = fly_start(scene, film)
    stepper = AbsStepper(scene, film, Track(scene, film.grid), SurfaceModel(scene, film.grid), steady)
    h = scene.numerics.dt
    for _ in range(3):
        assert stepper.step(h) is None
    saved = stepper.snapshot()
    stepper.restore(saved)  # a restore refreshes the film's derivatives at the next step: the same for both steps
    assert stepper.step(h) is None
    first = (stepper.q.copy(), film.P.copy())
    stepper.restore(saved)
    assert stepper.step(h) is None
    assert np.array_equal(stepper.q, first[0]) and np.array_equal(film.P, first[1])
    stepper.restore(saved)
    film.set_history((np.zeros_like(film.P), 0.0))  # no history
    assert stepper.step(h) is None
    assert not np.array_equal(film.P, first[1])


@pytest.mark.parametrize("correction", (False, True))
def test_the_carried_start_flux_is_the_evaluated_one_to_second_order(correction):
    """The trapezoid's carried start flux (numerics.film_start_flux 'carried'): the end residual of the last step
    carried to first order to the pressure it left, R(P_n; end) + J delta, and on to the pressure a slider's
    correction leaves (P += dP after the step, as the linearized coupling's P += S dq).  Against R evaluated over
    the new pressure and the end's spacing, its error is of second order in the step's change: one step of 0.2,
    0.1 and 0.05 us along the abrupt path of the order test (from steady flight), and with ``correction`` a change
    dP as large as the step's own, each error at most 0.3 of the last (order >= 1.7, measured 1.89, 1.94 and 1.90,
    1.95), and the largest 1e-3 of the residual's own change over the step at most (measured 3.4e-4 and 6.9e-4)."""
    film, q0 = coarse_film("trapezoid")
    film.solve_steady(q0, tol=1e-13)
    P0, disk = film.P.copy(), np.zeros(film.shape)
    amplitude = np.array([1e-9, 0.2e-6, 0.3e-6])
    omega = 2.0 * np.pi * 200e3 * np.array([1.0, 1.3, 2.0])
    errors, changes = [], []
    for dt in (0.2e-6, 0.1e-6, 0.05e-6):
        film.P[:] = P0
        film.set_history((np.zeros_like(P0), 0.0))
        assert film.step(q0, q0 + amplitude * np.sin(omega * dt), disk, disk, dt)
        start = film.scratch.R.copy()  # the last assemble: R(P_n) over the end's spacing
        if correction:
            film.P[:, 1:-1, 1:-1] += film.P[:, 1:-1, 1:-1] - P0[:, 1:-1, 1:-1]
        film.commit_step()
        carried = film.history()[0]
        evaluated = film.residual().copy()
        errors.append(np.max(np.abs(carried - evaluated)))
        changes.append(np.max(np.abs(evaluated - start)))
    errors, changes = np.array(errors), np.array(changes)
    assert np.all(errors[1:] < 0.3 * errors[:-1]), (errors, np.log2(errors[:-1] / errors[1:]))
    assert np.all(errors < 1e-3 * changes), errors / changes


def test_a_pressure_set_from_outside_gets_its_start_flux_evaluated():
    """The carried start flux belongs to the pressure the last accepted step left.  A film whose P is then set from
    outside (a test resetting it, a caller's own state) evaluates the start flux instead: its step is the evaluated
    trapezoid's to the bit, where carrying the old flux would not be.  Its own steps carry the flux again."""
    films = {flux: coarse_film(f"trapezoid {flux}", {"disk.rms": 0.2e-9}) for flux in ("carried", "evaluated")}
    q0 = films["carried"][1]
    P0, disk, dt = films["carried"][0].P.copy(), np.zeros(films["carried"][0].shape), 0.2e-6
    q1 = q0 + np.array([1e-10, 1e-7, -1e-7])
    ends = {}
    for flux, (film, q) in films.items():
        assert np.array_equal(q, q0) and np.array_equal(film.P, P0)
        assert film.step(q0, q1, disk, disk, dt)
        film.commit_step()
        film.P[:] = P0  # from outside
        assert film.step(q0, q1, disk, disk, dt)
        ends[flux] = film.P.copy()
    assert np.array_equal(ends["carried"], ends["evaluated"])
    film = films["carried"][0]
    film.commit_step()
    start, q2 = film.P.copy(), q1 + (q1 - q0)
    assert film.step(q1, q2, disk, disk, dt)  # carried: the history is its own pressure's
    carried_step = film.P.copy()
    film.P[:] = start
    film.set_history((np.zeros_like(P0), 0.0))
    assert film.step(q1, q2, disk, disk, dt)  # evaluated
    assert not np.array_equal(film.P, carried_step)
