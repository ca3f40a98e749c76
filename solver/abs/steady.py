"""Steady flight of an "abs" slider: film and surface forces balance the suspension."""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from solver.abs.dynamics import static_forces
from solver.abs.face import AbsGrid
from solver.abs.film import STEADY_ORDERING, AbsFilm, SteadyFilmError
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
    #: Where the equilibrium lies beyond the fold of the flying branch, on the branch held up by asperity contact:
    #: that fold and where it is, in words ("" on the flying branch).
    branch: str = ""
    #: The fold estimate (:meth:`SurfaceModel.touchdown_adhesion`): adhesion force [N] with the face lowered at this
    #: pitch and roll until its lowest patch is at eps, and that lowering [m].
    touchdown_adhesion: float = float("nan")
    touchdown_lowering: float = float("nan")
    #: Sparse LU factorizations of the steady film's Jacobian (the Reynolds solves reuse them while they contract).
    factorizations: int = 0


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
#: Tolerance of each steady Reynolds solve of the search.  Its force error grows with the grid: at 121 x 301 it
#: leaves a floor of 1.5e-5 preloads, above ``numerics.steady_tol``.  Where the search stalls, the tolerance is
#: tightened by FILM_TOLERANCE_STEP (down to FILM_TOLERANCE_MIN) and the search goes on from where it is.
FILM_TOLERANCE = 1e-9
FILM_TOLERANCE_STEP = 1e-3
FILM_TOLERANCE_MIN = 1e-13
#: Central-difference step of the film Jacobian in z [m] (over the slider length for the angles).
JACOBIAN_STEP = 2e-11
#: The residual's differences in :func:`_film_jacobian` take steps this much shorter: the flux is a power of the
#: spacing, and at JACOBIAN_STEP over a 1-nm pad its central difference is 4e-4 off, which the load's integral
#: of dP/dq (positive and negative parts) turns into percents of the pitch derivatives (measured).
RESIDUAL_STEP_FACTOR = 1e-2
#: A Newton step lowers no pad spacing by more than this fraction of it (spacings below FLOOR count as FLOOR [m]).
MAX_SPACING_DROP = 0.5
SPACING_FLOOR = 0.2e-9
#: Step halvings of the line search, and its sufficient-decrease factor (Armijo).
MAX_LINE_SEARCH_HALVINGS = 10
SUFFICIENT_DECREASE = 1e-4
#: Starting guess: pitch [rad] and the trailing pad's height [m].
START_PITCH = 150e-6
START_ELEMENT_HEIGHT = 10e-9


def face_spacing(scene: AbsScene, q: np.ndarray, x: np.ndarray, y: np.ndarray, etch: float) -> np.ndarray:
    """Spacing above the disk's mean plane [m] at points (x, y) of a region etched ``etch`` deep, at attitude q."""
    from solver.abs.face import shape

    s = scene.slider
    return etch + shape(x, y, scene) + q[0] - (x - s.pivot_x) * q[1] - (y - s.pivot_y) * q[2]


def exact_min_spacing(scene: AbsScene, q: np.ndarray) -> tuple[float, float, float]:
    """Smallest spacing over the pads (regions etched at most half the cavity) and where it is: (h, x, y) [m].

    The spacing is a quadratic in x and y on each region (plane, crown, camber, twist), so its minimum over a
    region's polygon lies at a vertex, at the minimum of the quadratic along an edge, or at its interior
    stationary point.  A candidate that a later region of another depth paints over is dropped (tested a hair
    inside its own region, so that shared edges count for both).  Exact, where the smallest spacing over the
    grid's nodes misses it by the slope times half a cell (first order in the grid spacing).
    """
    from solver.abs.face import inside_polygon, region_geometry

    s, regions = scene.slider, scene.abs.regions
    L, W = s.length, s.width
    best = (np.inf, np.nan, np.nan)
    for k, region in enumerate(regions):
        if scene.abs.base_depth > 0 and region.depth > 0.5 * scene.abs.base_depth:
            continue
        v = region_geometry(region, scene)
        w = np.roll(v, -1, axis=0)
        cand = [v]
        # along each edge h(t) = a t^2 + b t + c, from three points
        h0, hm, h1 = (face_spacing(scene, q, *(v + t * (w - v)).T, region.depth) for t in (0.0, 0.5, 1.0))
        a, b = 2.0 * (h0 + h1 - 2.0 * hm), 4.0 * hm - 3.0 * h0 - h1
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(a > 0, -b / (2.0 * a), -1.0)
        on = (t > 0) & (t < 1)
        cand.append(v[on] + t[on, None] * (w - v)[on])
        # interior: in xi = 2 (x - L/2) / L, eta = 2 y / W the gradient of shape - pitch x - roll y vanishes where
        # [[4 crown / L, 2 twist / L], [2 twist / W, 4 camber / W]] (xi, eta) = (pitch, roll)
        if s.crown > 0 and 4.0 * s.crown * s.camber > s.twist**2:
            xi, eta = np.linalg.solve([[4 * s.crown / L, 2 * s.twist / L], [2 * s.twist / W, 4 * s.camber / W]],
                                      [q[1], q[2]])  # fmt: skip
            c = np.array([[0.5 * L * (1.0 + xi), 0.5 * W * eta]])
            if inside_polygon(c[:, 0], c[:, 1], v)[0]:
                cand.append(c)
        pts = np.concatenate(cand)
        probe = pts + 1e-9 * L * np.sign(v.mean(axis=0) - pts)  # a hair inside this region
        covered = np.zeros(len(pts), dtype=bool)
        for later in regions[k + 1 :]:
            if later.depth != region.depth:
                covered |= inside_polygon(probe[:, 0], probe[:, 1], region_geometry(later, scene))
        h = np.where(covered, np.inf, face_spacing(scene, q, pts[:, 0], pts[:, 1], region.depth))
        n = int(np.argmin(h))
        if h[n] < best[0]:
            best = (float(h[n]), float(pts[n, 0]), float(pts[n, 1]))
    return best


def _attitude_text(q: np.ndarray) -> str:
    return f"z = {q[0] * 1e9:.3f} nm, pitch = {q[1] * 1e6:.2f} urad, roll = {q[2] * 1e6:.3f} urad"


def fly_abs(scene: AbsScene, film: AbsFilm | None = None, q0: np.ndarray | None = None) -> AbsSteady:
    """Steady attitude: film + surface forces balance the preload and static moments (smooth mean disk).

    First Newton's method from ``q0`` or the standard guess
    (:func:`_newton_flight`).  Where it fails and the scene has adhesion,
    the flight is continued from the one without adhesion along its
    flying height (:func:`_adhesion_continuation`): it reaches the scene's
    delta_gamma, or passes the fold of the branch, beyond which there is no
    flying equilibrium (an :class:`AttitudeError` naming the fold).
    """
    wall0 = time.perf_counter()
    film = film if film is not None else AbsFilm(scene)
    try:
        return _newton_flight(scene, film, q0)
    except (AttitudeError, SteadyFilmError) as err:
        if scene.contact.delta_gamma <= 0.0 or scene.models.contact == "none":
            raise
        first = err
    log.info("fly_abs: %s; continuing from the flight without adhesion", first)
    return _adhesion_continuation(scene, film, first, wall0)


def _newton_flight(scene: AbsScene, film: AbsFilm, q0: np.ndarray | None = None) -> AbsSteady:
    """Newton's method on the three balances, from q0 or the standard guess; an error where it fails.

    The balances are scaled by the preload (and the slider length for
    moments); the film's Jacobian by central differences (each a
    warm-started steady Reynolds solve), the surface forces' exactly.  A
    step is shortened so that the smallest pad spacing never falls below
    half its value, then halved until the largest residual falls (Armijo).
    The roughness acts only statistically here (sigma = the track RMS on
    every cell).
    """
    wall0 = time.perf_counter()
    grid = film.grid
    surface = SurfaceModel(scene, grid)
    track_sigma = np.full(grid.shape, scene.disk.rms)
    film.set_disk(np.zeros(grid.shape))
    f_static = static_forces(scene)
    L = scene.slider.length
    scale = np.array([1.0, L, L]) * max(scene.suspension.preload, MIN_FORCE_SCALE)
    pad = grid.depth <= 0.5 * scene.abs.base_depth if scene.abs.base_depth > 0 else np.ones(grid.shape, bool)

    film_tol = [FILM_TOLERANCE]

    def balance(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, SurfaceForces]:
        film.solve_steady(q, tol=film_tol[0])
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
        stalled = len(best) > STALL_WINDOW and best[-1] > STALL_RATIO * best[-1 - STALL_WINDOW]
        if it > STALL_AFTER and stalled and film_tol[0] > FILM_TOLERANCE_MIN:
            # the film's own tolerance may be the floor: tighten it and go on from here
            film_tol[0] = max(film_tol[0] * FILM_TOLERANCE_STEP, FILM_TOLERANCE_MIN)
            r, fa, sf = balance(q)
            P_keep = film.P.copy()
            best = [np.max(np.abs(r))]
            continue
        if it > STALL_AFTER and stalled:
            raise AttitudeError(
                f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the attitude search stalled "
                f"at a force residual of {best[-1]:.2e} preloads near {_attitude_text(q)}"
            )
        J = sf.dfdq / scale[:, None] + _film_jacobian(film, q, P_keep, scale)
        dq = np.linalg.solve(J, -r)
        step = _spacing_limited_step(film, surface, pad, q, dq)
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
    touchdown, lowering = surface.touchdown_adhesion(h, track_sigma)
    h_min, x_min, y_min = exact_min_spacing(scene, q)
    return AbsSteady(
        q=q,
        element_spacing=element_spacing(scene, q),
        min_spacing=h_min,
        min_spacing_x=x_min,
        min_spacing_y=y_min,
        air_force=fa,
        surface=sf,
        pressure=film.P[0].copy() * film.p0,
        x=grid.x,
        y=grid.y,
        depth=grid.depth,
        iterations=it - 1,
        reynolds_solves=film.reynolds_solves,
        factorizations=film.factorizations,
        force_residual=float(np.max(np.abs(r))),
        wall_time=time.perf_counter() - wall0,
        touchdown_adhesion=touchdown,
        touchdown_lowering=lowering,
    )


def fly_start(scene: AbsScene, film: AbsFilm | None = None) -> AbsSteady:
    """The steady state a run starts from: the scene's own, or, if adhesion leaves none, the flight without adhesion.

    Strong adhesion (large delta_gamma on a near-contact pad) ends the flying
    branch at a fold (the film's stiffness cannot hold the attraction's
    negative stiffness).  :func:`fly_abs` then looks for the equilibrium
    beyond it, held up by asperity contact (``branch`` says so); only where
    there is none does the run start from the steady flight with
    delta_gamma = 0, the dynamics showing where the adhesion takes the
    slider, and ``note`` says so.
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


def _with_adhesion(scene: AbsScene, delta_gamma: float) -> AbsScene:
    return dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, delta_gamma=delta_gamma))


class _HeightBalances:
    """The three balances at a prescribed element height, with delta_gamma as the third unknown.

    The surface forces are affine in delta_gamma (the adhesion pressure of
    either law is delta_gamma times a function of the spacing; contact and
    friction do not depend on it), so

        r(q, dg) = (f_film(q) + f_s(q; 0) + dg a(q) + f_static) / scale,   a = f_s(q; 1) - f_s(q; 0),

    and with the attitude q = (h - e0 - e1 pitch - e2 roll, pitch, roll)
    (e = :func:`element_row`) the unknowns u = (pitch, roll, dg) are regular
    through a fold in delta_gamma, where dg(h) has its maximum.
    """

    def __init__(self, scene: AbsScene, film: AbsFilm) -> None:
        grid = film.grid
        self.film = film
        self.free = SurfaceModel(_with_adhesion(scene, 0.0), grid)
        self.unit = SurfaceModel(_with_adhesion(scene, 1.0), grid)
        self.sigma = np.full(grid.shape, scene.disk.rms)
        self.f_static = static_forces(scene)
        L = scene.slider.length
        self.scale = np.array([1.0, L, L]) * max(scene.suspension.preload, MIN_FORCE_SCALE)
        self.pad = grid.depth <= 0.5 * scene.abs.base_depth if scene.abs.base_depth > 0 else np.ones(grid.shape, bool)
        self.row = element_row(scene)
        self.tol = scene.numerics.steady_tol
        #: dq / d(pitch, roll) at a fixed element height
        self.tangent = np.array([[-self.row[1], -self.row[2]], [1.0, 0.0], [0.0, 1.0]])
        self.iterations = 0

    def attitude(self, h: float, u: np.ndarray) -> np.ndarray:
        return np.array([h - self.row[0] - self.row[1] * u[0] - self.row[2] * u[1], u[0], u[1]])

    def residual(self, q: np.ndarray, dg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Scaled residual (3,), the surface Jacobian d(f_s / scale)/dq (3, 3) and a / scale (3,) at (q, dg)."""
        self.film.solve_steady(q, tol=FILM_TOLERANCE)
        d = self.film.spacing(q)
        free, unit = self.free.forces(d, self.sigma), self.unit.forces(d, self.sigma)
        rate = (unit.f - free.f) / self.scale
        dfdq = (free.dfdq + dg * (unit.dfdq - free.dfdq)) / self.scale[:, None]
        r = (self.film.forces() + free.f + self.f_static) / self.scale + dg * rate
        return r, dfdq, rate

    def correct(self, h: float, u: np.ndarray, max_iterations: int) -> np.ndarray | None:
        """Newton on u = (pitch, roll, dg) at element height h from u; the solution, or None if it fails.

        Steps are limited like those of :func:`_newton_flight` (pad spacing,
        then Armijo halvings of the largest residual).
        """
        film = self.film
        u = np.array(u, dtype=float)
        try:
            q = self.attitude(h, u)
            r, dfdq, rate = self.residual(q, u[2])
        except SteadyFilmError:
            return None
        P_keep = film.P.copy()
        for _ in range(max_iterations):
            if np.max(np.abs(r)) < self.tol:
                return u
            self.iterations += 1
            Jq = dfdq + _film_jacobian(film, q, P_keep, self.scale)
            A = np.column_stack([Jq @ self.tangent, rate])
            du = np.linalg.solve(A, -r)
            step = _spacing_limited_step(film, self.free, self.pad, q, self.tangent @ du[:2])
            trial = None
            for _ in range(MAX_LINE_SEARCH_HALVINGS):
                film.P[:] = P_keep
                try:
                    trial = self.residual(self.attitude(h, u + step * du), u[2] + step * du[2])
                except SteadyFilmError:
                    trial = None
                if trial is not None and np.max(np.abs(trial[0])) < np.max(np.abs(r)) * (
                    1.0 - SUFFICIENT_DECREASE * step
                ):
                    break
                trial = None
                step *= 0.5
            if trial is None:
                film.P[:] = P_keep
                return None
            u = u + step * du
            q = self.attitude(h, u)
            r, dfdq, rate = trial
            P_keep = film.P.copy()
            log.debug("height %.4f nm: pitch %.3f urad roll %.3f urad dg %.6f residual %s", h * 1e9, u[0] * 1e6,
                      u[1] * 1e6, u[2], r)  # fmt: skip
        film.P[:] = P_keep
        return u if np.max(np.abs(r)) < self.tol else None


#: Continuation along the flying height: first step, smallest and largest step [m], corrector iterations per
#: step, and the growth of a step after a corrector that needed at most EASY_STEP iterations.
HEIGHT_STEP = 0.05e-9
MIN_HEIGHT_STEP = 1e-13
#: The smallest step beyond the flying branch's fold [m]: there the corrector fails where the contact branch turns
#: sharply deep in the asperities (0.16 nm on the default face at delta_gamma 0.08), and each halving costs a failed
#: corrector.
MIN_HEIGHT_STEP_BEYOND_FOLD = 1e-12
MAX_HEIGHT_STEP = 0.1e-9
CORRECTOR_ITERATIONS = 8
EASY_STEP = 3
STEP_GROWTH = 1.5
#: The continuation gives up below this element height [m]: the pad is then deep in the asperities.
MIN_ELEMENT_HEIGHT = -1e-9


def _adhesion_continuation(scene: AbsScene, film: AbsFilm, first: Exception, wall0: float) -> AbsSteady:
    """Continue from the flight without adhesion along the flying height until delta_gamma is reached.

    The flight without adhesion (Newton from the standard guess) starts a
    branch of equilibria (q, dg) parametrized by the element height h:
    stepping h down, a predictor (secant in h) and :meth:`_HeightBalances.correct`
    give dg(h).  Adhesion grows as the pad comes down; where the branch
    reaches the scene's delta_gamma, Newton at that delta_gamma from the
    interpolated attitude finishes the flight.  Where dg(h) turns back
    first, its maximum is the fold of the flying branch (the parabola
    through the three points around the maximum locates it): no flying
    equilibrium exists beyond it.  The continuation goes on through the
    fold, down the unstable middle branch, to where the asperities' contact
    stiffens the balance and dg(h) rises again: where that contact branch
    reaches the scene's delta_gamma, the equilibrium is there, held up by
    contact (``branch`` names the fold).  On the default scene's face,
    110-um pad at 1.4 gf (121 x 101): the flying branch folds at 0.00516
    J/m2, dg(h) falls to 0.0048 and rises again, and 0.008 is reached at a
    flying height of 1.24 nm with 3.5 mN of contact.  Only where the branch
    goes deep into the asperities (MIN_ELEMENT_HEIGHT) without reaching it
    is there no equilibrium at all (an :class:`AttitudeError` naming the fold).
    """
    grid = film.grid
    target = scene.contact.delta_gamma
    P_first = film.P.copy()
    film.P[:] = 1.0
    try:
        free = _newton_flight(_with_adhesion(scene, 0.0), film)
    except (AttitudeError, SteadyFilmError) as err:
        raise AttitudeError(
            f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid, even without adhesion ({err}); "
            f"the attitude search with it had failed: {first}"
        ) from err
    bal = _HeightBalances(scene, film)
    iterations = free.iterations
    h = element_spacing(scene, free.q, bal.row)
    branch = [(h, np.array([free.q[1], free.q[2], 0.0]), film.P.copy())]
    dh = HEIGHT_STEP
    fold: tuple[float, float, np.ndarray] | None = None  # the flying branch's fold: (dg, h, u) once passed
    fold_index = 0  # the first point of the branch beyond it
    while True:
        h0, u0, P0 = branch[-1]
        if len(branch) > 1:
            h1, u1, _ = branch[-2]
            guess = u0 + (u0 - u1) * (dh / (h1 - h0))
        else:
            guess = u0
        film.P[:] = P0
        before = bal.iterations
        u = bal.correct(h0 - dh, guess, CORRECTOR_ITERATIONS)
        if u is None:
            dh *= 0.5
            if dh < (MIN_HEIGHT_STEP if fold is None else MIN_HEIGHT_STEP_BEYOND_FOLD):
                film.P[:] = P_first
                if fold is not None:
                    most = max(b[1][2] for b in branch[fold_index:])
                    raise _fold_error(scene, film, free, bal, fold, first, most, h0)
                raise AttitudeError(
                    f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the continuation in "
                    f"delta_gamma stopped at {u0[2]:.4g} J/m2 near {_attitude_text(bal.attitude(h0, u0))} "
                    f"(flying height {h0 * 1e9:.3f} nm); the attitude search had failed: {first}"
                )
            continue
        branch.append((h0 - dh, u, film.P.copy()))
        log.info("fly_abs continuation: flying height %.4f nm, delta_gamma %.6g J/m2", (h0 - dh) * 1e9, u[2])
        if u[2] >= target:
            w = (target - u0[2]) / (u[2] - u0[2])
            uq = u0 + w * (u - u0)
            q = bal.attitude(h0 - w * dh, uq)
            try:
                steady = _newton_flight(scene, film, q)
            except (AttitudeError, SteadyFilmError):
                branch.pop()
                dh *= 0.25
                continue
            steady.iterations += iterations + bal.iterations
            steady.wall_time = time.perf_counter() - wall0
            if fold is not None:
                steady.branch = (
                    f"beyond the fold of the flying branch at delta_gamma = {fold[0]:.4g} J/m2 (flying height "
                    f"{fold[1] * 1e9:.3f} nm): held up by asperity contact ({steady.surface.contact * 1e3:.4g} mN)"
                )
            return steady
        if fold is None and u[2] < u0[2] and len(branch) >= 3:
            top, hf = _parabola_peak(*[(b[0], b[1][2]) for b in branch[-3:]])
            (ha, ua, _), (hb, ub, _) = branch[-2], branch[-1]
            fold = (top, hf, ua + (hf - ha) / (hb - ha) * (ub - ua))
            fold_index = len(branch) - 1
            log.info("fly_abs continuation: the flying branch folds at delta_gamma %.6g J/m2", top)
        if h0 - 2.0 * dh < MIN_ELEMENT_HEIGHT:
            film.P[:] = P_first
            if fold is not None:
                most = max(b[1][2] for b in branch[fold_index:])
                raise _fold_error(scene, film, free, bal, fold, first, most, h0 - dh)
            raise AttitudeError(
                f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the continuation reached "
                f"deep into the asperities (flying height {(h0 - dh) * 1e9:.3f} nm) at delta_gamma = {u[2]:.4g} "
                f"J/m2 near {_attitude_text(bal.attitude(h0 - dh, u))}; the attitude search had failed: {first}"
            )
        if bal.iterations - before <= EASY_STEP:
            dh = min(MAX_HEIGHT_STEP, STEP_GROWTH * dh)


def _fold_error(
    scene: AbsScene,
    film: AbsFilm,
    free: AbsSteady,
    bal: _HeightBalances,
    fold: tuple,
    first: Exception,
    most: float,
    end: float,
) -> AttitudeError:
    """No equilibrium at all: the flying branch folds, and the branch beyond it stays below the scene's
    delta_gamma down to the flying height ``end`` where the continuation ended (``most``: the largest
    delta_gamma it reaches beyond the fold)."""
    grid, target = film.grid, scene.contact.delta_gamma
    top, hf, uf = fold
    touchdown, _ = SurfaceModel(scene, grid).touchdown_adhesion(film.spacing(free.q), bal.sigma)
    err = AttitudeError(
        f"no flying equilibrium on the {grid.shape[0]} x {grid.shape[1]} grid: the fold lies at delta_gamma "
        f"= {top:.4g} J/m2 (the scene asks {target:g}); beyond it the pad is pulled onto the disk "
        f"(at the fold: flying height {hf * 1e9:.3f} nm, {_attitude_text(bal.attitude(hf, uf))}; every "
        f"point of the branch balanced to a force residual below {bal.tol:.0e} preloads; beyond the fold, down to "
        f"a flying height of {end * 1e9:.3f} nm, the branch held up by asperity contact reaches at "
        f"most {most:.4g} J/m2; fold estimate: "
        f"{touchdown_text(touchdown, scene.suspension.preload)} with the face lowered to touch at the pitch "
        f"and roll of the flight without adhesion; Newton at delta_gamma = {target:g} had failed: {first})"
    )
    err.fold_delta_gamma = top
    err.touchdown_adhesion = touchdown
    return err


def touchdown_text(force: float, preload: float) -> str:
    """The fold estimate in words: 'adhesion at touchdown -5.912 mN = 0.754 preloads'."""
    ratio = -force / preload if preload > 0.0 else float("inf")
    return f"adhesion at touchdown {force * 1e3:.3f} mN = {ratio:.3g} preloads"


def _parabola_peak(*points: tuple[float, float]) -> tuple[float, float]:
    """Largest value and its abscissa of the parabola through three points (x, y), at least their largest y."""
    x, y = np.array(points).T
    a, b, c = np.polyfit(x - x[1], y, 2)
    top = int(np.argmax(y))
    if a >= 0.0:
        return float(y[top]), float(x[top])
    xs = -b / (2.0 * a)
    if not min(x) - x[1] <= xs <= max(x) - x[1]:
        return float(y[top]), float(x[top])
    return float(max(c - b * b / (4.0 * a), y[top])), float(xs + x[1])


def _film_jacobian(film: AbsFilm, q: np.ndarray, P_keep: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Scaled film forces' Jacobian d(f / scale)/dq (3, 3) of the steady film P_keep at q, by the implicit function.

    The steady film solves R(P; q) = 0, so dP/dq_k = -(dR/dP)^-1 dR/dq_k: one sparse LU of the Jacobian Newton
    converged with, and dR/dq_k by central differences of the residual at fixed P (the spacings move with q).
    The force's derivative is then the central difference of f along the solution's tangent, (P_keep +- s dP/dq_k,
    q +- s e_k).  Six residuals and six forces, against six warm-started steady solves (each a few sparse LUs)
    by differences of whole solves; the same Jacobian to the differences' truncation (tests/test_abs_steady.py).
    ``film.P`` is left at P_keep, its spacings at q.
    """
    L = film.length
    steps = np.array([JACOBIAN_STEP, JACOBIAN_STEP / L, JACOBIAN_STEP / L])
    film.P[:] = P_keep
    film.fill_faces(q)
    film.residual()
    lu = spla.splu(film.sparse_jacobian(), permc_spec=STEADY_ORDERING)
    film.factorizations += 1
    film.keep_steady_lu(lu)  # the exact Jacobian at the solution: the next nearby steady solve starts its chord on it
    inner = (0, slice(1, -1), slice(1, -1))
    J = np.zeros((3, 3))
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = steps[k] * RESIDUAL_STEP_FACTOR
        film.P[:] = P_keep  # the last column's forces moved it
        residuals = []
        for sign in (1.0, -1.0):
            film.fill_faces(q + sign * dq)
            residuals.append(film.residual()[inner].ravel())
        dP = -lu.solve((residuals[0] - residuals[1]) / (2.0 * dq[k])).reshape(film.P[inner].shape)
        dq[k] = steps[k]
        forces = []
        for sign in (1.0, -1.0):
            film.P[inner] = P_keep[inner] + sign * steps[k] * dP
            film.fill_faces(q + sign * dq)
            forces.append(film.forces())
        J[:, k] = (forces[0] - forces[1]) / scale / (2.0 * steps[k])
    film.P[:] = P_keep
    film.fill_faces(q)
    return J


def _spacing_limited_step(
    film: AbsFilm, surface: SurfaceModel, pad: np.ndarray, q: np.ndarray, dq: np.ndarray
) -> float:
    """The largest step (<= 1) along dq that lowers no pad spacing by more than MAX_SPACING_DROP of it."""
    h = film.spacing(q)[pad]
    change = dq @ surface.b[:, pad.ravel()]
    hmin_allowed = np.where(change < 0, -MAX_SPACING_DROP * np.maximum(h, SPACING_FLOOR) / change, np.inf)
    return min(1.0, float(hmin_allowed.min()))


def _initial_attitude(scene: AbsScene, grid: AbsGrid) -> np.ndarray:
    """Pitch START_PITCH, no roll, and z such that the trailing pad flies at START_ELEMENT_HEIGHT."""
    s = scene.slider
    pitch = START_PITCH
    return np.array([START_ELEMENT_HEIGHT + (s.element_x - s.pivot_x) * pitch, pitch, 0.0])
