"""Steady flight of scene kind "abs": where Newton from the standard guess stalls, and under refinement.

chen_bogy2007's balances, continued from the flight without adhesion
along the element's flying height h, give the adhesion that holds each
height, delta_gamma(h); where it has a maximum (a fold) there is no
flying equilibrium beyond it.  On the sampled faces the fold and the
flight scattered from grid to grid (no flight at 181 x 151, the pad in
contact at 81 x 67); on the fitted faces (region edges on control-volume
faces, :mod:`solver.abs.cuts`) every grid from 81 x 67 to 321 x 271 flies.
"""

from __future__ import annotations

import pytest
from conftest import WIDTH, chen_bogy

from solver.abs.steady import fly_abs, fly_start
from solver.errors import AttitudeError


@pytest.mark.parametrize(
    "overrides",
    [
        {"numerics.nx": 61, "numerics.ny": 51},
        {"numerics.nx": 81, "numerics.ny": 67},
        {"suspension.preload": 0.980665e-3},
    ],
    ids=["61x51", "81x67", "preload-0.1gf"],
)
def test_flight_found_where_newton_stalls(overrides):
    """Newton from the standard guess stalls here; the continuation in adhesion balances the forces.

    On 61 x 51 and 81 x 67 it stalls where the flying branch flattens
    (residual 0.099 preloads on 81 x 67); at 0.1 gf on 121 x 101 at the
    film solves' round-off floor (1.37e-5 preloads, the tolerance is 1e-5).
    Measured: residuals 4.8e-8, 2.3e-6, 3.0e-9; 2.7 s, 5.5 s, 5.2 s.
    """
    scene = chen_bogy(overrides)
    steady = fly_abs(scene)
    assert steady.force_residual < scene.numerics.steady_tol
    assert steady.surface.adhesion < 0.0
    assert steady.iterations <= 60  # measured 34, 29 and 9, the continuation's corrector iterations included


def test_a_film_tolerance_floor_is_tightened_not_reported_as_a_stall(monkeypatch):
    """121 x 301 without skew or adhesion: at the film tolerance 1e-9 the force balance floors at 1.5e-5 preloads
    (measured), above steady_tol; the search tightens the film's tolerance and converges to the flight that a
    tolerance of 1e-12 from the start finds, with zero roll (the face and the flow are symmetric in y)."""
    import solver.abs.steady as steady_module

    scene = chen_bogy({"numerics.nx": 121, "numerics.ny": 301, "disk.skew": 0.0, "contact.delta_gamma": 0.0})
    flight = fly_abs(scene)
    assert flight.force_residual < scene.numerics.steady_tol
    assert abs(flight.q[2]) <= 1e-12
    monkeypatch.setattr(steady_module, "FILM_TOLERANCE", 1e-12)
    tight = fly_abs(scene)
    assert flight.element_spacing == pytest.approx(tight.element_spacing, abs=1e-13)  # steady_tol moves z ~1e-14 m
    assert flight.q[1] == pytest.approx(tight.q[1], rel=1e-6)


def test_flying_height_and_pitch_fall_monotonically_under_refinement():
    """On the fitted faces the flight converges from above: flying height and pitch fall with every refinement.

    Measured on 81 x 67, 121 x 101, 181 x 151 (since the slanted corners are fitted, 43cc7c4): flying height
    2.1937, 2.1177, 2.0712 nm, pitch 135.151, 134.456, 134.203 urad, the pad flying (no contact).  (Before:
    2.2109, 2.1412, 2.0616 nm; before the fitted faces: 0.908 nm in contact, 2.084 nm, no flying
    equilibrium.)  The README's ladder goes on to 321 x 271 (2.0372 nm).
    """
    flights = [
        fly_abs(chen_bogy({"numerics.nx": nx, "numerics.ny": ny})) for nx, ny in ((81, 67), (121, 101), (181, 151))
    ]
    f_preload = chen_bogy({}).suspension.preload
    heights = [f.element_spacing for f in flights]
    pitches = [f.q[1] for f in flights]
    assert heights[0] > heights[1] > heights[2] and pitches[0] > pitches[1] > pitches[2], (heights, pitches)
    assert all(f.surface.contact < 1e-3 * f_preload and f.surface.adhesion < 0.0 for f in flights)


def test_beyond_the_fold_the_contact_branch_holds_the_pad():
    """delta_gamma = 0.013 on 81 x 67: the flying branch folds below it, and the equilibrium lies beyond the fold.

    Continued through the fold (measured at 0.01238 J/m2, flying height
    1.973 nm), dg(h) falls on the unstable middle branch and rises again
    where the asperities' contact stiffens the balance; 0.013 is reached at
    1.455 nm with 2.65 mN of contact (29.6 s, with the map's runs on both
    cores).  Before, fly_abs raised "no flying equilibrium" here and a run
    started from the flight without adhesion.
    """
    import re

    scene = chen_bogy({"numerics.nx": 81, "numerics.ny": 67, "contact.delta_gamma": 0.013})
    steady = fly_abs(scene)
    assert steady.force_residual < scene.numerics.steady_tol
    pattern = r"fold of the flying branch at delta_gamma = (\S+) J/m2 \(flying height (\S+) nm\)"
    found = re.search(pattern, steady.branch)
    assert found, steady.branch
    fold, fold_height = float(found.group(1)), float(found.group(2)) * 1e-9
    assert 0.008 < fold < 0.013
    # beyond the fold: lower than the fold's flight, and held up by the asperities against more adhesion
    assert steady.element_spacing < fold_height - 0.2e-9
    assert steady.surface.contact > 0.1 * scene.suspension.preload
    assert steady.surface.adhesion < -steady.surface.contact
    assert steady.note == ""  # an equilibrium of the scene itself: a run starts from it


@pytest.mark.slow
def test_strong_adhesion_reports_the_fold():
    """delta_gamma = 0.08 on 81 x 67: the flying branch folds (measured at 0.01238 J/m2), the branch beyond it,
    held up by contact, reaches at most 0.0211 J/m2, and the error says so.

    fly_start then starts from the flight without adhesion, and its note
    carries the fold.  Measured 82 s for the fly (the continuation goes down the contact branch until its
    corrector fails at 0.15 nm), with the map's runs on both cores.
    """
    import re

    scene = chen_bogy({"numerics.nx": 81, "numerics.ny": 67, "contact.delta_gamma": 0.08})
    with pytest.raises(AttitudeError, match="no flying equilibrium on the 81 x 67 grid: the fold lies at") as info:
        fly_abs(scene)
    fold = info.value.fold_delta_gamma
    assert 0.008 < fold < 0.08
    assert f"delta_gamma = {fold:.4g} J/m2" in str(info.value)
    assert "beyond it the pad is pulled onto the disk" in str(info.value)
    most = float(re.search(r"held up by asperity contact reaches at most (\S+) J/m2", str(info.value)).group(1))
    assert fold < most < 0.08  # the contact branch rises beyond the fold, but not to the scene's adhesion
    # the fold estimate: the pull at touchdown is several preloads (5.5 with the flight's own attitude, 121 x 101)
    ratio = -info.value.touchdown_adhesion / scene.suspension.preload
    assert ratio > 1.0
    assert f"fold estimate: adhesion at touchdown {info.value.touchdown_adhesion * 1e3:.3f} mN = {ratio:.3g}" in str(
        info.value
    )
    steady = fly_start(scene)
    assert f"the fold lies at delta_gamma = {fold:.4g}" in steady.note
    assert steady.surface.adhesion == 0.0


def test_region_loads_add_up_and_mirror_on_a_symmetric_face():
    """What each region carries: the rows sum to the film's node quadrature, and on a face symmetric in y, with
    the disk moving along x (skew 0), mirrored regions carry the same load and opposite roll moments."""
    import numpy as np

    from solver.abs.face import region_loads
    from solver.abs.film import AbsFilm
    from solver.kernels.film import film_forces

    scene = chen_bogy({"disk.skew": 0.0, "disk.rms": 0.0, "contact.delta_gamma": 0.0})
    film = AbsFilm(scene)
    steady = fly_abs(scene, film)
    names, loads = region_loads(scene, steady.x, steady.y, steady.pressure)
    p0 = scene.air.ambient_pressure
    g = film.grid
    node = p0 * np.array(film_forces(steady.pressure[None] / p0, g.area, g.x, g.y, *film.pivot))
    assert np.abs(loads.sum(axis=0) - node).max() <= 1e-12 * np.abs(node).max()
    left, right = loads[names.index("left rail")], loads[names.index("right rail")]
    scale = np.abs(loads[:, 0]).max()
    assert abs(left[0] - right[0]) <= 1e-6 * scale, (left, right)
    assert abs(left[2] + right[2]) <= 1e-6 * scale * WIDTH, (left, right)
    assert left[2] != 0.0
    # the pads lift, the cavity pulls, and the trailing pad's load pitches the nose down
    pad = loads[names.index("trailing pad")]
    assert loads[names.index("cavity (base)"), 0] < 0 < loads[names.index("front pad"), 0]
    assert pad[0] > 0 > pad[1]


@pytest.mark.parametrize("lowered", [0.0, 1.3e-9])
def test_film_jacobian_by_the_implicit_function_is_that_of_whole_solves(lowered):
    """The steady search's film Jacobian (:func:`solver.abs.steady._film_jacobian`: one LU, dP/dq from the
    residual's differences, the force along the solution's tangent) against central differences of whole steady
    solves (tolerance 1e-13, the same steps), at the flight without adhesion and with the face lowered 1.3 nm into
    contact (61 x 41): every column within 2e-3 of its largest entry.  Measured: 5e-5 and 1.0e-3; the whole solves
    themselves move by 1.8 % with steps four times longer, so the difference is their truncation."""
    import numpy as np

    from solver.abs.film import AbsFilm
    from solver.abs.steady import JACOBIAN_STEP, _film_jacobian

    scene = chen_bogy({"numerics.nx": 61, "numerics.ny": 41, "numerics.refine": 3, "contact.delta_gamma": 0.0})
    film = AbsFilm(scene)
    q = fly_start(scene, film).q - [lowered, 0.0, 0.0]
    film.solve_steady(q, tol=1e-13)
    P_keep = film.P.copy()
    scale = np.ones(3)
    steps = np.array([JACOBIAN_STEP, JACOBIAN_STEP / film.length, JACOBIAN_STEP / film.length])
    reference = np.zeros((3, 3))
    for k in range(3):
        forces = []
        for sign in (1.0, -1.0):
            film.P[:] = P_keep
            film.solve_steady(q + sign * steps[k] * np.eye(3)[k], tol=1e-13)
            forces.append(film.forces())
        reference[:, k] = (forces[0] - forces[1]) / (2.0 * steps[k])
    J = _film_jacobian(film, q, P_keep, scale)
    assert np.array_equal(film.P, P_keep)
    assert np.all(np.abs(J - reference) <= 2e-3 * np.max(np.abs(reference), axis=0)), (J, reference)


def test_the_steady_flight_does_not_depend_on_what_the_kind_calls_steady_free():
    """Studies reuse one steady flight across the keys solver/abs/kind.py declares free of it (the track's
    realisation, the time step, the contact damping...): on a flight held up by 2.5 mN of asperity contact (61 x
    41, 3 gf, no adhesion: 0.67 nm at the element), flights that differ in those keys only are equal to the last
    bit, and so are their steady keys."""
    import numpy as np

    from solver.kinds import get_kind

    kind = get_kind("abs")
    common = {"numerics.nx": 61, "numerics.ny": 41, "numerics.refine": 3, "suspension.preload": 0.0235,
              "contact.delta_gamma": 0.0}  # fmt: skip
    scene = chen_bogy(common)
    changed = chen_bogy(common | {"contact.damping_ratio": 0.1, "disk.seed": 4, "numerics.dt": 0.05e-6,
                                  "numerics.rho_infinity": 0.5, "numerics.film_update": "secant",
                                  "numerics.film_dt": 0.025e-6, "numerics.film_refresh_gap": 0.5e-9,
                                  "numerics.film_scheme": "bdf2"})  # fmt: skip
    assert kind.steady_key(changed.to_dict()) == kind.steady_key(scene.to_dict())
    base, other = kind.fly(scene), kind.fly(changed)
    assert base.surface.contact > 1e-3  # N: the contact the damping would act on, were the flight not static
    assert np.array_equal(other.q, base.q) and np.array_equal(other.pressure, base.pressure)


def test_the_steady_films_chord_iteration_ends_at_newtons_solution():
    """solve_steady keeps its LU across calls while each residual falls to 0.3 of the last.  From a film converged
    at the flight without adhesion (61 x 41) to attitudes 0.05 nm and 0.1 urad, 1 and 10 nm, 30 urad of pitch and
    20 urad of roll away, it ends where Newton's method with a fresh Jacobian at every step ends (a film of its
    own), within 1e-8 of the largest pressure at a scaled residual of 1e-12 (the chord's last iterate sits near
    the tolerance, Newton's well below it: measured 5e-12 to 2e-9); the nearby attitude takes no new LU, and at
    30 urad the stale Jacobian's first step raises the residual (x 1.24, measured) and is taken back."""
    import numpy as np

    from solver.abs.film import AbsFilm

    scene = chen_bogy({"numerics.nx": 61, "numerics.ny": 41, "numerics.refine": 3, "contact.delta_gamma": 0.0})
    film = AbsFilm(scene)
    q0 = fly_start(scene, film).q
    film.solve_steady(q0, tol=1e-13, chord=False)
    P0 = film.P.copy()
    for dq in ([0.05e-9, 0.1e-6, 0.0], [1e-9, 0.0, 0.0], [10e-9, 0.0, 0.0], [0.0, 30e-6, 0.0], [0.0, 0.0, 20e-6]):
        chord, newton = AbsFilm(scene), AbsFilm(scene)
        chord.P[:] = P0
        chord.P[0, 1:-1, 1:-1] *= 1.0 + 1e-6
        chord.solve_steady(q0, tol=1e-13)  # Newton's steps (no LU yet); the last LU, at P0 within 1e-6, is kept
        assert np.max(np.abs(chord.P - P0)) <= 1e-8 * np.max(P0) and chord.factorizations > 0
        newton.P[:] = chord.P
        factorized = chord.factorizations
        chord.solve_steady(q0 + dq, tol=1e-12)
        newton.solve_steady(q0 + dq, tol=1e-12, chord=False)
        assert np.max(np.abs(chord.P - newton.P)) <= 1e-8 * np.max(newton.P), dq
        if dq[0] == 0.05e-9:
            assert chord.factorizations == factorized
