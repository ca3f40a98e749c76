"""Steady flight of an "abs" slider: film and surface forces balance the suspension."""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np

from solver.abs.dynamics import static_forces
from solver.abs.face import AbsGrid
from solver.abs.film import AbsFilm, SteadyFilmError
from solver.abs.forces import SurfaceForces, SurfaceModel
from solver.abs.params import AbsScene
from solver.errors import AttitudeError

log = logging.getLogger(__name__)


@dataclass
class AbsSteady:
    """Steady flying attitude and what carries it."""

    q: np.ndarray
    element_spacing: float
    min_spacing: float
    min_spacing_x: float
    min_spacing_y: float
    air_force: np.ndarray
    surface: SurfaceForces
    pressure: np.ndarray
    x: np.ndarray
    y: np.ndarray
    depth: np.ndarray  # etch depth of the face on the grid [m]
    iterations: int
    reynolds_solves: int
    force_residual: float
    wall_time: float
    note: str = ""  # how the start was obtained when the scene itself has no steady flight


def element_row(scene: AbsScene) -> np.ndarray:
    """(surface, -(x_e - xp), -(y_e - yp)): the flying height at the element is element_row . (1, z, pitch, roll)."""
    from solver.abs.face import depth, shape

    s = scene.slider
    surf = float(depth(np.array(s.element_x), np.array(s.element_y), scene)) + float(
        shape(s.element_x, s.element_y, scene)
    )
    return np.array([surf, -(s.element_x - s.pivot_x), -(s.element_y - s.pivot_y)])


def element_spacing(scene: AbsScene, q: np.ndarray, row: np.ndarray | None = None) -> float:
    """Flying height at the read/write element above the disk's mean plane [m] (static surface included)."""
    row = element_row(scene) if row is None else row
    return float(row[0] + q[0] + row[1] * q[1] + row[2] * q[2])


#: Newton iterations of the steady attitude search before it gives up.
MAX_ATTITUDE_ITERATIONS = 40
#: The search has stalled when after STALL_AFTER iterations the best residual has not halved
#: (STALL_RATIO) over the last STALL_WINDOW iterations.
STALL_AFTER = 8
STALL_RATIO = 0.5
STALL_WINDOW = 6
#: Force scale floor of the balances when the preload is zero [N].
MIN_FORCE_SCALE = 1e-6
#: Tolerance of each steady Reynolds solve of the search.
FILM_TOLERANCE = 1e-9
#: Central-difference step of the film Jacobian in z [m] (over the slider length for the angles).
JACOBIAN_STEP = 2e-11
#: A Newton step lowers no pad spacing by more than this fraction of it (spacings below FLOOR count as FLOOR [m]).
MAX_SPACING_DROP = 0.5
SPACING_FLOOR = 0.2e-9
#: Step halvings of the line search, and its sufficient-decrease factor (Armijo).
MAX_LINE_SEARCH_HALVINGS = 10
SUFFICIENT_DECREASE = 1e-4
#: Starting guess: pitch [rad] and the trailing pad's height [m].
START_PITCH = 150e-6
START_ELEMENT_HEIGHT = 10e-9


def _attitude_text(q: np.ndarray) -> str:
    return f"z = {q[0] * 1e9:.3f} nm, pitch = {q[1] * 1e6:.2f} urad, roll = {q[2] * 1e6:.3f} urad"


def fly_abs(scene: AbsScene, film: AbsFilm | None = None, q0: np.ndarray | None = None) -> AbsSteady:
    """Steady attitude: film + surface forces balance the preload and static moments (smooth mean disk).

    Newton's method on the three balances scaled by the preload (and the
    slider length for moments); the film's Jacobian by forward differences
    (each a warm-started steady Reynolds solve), the surface forces'
    exactly.  A step is shortened so that the smallest pad spacing never
    falls below half its value.  The roughness acts only statistically
    here (sigma = the track RMS on every cell).
    """
    wall0 = time.perf_counter()
    film = film if film is not None else AbsFilm(scene)
    grid = film.grid
    surface = SurfaceModel(scene, grid)
    track_sigma = np.full(grid.shape, scene.disk.rms)
    film.set_disk(np.zeros(grid.shape))
    f_static = static_forces(scene)
    L = scene.slider.length
    scale = np.array([1.0, L, L]) * max(scene.suspension.preload, MIN_FORCE_SCALE)
    pad = grid.depth <= 0.5 * scene.abs.base_depth if scene.abs.base_depth > 0 else np.ones(grid.shape, bool)

    def balance(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, SurfaceForces]:
        film.solve_steady(q, tol=FILM_TOLERANCE)
        fa = film.forces()
        sf = surface.forces(film.spacing(q), track_sigma)
        return (fa + sf.f + f_static) / scale, fa, sf

    q = np.array(q0, dtype=float) if q0 is not None else _initial_attitude(scene, grid)
    r, fa, sf = balance(q)
    P_keep = film.P.copy()
    best = [np.max(np.abs(r))]
    for it in range(1, MAX_ATTITUDE_ITERATIONS + 1):
        if np.max(np.abs(r)) < scene.numerics.steady_tol:
            break
        if it > STALL_AFTER and best[-1] > STALL_RATIO * best[-1 - STALL_WINDOW]:
            raise AttitudeError(
                f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the attitude search stalled "
                f"at a force residual of {best[-1]:.2e} preloads near {_attitude_text(q)}"
            )
        J = sf.dfdq / scale[:, None]
        steps = np.array([JACOBIAN_STEP, JACOBIAN_STEP / L, JACOBIAN_STEP / L])
        for k in range(3):
            dq = np.zeros(3)
            dq[k] = steps[k]
            forces = []
            for sign in (1.0, -1.0):
                film.P[:] = P_keep
                film.solve_steady(q + sign * dq, tol=FILM_TOLERANCE)
                forces.append(film.forces())
            J[:, k] += (forces[0] - forces[1]) / scale / (2.0 * steps[k])
        dq = np.linalg.solve(J, -r)
        h = film.spacing(q)[pad]
        change = dq @ surface.b[:, pad.ravel()]
        hmin_allowed = np.where(change < 0, -MAX_SPACING_DROP * np.maximum(h, SPACING_FLOOR) / change, np.inf)
        step = min(1.0, float(hmin_allowed.min()))
        trial = None
        for _ in range(MAX_LINE_SEARCH_HALVINGS):
            film.P[:] = P_keep
            try:
                trial = balance(q + step * dq)
            except SteadyFilmError:
                step *= 0.5
                continue
            if np.max(np.abs(trial[0])) < np.max(np.abs(r)) * (1.0 - SUFFICIENT_DECREASE * step):
                break
            step *= 0.5
        if trial is None:
            raise AttitudeError(
                f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the steady film does not "
                f"converge near {_attitude_text(q)}"
            )
        r_new, fa_new, sf_new = trial
        q = q + step * dq
        r, fa, sf = r_new, fa_new, sf_new
        P_keep = film.P.copy()
        best.append(min(best[-1], float(np.max(np.abs(r)))))
        log.info("fly_abs %d: q = %s residual %.2e step %.3f", it, q, np.max(np.abs(r)), step)
    else:
        raise AttitudeError(
            f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the attitude search did not "
            f"converge in {MAX_ATTITUDE_ITERATIONS} iterations (force residual {np.max(np.abs(r)):.2e} preloads "
            f"near {_attitude_text(q)})"
        )
    h = film.spacing(q)
    hp = np.where(pad, h, np.inf)
    k = np.unravel_index(np.argmin(hp), h.shape)
    return AbsSteady(
        q=q,
        element_spacing=element_spacing(scene, q),
        min_spacing=float(hp[k]),
        min_spacing_x=float(grid.x[k[0]]),
        min_spacing_y=float(grid.y[k[1]]),
        air_force=fa,
        surface=sf,
        pressure=film.P[0].copy() * film.p0,
        x=grid.x,
        y=grid.y,
        depth=grid.depth,
        iterations=it - 1,
        reynolds_solves=film.reynolds_solves,
        force_residual=float(np.max(np.abs(r))),
        wall_time=time.perf_counter() - wall0,
    )


def fly_start(scene: AbsScene, film: AbsFilm | None = None) -> AbsSteady:
    """The steady flight a run starts from: the scene's own, or, if adhesion leaves none, the one without adhesion.

    Strong adhesion (large delta_gamma on a near-contact pad) can remove the
    flying equilibrium altogether (the film's stiffness cannot hold the
    attraction's negative stiffness: a fold).  The run then starts from the
    steady flight with delta_gamma = 0 and the dynamics show where the
    adhesion takes the slider; ``note`` says so.
    """
    try:
        return fly_abs(scene, film)
    except (AttitudeError, SteadyFilmError) as err:
        if scene.contact.delta_gamma == 0.0:
            raise
        free = dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, delta_gamma=0.0))
        steady = fly_abs(free, film)
        steady.note = (
            f"no steady flight with delta_gamma = {scene.contact.delta_gamma} J/m2 ({err}); "
            "the run starts from the steady flight without adhesion"
        )
        log.info(steady.note)
        return steady


def _initial_attitude(scene: AbsScene, grid: AbsGrid) -> np.ndarray:
    """Pitch START_PITCH, no roll, and z such that the trailing pad flies at START_ELEMENT_HEIGHT."""
    s = scene.slider
    pitch = START_PITCH
    return np.array([START_ELEMENT_HEIGHT + (s.element_x - s.pivot_x) * pitch, pitch, 0.0])
