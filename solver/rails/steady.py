"""Steady flight: the attitude (z, pitch, roll) at which the film balances the suspension.

Newton's method on the three generalized-force balances

    f(q) = f_film(q) + f_susp(q) = 0,     q = (z, pitch, roll),

scaled by the preload (and the rail length for the moments), with a
finite-difference Jacobian; each evaluation is a steady Reynolds solve
warm-started from the previous pressure.  Steps are limited so that the
minimum spacing never falls below half its current value.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np

from solver.errors import AttitudeError
from solver.rails.dynamics import suspension_forces
from solver.rails.film import ReynoldsFilm, SteadyFilmError, make_film
from solver.rails.geometry import CORNERS, corner_positions, corner_spacings
from solver.rails.params import Scene, Suspension

log = logging.getLogger(__name__)

#: Force scale of the balance when the preload is tiny: this fraction of p0 times a rail's area [N].
FORCE_SCALE_FRACTION = 1e-3
#: Starting height: this many mean free paths, at least FLOOR [m] and twice the asperity height.
START_MEAN_FREE_PATHS = 1.5
START_HEIGHT_FLOOR = 2.0e-8
#: Starting pitch: this fraction of the starting height over the slider length [rad per (m/m)].
START_PITCH_FRACTION = 0.2
#: The balance must fall below this multiple of ``numerics.steady_tol`` (the film solve's own tolerance).
BALANCE_TOLERANCE_FACTOR = 100.0
#: Forward-difference steps of the attitude Jacobian: this fraction of the minimum spacing (z; over L for angles).
JACOBIAN_STEP = 1e-4
#: A Newton step changes the minimum spacing by at most this fraction of itself.
MAX_SPACING_CHANGE = 0.5
#: Step halvings of the line search, and the step fraction below which a step is taken anyway.
MAX_LINE_SEARCH_HALVINGS = 30
MIN_STEP_FRACTION = 1e-3


@dataclass
class SteadyFlight:
    """Steady flying attitude and the film that carries it."""

    z: float
    pitch: float
    roll: float
    min_spacing: float
    min_spacing_x1: float
    min_spacing_x2: float
    corner_spacings: np.ndarray
    load: float
    centre_of_pressure: tuple[float, float]
    bearing_number: float
    pressure: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    newton_iterations: int
    reynolds_solves: int
    force_residual: float
    suspension: Suspension

    @property
    def q(self) -> np.ndarray:
        return np.array([self.z, self.pitch, self.roll])


def _balance(film: ReynoldsFilm, scene: Scene, q: np.ndarray, P0: np.ndarray | None) -> np.ndarray:
    film.solve_steady(q, P0)
    f = film.generalized_forces() + suspension_forces(scene.suspension, q)
    scale = max(
        scene.suspension.preload,
        FORCE_SCALE_FRACTION * scene.air.ambient_pressure * film.length * scene.slider.rail_width,
    )
    return f / np.array([scale, scale * film.length, scale * film.length])


def initial_attitude(scene: Scene) -> np.ndarray:
    """A starting guess: flat parallel to the disk at 1.5 mean free paths (at least 20 nm)."""
    z = max(START_MEAN_FREE_PATHS * scene.air.mean_free_path, START_HEIGHT_FLOOR, 2.0 * scene.disk.asperity_height)
    return np.array([z, START_PITCH_FRACTION * z / scene.slider.length, 0.0])


def calibrated_suspension(scene: Scene, film: ReynoldsFilm, q: np.ndarray) -> Suspension:
    """The suspension that makes q an equilibrium: preload = Q(q), moments cancel the film's."""
    forces = film.generalized_forces()
    sus = scene.suspension
    return dataclasses.replace(
        sus,
        preload=float(forces[0]),
        static_pitch_moment=float(-forces[1] + sus.pitch_stiffness * q[1]),
        static_roll_moment=float(-forces[2] + sus.roll_stiffness * q[2]),
    )


def fly(
    scene: Scene, q0: np.ndarray | None = None, film: ReynoldsFilm | None = None, max_iter: int = 60
) -> SteadyFlight:
    """Steady flight of ``scene``, following ``scene.calibration.mode``.

    ``none``: Newton on the attitude with the scene's suspension.
    ``source_attitude``: the attitude is the calibration target and the
    suspension is set to balance the film there (:func:`calibrated_suspension`).
    """
    film = make_film(scene) if film is None else film
    cal = scene.calibration
    if film.P.shape[0] == 0 and cal.mode != "source_attitude":
        raise AttitudeError(
            "models.air_bearing = 'none' has no film to fly on: set calibration.mode = 'source_attitude' "
            "or pass the initial state"
        )
    if cal.mode == "source_attitude":
        q = np.array([cal.z, cal.pitch, cal.roll])
        film.solve_steady(q)
        suspension = calibrated_suspension(scene, film, q)
        return _steady_flight(scene, film, q, suspension, 0.0)
    q = initial_attitude(scene) if q0 is None else np.array(q0, dtype=float)
    tol = BALANCE_TOLERANCE_FACTOR * scene.numerics.steady_tol
    L = film.length
    P = None
    f = _balance(film, scene, q, P)
    P = film.P.copy()
    for it in range(1, max_iter + 1):
        if np.abs(f).max() < tol:
            break
        hmin = film.spacing(q).min()
        steps = np.array([JACOBIAN_STEP * hmin, JACOBIAN_STEP * hmin / L, JACOBIAN_STEP * hmin / L])
        jac = np.empty((3, 3))
        for k in range(3):
            dq = np.zeros(3)
            dq[k] = steps[k]
            jac[:, k] = (_balance(film, scene, q + dq, P) - f) / steps[k]
        dq = np.linalg.solve(jac, -f)
        # damp so the minimum spacing changes by at most half of itself
        change = np.abs(dq[0]) + L * (np.abs(dq[1]) + np.abs(dq[2]))
        scale = min(1.0, MAX_SPACING_CHANGE * hmin / max(change, 1e-300))
        for _ in range(MAX_LINE_SEARCH_HALVINGS):
            trial = q + scale * dq
            try:
                f_trial = _balance(film, scene, trial, P)
            except SteadyFilmError:
                scale *= 0.5
                continue
            if np.abs(f_trial).max() < np.abs(f).max() or scale < MIN_STEP_FRACTION:
                break
            scale *= 0.5
        q, f, P = trial, f_trial, film.P.copy()
        log.debug("attitude iteration %d: q=%s |f|=%.3g", it, q, np.abs(f).max())
    else:
        raise AttitudeError(
            f"steady attitude not found in {max_iter} iterations (force residual {np.abs(f).max():.3g})"
        )
    film.solve_steady(q, P)
    return _steady_flight(scene, film, q, scene.suspension, float(np.abs(f).max()))


def _steady_flight(
    scene: Scene, film: ReynoldsFilm, q: np.ndarray, suspension: Suspension, residual: float
) -> SteadyFlight:
    corners = corner_positions(scene.slider)
    at_corners = corner_spacings(q, corners)
    forces = film.generalized_forces()
    load = float(forces[0])
    if film.P.shape[0]:
        h = film.spacing(q)
        k = np.unravel_index(np.argmin(h), h.shape)
        hmin, where = float(h.min()), (float(film.x[k[1]]), float(film.y_abs[k[0], k[2]]))
        cop = (float(-forces[1] / load), float(-forces[2] / load))
    else:
        c = int(np.argmin(at_corners))
        hmin, where = float(at_corners[c]), (float(corners[c, 0]), float(corners[c, 1]))
        cop = (float("nan"), float("nan"))
    air, disk = scene.air, scene.disk
    return SteadyFlight(
        z=float(q[0]),
        pitch=float(q[1]),
        roll=float(q[2]),
        min_spacing=hmin,
        min_spacing_x1=where[0],
        min_spacing_x2=where[1],
        corner_spacings=at_corners,
        load=load,
        centre_of_pressure=cop,
        bearing_number=6.0 * air.viscosity * disk.speed * film.length / (air.ambient_pressure * hmin**2),
        pressure=film.P * air.ambient_pressure,
        x1=film.x.copy(),
        x2=film.y_abs.copy(),
        newton_iterations=film.work.newton_iterations,
        reynolds_solves=film.work.reynolds_solves,
        force_residual=residual,
        suspension=suspension,
    )


__all__ = ["CORNERS", "SteadyFlight", "fly", "AttitudeError"]
