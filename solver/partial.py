"""Partial-contact dynamics of an ABS slider over a moving rough track (scene kind "abs").

State q = (z, pitch, roll) about the pivot (:mod:`solver.absparams`).
Equations of motion

    M q'' + C q' + K (q - q_s) = f_s + f_air(q, t) + f_surface(q, t),

with the suspension's springs K and dampers C acting about the steady
attitude q_s, its preload and static moments f_s = (-F, M_p, M_r), the
film's generalized forces f_air and the surface forces on every cell of
the face: asperity (Greenwood-Williamson) or elastic (influence-coefficient)
contact pressure p_c, adhesion p_a and Coulomb friction mu p_c along the
disk's motion.  With the cell's spacing derivative b = (1, -(x - xp),
-(y - yp)) and the pivot a height t above the face,

    f_surface = sum_cells A [(p_c + p_a) b + mu p_c (0, -t cos psi, -t sin psi)].

Time integration: the generalized-alpha method (Chung & Hulbert 1993), a
Newmark-beta scheme whose equation of motion is balanced between the ends
of the step,

    M [(1 - am) a_n+1 + am a_n] + C [...] + K [...] = (1 - af) f_n+1 + af f_n,
    am = (2 rho - 1)/(rho + 1), af = rho/(rho + 1), gamma = 1/2 - am + af, beta = (1 - am + af)^2 / 4,

second order, with spectral radius rho (``numerics.rho_infinity``) at
infinite frequency: rho = 1 is the trapezoidal (average-acceleration)
Newmark rule.  The asperity contact's rotational modes (MHz, far above any
step we can afford) are stiff and hardening, and the trapezoidal rule
feeds them energy (a free bounce on a smooth disk with no air and no
friction rebounded with 5x its kinetic energy, 11x at dt / 4; 2.7x with
rho = 0.5).  The default rho = 0 annihilates them (the bounce keeps 28-44 %
of its kinetic energy: the rest went into the damped contact modes) at the
price of 2 % algorithmic damping at omega dt = 0.4 (300 kHz at dt = 0.2 us),
0.6 % at 200 kHz and 0.05 % below 80 kHz.  One step
t_n -> t_n+1:

1. predictor q* = q_n + dt v_n + dt^2 a_n / 2; the film is advanced along
   the attitude path it has followed (q*_n -> q*_n+1) with the disk moved
   to t_n+1 (:meth:`solver.film.AbsFilm.step`), giving f_air at t_n+1;
2. Newton's method on a_n+1 with the Newmark relations
   q = q_n + dt v_n + dt^2 ((1/2 - beta) a_n + beta a_n+1),
   v = v_n + dt ((1 - gamma) a_n + gamma a_n+1), the surface forces and
   their exact Jacobian implicit, the film force explicit.

The surface stiffness (asperities: 1e7-1e9 N/m) is far above the film's,
and the implicit treatment keeps the step stable with dt set by the film
and the disk's features, not by the contact.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .abs import AbsGrid
from .absparams import AbsScene
from .errors import AttitudeError
from .film import AbsFilm, SteadyFilmError
from .kernels import surface as ksurf

log = logging.getLogger(__name__)


# mass, suspension --------------------------------------------------------------------------------------


def mass_matrix(scene: AbsScene) -> np.ndarray:
    """3 x 3 mass matrix of (z, pitch, roll) about the pivot, mass centre at the face's centre."""
    s = scene.slider
    m = s.mass
    dx, dy = 0.5 * s.length - s.pivot_x, 0.0 - s.pivot_y
    return np.array(
        [
            [m, -m * dx, -m * dy],
            [-m * dx, s.pitch_inertia, m * dx * dy],
            [-m * dy, m * dx * dy, s.roll_inertia],
        ]
    )


def stiffness_damping(scene: AbsScene) -> tuple[np.ndarray, np.ndarray]:
    sus = scene.suspension
    K = np.diag([sus.vertical_stiffness, sus.pitch_stiffness, sus.roll_stiffness])
    C = np.diag([sus.vertical_damping, sus.pitch_damping, sus.roll_damping])
    return K, C


def static_forces(scene: AbsScene) -> np.ndarray:
    sus = scene.suspension
    return np.array([-sus.preload, sus.static_pitch_moment, sus.static_roll_moment])


# surface forces ----------------------------------------------------------------------------------------


@dataclass
class SurfaceForces:
    """Surface forces of one evaluation: generalized force (3,), its Jacobian (3, 3), and totals [N]."""

    f: np.ndarray
    dfdq: np.ndarray
    contact: float
    adhesion: float
    friction: float
    cells: int


@dataclass
class Candidates:
    """Cells near the disk for one time step: grid index, offset (surface - disk) [m], sigma [m], b (3, k)."""

    index: np.ndarray
    base: np.ndarray
    sigma: np.ndarray
    b: np.ndarray


class SurfaceModel:
    """Contact, adhesion and friction on the cells of the face (those near the disk)."""

    def __init__(self, scene: AbsScene, grid: AbsGrid) -> None:
        c = scene.contact
        self.law = scene.models.contact
        self.eps = c.equilibrium_spacing
        e_comp = 1.0 / ((1 - c.slider_poisson**2) / c.slider_modulus + (1 - c.disk_poisson**2) / c.disk_modulus)
        self.e_composite = e_comp
        self.gw_coef = 4.0 / 3.0 * c.summit_density * e_comp * math.sqrt(c.summit_radius)
        self.adh_coef = 8.0 * c.delta_gamma / (3.0 * self.eps)
        self.mu = c.mu
        psi = math.radians(scene.disk.skew)
        t = scene.slider.thickness
        self.friction_arm = np.array([0.0, -t * math.cos(psi), -t * math.sin(psi)])
        self.reach = self.eps + c.candidate_gap
        s = scene.slider
        X, Y = np.meshgrid(grid.x - s.pivot_x, grid.y - s.pivot_y, indexing="ij")
        self.b = np.stack([np.ones(X.size), -X.ravel(), -Y.ravel()])  # (3, n) d(spacing)/dq per node
        self.area = grid.area.ravel()
        self.xc, self.yc = grid.x, grid.y
        self.grid = grid
        self._out = np.zeros((4, 0))
        self._elastic = None

    def forces(self, d: np.ndarray, sigma: np.ndarray) -> SurfaceForces:
        """Surface forces for node spacings d (nx, ny) [m] and unresolved RMS sigma (nx, ny) [m]."""
        if self.law == "none":
            return SurfaceForces(np.zeros(3), np.zeros((3, 3)), 0.0, 0.0, 0.0, 0)
        d_flat, s_flat = d.ravel(), sigma.ravel()
        near = np.flatnonzero(d_flat < self.reach + 6.0 * s_flat)
        return self._on(near, d_flat[near], s_flat[near])

    def candidates(self, offset: np.ndarray, sigma: np.ndarray, q: np.ndarray, margin: float) -> Candidates:
        """The cells within reach (plus ``margin``) at attitude q; offset = static surface - disk height (nx, ny).

        A time step's Newton iterations then evaluate only these cells
        (:meth:`forces_on`), instead of the whole face.
        """
        base, s_flat = offset.ravel(), sigma.ravel()
        d = base + q @ self.b
        near = np.flatnonzero(d < self.reach + 6.0 * s_flat + margin)
        return Candidates(near, base[near], np.ascontiguousarray(s_flat[near]), np.ascontiguousarray(self.b[:, near]))

    def forces_on(self, cells: Candidates, q: np.ndarray) -> SurfaceForces:
        """Surface forces at attitude q from the candidate cells only."""
        if self.law == "none":
            return SurfaceForces(np.zeros(3), np.zeros((3, 3)), 0.0, 0.0, 0.0, 0)
        return self._on(cells.index, cells.base + q @ cells.b, cells.sigma, cells.b)

    def _on(self, near: np.ndarray, dn: np.ndarray, sn: np.ndarray, b: np.ndarray | None = None) -> SurfaceForces:
        if near.size == 0:
            return SurfaceForces(np.zeros(3), np.zeros((3, 3)), 0.0, 0.0, 0.0, 0)
        dn, sn = np.ascontiguousarray(dn), np.ascontiguousarray(sn)
        out = np.empty((4, near.size))
        ksurf.surface_pressures(dn, sn, self.eps, self.gw_coef, self.adh_coef, out)
        pc, dpc, pa, dpa = out
        if self.law == "elastic":
            pc, dpc_matrix = self._elastic_pressure(near, dn)
        area = self.area[near]
        b = self.b[:, near] if b is None else b
        fc = pc * area
        fa = pa * area
        f = b @ (fc + fa) + self.mu * fc.sum() * self.friction_arm
        if self.law == "elastic":
            dfdq = (b * (dpa * area)) @ b.T
            dfdq += (b * area) @ dpc_matrix @ b.T + self.mu * np.outer(self.friction_arm, area @ dpc_matrix @ b.T)
        else:
            w = dpc * area
            dfdq = (b * (w + dpa * area)) @ b.T + self.mu * np.outer(self.friction_arm, b @ w)
        in_reach = int(np.count_nonzero(dn < self.reach + 6.0 * sn))
        return SurfaceForces(f, dfdq, float(fc.sum()), float(fa.sum()), self.mu * float(fc.sum()), in_reach)

    def _elastic_pressure(self, near: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Elastic half-space contact on the cells whose rigid gap d - eps is negative (others cannot touch)."""
        from .elastic import influence_matrix, solve_contact

        gap = d - self.eps
        pc = np.zeros(d.size)
        dp = np.zeros((d.size, d.size))
        touching = np.flatnonzero(gap < 0.0)
        if touching.size == 0:
            return pc, dp
        ny = self.grid.y.size
        i, j = np.divmod(near[touching], ny)
        from .grid import control_volume_widths

        wx, wy = control_volume_widths(self.grid.x), control_volume_widths(self.grid.y)
        C = influence_matrix(self.grid.x[i], self.grid.y[j], 0.5 * wx[i], 0.5 * wy[j], self.e_composite)
        p, active = solve_contact(gap[touching], C, 1e-12)
        pc[touching] = p
        act = touching[np.asarray(active, dtype=bool)]
        if act.size:
            sub = np.flatnonzero(np.asarray(active, dtype=bool))
            dp[np.ix_(act, act)] = -np.linalg.inv(C[np.ix_(sub, sub)])
        return pc, dp


# disk track ------------------------------------------------------------------------------------------


class Track:
    """The disk under the slider: resolved heights z_d and unresolved RMS at the nodes at time t."""

    def __init__(self, scene: AbsScene, grid: AbsGrid, profile=None) -> None:
        from .disk import disk_tables, synthetic_profile
        from .grid import control_volume_widths

        disk, num = scene.disk, scene.numerics
        psi = math.radians(disk.skew)
        self.speed = disk.speed
        self.rms = disk.rms
        self.smooth = profile is None and disk.rms == 0.0
        nx, ny = grid.shape
        self.zero = np.zeros((nx, ny))
        if self.smooth:
            return
        if profile is None:
            if disk.profile_file:
                raise ValueError(
                    f"disk.profile_file = {disk.profile_file!r}: read it with pipeline.profiles.read_profile and "
                    "pass the profile (the solver does no file I/O)"
                )
            ell = disk.correlation_length
            length = self.speed * num.t_end + scene.slider.length * 2.0 + 32.0 * ell
            length = max(length, 16.0 * ell * 1.01)
            spacing = min(disk.profile_spacing, ell / 4.0)
            profile = synthetic_profile(disk.rms, ell, length, spacing, disk.seed, acf=disk.acf)
        self.profile = profile
        self.s_nodes = np.ascontiguousarray(grid.x[:, None] * math.cos(psi) + grid.y[None, :] * math.sin(psi))
        wx, wy = control_volume_widths(grid.x), control_volume_widths(grid.y)
        width = wx[:, None] * abs(math.cos(psi)) + wy[None, :] * abs(math.sin(psi))  # each cell along the track
        self.tables = disk_tables(profile, width)
        self.zd = np.zeros((nx, ny))
        self.sd = np.zeros((nx, ny))

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(z_d, sigma) at the nodes at time t: (nx, ny) each [m]; a smooth disk gives zeros."""
        if self.smooth:
            return self.zero, self.zero
        from .disk import disk_surface

        disk_surface(self.tables, self.s_nodes, self.speed * t, self.zd, self.sd)
        return self.zd.copy(), self.sd.copy()

    def steady_sigma(self, shape: tuple[int, int]) -> np.ndarray:
        """Unresolved RMS for the steady state: the whole roughness is statistical (no resolved profile)."""
        return np.full(shape, self.rms)


# steady flight ---------------------------------------------------------------------------------------------


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
    iterations: int
    reynolds_solves: int
    force_residual: float
    wall_time: float
    note: str = ""  # how the start was obtained when the scene itself has no steady flight


def element_row(scene: AbsScene) -> np.ndarray:
    """(surface, -(x_e - xp), -(y_e - yp)): the flying height at the element is element_row . (1, z, pitch, roll)."""
    from .abs import depth, shape

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
    scale = np.array([1.0, L, L]) * max(scene.suspension.preload, 1e-6)
    pad = grid.depth <= 0.5 * scene.abs.base_depth if scene.abs.base_depth > 0 else np.ones(grid.shape, bool)

    def balance(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, SurfaceForces]:
        film.solve_steady(q, tol=1e-9)
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
        if it > 8 and best[-1] > 0.5 * best[-7]:
            raise AttitudeError(
                f"no steady flight found on the {grid.shape[0]} x {grid.shape[1]} grid: the attitude search stalled "
                f"at a force residual of {best[-1]:.2e} preloads near {_attitude_text(q)}"
            )
        J = sf.dfdq / scale[:, None]
        steps = np.array([2e-11, 2e-11 / L, 2e-11 / L])
        for k in range(3):
            dq = np.zeros(3)
            dq[k] = steps[k]
            forces = []
            for sign in (1.0, -1.0):
                film.P[:] = P_keep
                film.solve_steady(q + sign * dq, tol=1e-9)
                forces.append(film.forces())
            J[:, k] += (forces[0] - forces[1]) / scale / (2.0 * steps[k])
        dq = np.linalg.solve(J, -r)
        h = film.spacing(q)[pad]
        change = dq @ surface.b[:, pad.ravel()]
        hmin_allowed = np.where(change < 0, -0.5 * np.maximum(h, 0.2e-9) / change, np.inf)
        step = min(1.0, float(hmin_allowed.min()))
        trial = None
        for _ in range(10):
            film.P[:] = P_keep
            try:
                trial = balance(q + step * dq)
            except SteadyFilmError:
                step *= 0.5
                continue
            if np.max(np.abs(trial[0])) < np.max(np.abs(r)) * (1.0 - 1e-4 * step):
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
    """Pitch 150 urad, no roll, and z such that the trailing pad flies at 10 nm."""
    s = scene.slider
    pitch = 150e-6
    return np.array([10e-9 + (s.element_x - s.pivot_x) * pitch, pitch, 0.0])


# dynamics ------------------------------------------------------------------------------------------------

#: A step whose Newton solve fails is halved at most this many times (dt / 256).
MAX_HALVINGS = 8


@dataclass
class AbsResult:
    """Time series and summary of one partial-contact run."""

    t: np.ndarray
    q: np.ndarray  # (n, 3)
    v: np.ndarray  # (n, 3)
    series: dict[str, np.ndarray]
    steady: AbsSteady
    status: int
    message: str
    work: dict[str, float] = field(default_factory=dict)


SERIES = {
    "flying_height": ("m", "flying height at the read/write element above the disk mean plane"),
    "clearance": ("m", "smallest spacing of the face to the resolved disk surface"),
    "contact_force": ("N", "normal contact force"),
    "adhesion_force": ("N", "adhesion force (negative: towards the disk)"),
    "friction_force": ("N", "friction force along the disk motion"),
    "air_force": ("N", "air-bearing force"),
    "contact_cells": ("1", "cells within reach of the surface forces"),
}


def simulate_abs(scene: AbsScene, steady: AbsSteady | None = None, profile=None) -> AbsResult:
    """Integrate one run from steady flight over the moving track; never raises for a physical failure.

    status 0: reached t_end; -1: the film or the Newton solve failed (message says where).
    """
    wall0 = time.perf_counter()
    num = scene.numerics
    film = AbsFilm(scene)
    grid = film.grid
    if steady is None:
        steady = fly_start(scene, film)
    else:
        film.set_disk(np.zeros(grid.shape))
        film.solve_steady(steady.q)
    track = Track(scene, grid, profile)
    surface = SurfaceModel(scene, grid)
    M = mass_matrix(scene)
    K, C = stiffness_damping(scene)
    f_static = static_forces(scene)
    q_ref = steady.q.copy()
    dt = num.dt
    rho = num.rho_infinity
    alpha_m, alpha_f = (2.0 * rho - 1.0) / (rho + 1.0), rho / (rho + 1.0)
    gamma = 0.5 - alpha_m + alpha_f
    beta = 0.25 * (1.0 - alpha_m + alpha_f) ** 2
    n_steps = int(round(num.t_end / dt))
    every = num.output_every
    use_air = scene.models.air_bearing == "reynolds"

    q = steady.q.copy()
    v = np.array([scene.initial.zdot, scene.initial.pitch_rate, scene.initial.roll_rate])
    zd, sd = track.at(0.0)
    film.set_disk(zd)
    f_air = film.forces() if use_air else np.zeros(3)
    sf = surface.forces(film.spacing(q), sd)
    a = np.linalg.solve(M, f_static + f_air + sf.f - C @ v - K @ (q - q_ref))
    q_film = q.copy()
    n_out = n_steps // every + 1
    t_out = np.empty(n_out)
    q_out = np.empty((n_out, 3))
    v_out = np.empty((n_out, 3))
    series = {k: np.empty(n_out) for k in SERIES}
    newton_total = 0
    status, message = 0, "reached t_end"
    tol = num.newton_tol * max(scene.suspension.preload, 1e-6)
    weights = np.array([1.0, 1.0 / scene.slider.length, 1.0 / scene.slider.length])

    fh_row = element_row(scene)
    offset_base = grid.surface  # the face's static surface; the disk height is subtracted per step

    def track_zd(zd_nodes: np.ndarray) -> np.ndarray:
        return zd_nodes

    def record(k: int, t: float, sf: SurfaceForces, f_air: np.ndarray, zd: np.ndarray) -> None:
        t_out[k] = t
        q_out[k] = q
        v_out[k] = v
        series["flying_height"][k] = element_spacing(scene, q, fh_row)
        series["clearance"][k] = float(np.min(film.spacing(q)))
        series["contact_force"][k] = sf.contact
        series["adhesion_force"][k] = sf.adhesion
        series["friction_force"][k] = sf.friction
        series["air_force"][k] = f_air[0]
        series["contact_cells"][k] = sf.cells

    record(0, 0.0, sf, f_air, zd)
    k_out = 1
    state = {"q": q, "v": v, "a": a, "q_film": q_film, "zd": zd, "f_air": f_air, "sf": sf}
    counters = {"newton": 0, "substeps": 0, "halvings": 0}

    def advance(t0: float, h: float, depth: int) -> str:
        """Advance ``state`` from t0 by h; on a failed Newton solve, restore the film and take two halves."""
        st = state
        q, v, a = st["q"], st["v"], st["a"]
        t1 = t0 + h
        zd1, sd1 = track.at(t1)
        q_pred = q + h * v + 0.5 * h * h * a
        P_saved = film.P.copy()

        def halve() -> str:
            film.P[:] = P_saved
            film.set_disk(st["zd"])
            counters["halvings"] += 1
            message = advance(t0, 0.5 * h, depth + 1)
            return message or advance(t0 + 0.5 * h, 0.5 * h, depth + 1)

        f_old = st["f_air"] + st["sf"].f
        margin = 2.0e-9 + float(np.abs(h * v + 2.0 * h * h * a) @ np.abs(surface.b).max(axis=1))
        cells = surface.candidates(offset_base - track_zd(zd1), sd1, q, margin)

        def newmark(a_trial: np.ndarray, f_air: np.ndarray):
            q1 = q + h * v + h * h * ((0.5 - beta) * a + beta * a_trial)
            v1 = v + h * ((1.0 - gamma) * a + gamma * a_trial)
            sf = surface.forces_on(cells, q1)
            G = (
                M @ ((1.0 - alpha_m) * a_trial + alpha_m * a)
                + C @ ((1.0 - alpha_f) * v1 + alpha_f * v)
                + K @ ((1.0 - alpha_f) * q1 + alpha_f * q - q_ref)
                - f_static
                - (1.0 - alpha_f) * (f_air + sf.f)
                - alpha_f * f_old
            )
            return q1, v1, sf, G

        # Two passes: the film moves along the predicted path, then again along the corrected one, so that
        # a hard contact (accelerations of 1e5 m/s2) never leaves the film on a path the slider did not take.
        q_path = q_pred
        a_new = a.copy()
        for sweep in range(2):
            f_air = st["f_air"]
            if use_air:
                if sweep:
                    film.P[:] = P_saved
                film.step(q, q_path, st["zd"], zd1, h)
                f_air = film.forces()
                if not (np.all(np.isfinite(f_air)) and np.all(film.P > 0.0)):
                    if depth >= MAX_HALVINGS:
                        return f"film failed (pressure not positive and finite) at t = {t1:.4g} s, dt / 2^{depth}"
                    return halve()
            else:
                film.set_disk(zd1)
            q1, v1, sf, G = newmark(a_new, f_air)
            norm = np.max(np.abs(G * weights))
            for it in range(num.newton_max_iter):
                counters["newton"] += 1
                if norm < tol or norm <= 1e-12 * (np.max(np.abs(sf.f * weights)) + np.max(np.abs(f_air * weights))):
                    break  # converged, absolutely or to round-off of the forces
                Jn = (1.0 - alpha_m) * M + (1.0 - alpha_f) * (gamma * h * C + beta * h * h * (K - sf.dfdq))
                step_a = np.linalg.solve(Jn, G)
                lam = 1.0
                for _ in range(12):  # backtracking: the contact and adhesion laws are steep power laws
                    trial = newmark(a_new - lam * step_a, f_air)
                    trial_norm = np.max(np.abs(trial[3] * weights))
                    if trial_norm < norm or lam < 1e-3:
                        break
                    lam *= 0.5
                a_new = a_new - lam * step_a
                q1, v1, sf, G = trial
                norm = trial_norm
                log.debug("t = %.4g Newton %d: |G| = %.3e (lambda %.3g)", t1, it, norm, lam)
            if norm >= tol and norm > 1e-12 * (np.max(np.abs(sf.f * weights)) + np.max(np.abs(f_air * weights))):
                if depth >= MAX_HALVINGS:
                    return f"Newton did not converge at t = {t1:.4g} s (|G| = {norm:.2e}) with dt / 2^{depth}"
                # A snap (adhesion pulling the pad in, a hard landing) outruns the step: restore, take two halves.
                return halve()
            if not use_air:
                break
            q_path = q1
        counters["substeps"] += 1
        state.update(q=q1, v=v1, a=a_new, q_film=q_path, zd=zd1, f_air=f_air, sf=sf)
        return ""

    n = -1
    for n in range(n_steps):
        t1 = (n + 1) * dt
        message_n = advance(n * dt, dt, 0)
        if message_n:
            status, message = -1, message_n
            break
        q, v = state["q"], state["v"]
        if (n + 1) % every == 0 and k_out < n_out:
            record(k_out, t1, state["sf"], state["f_air"], state["zd"])
            k_out += 1
    newton_total = counters["newton"]
    work = {
        "steps": n + 1 if n_steps else 0,
        "substeps": counters["substeps"],
        "step_halvings": counters["halvings"],
        "newton_iterations": newton_total,
        "reynolds_solves": film.reynolds_solves,
        "nodes": grid.x.size * grid.y.size,
        "wall_time": time.perf_counter() - wall0,
    }
    return AbsResult(
        t=t_out[:k_out],
        q=q_out[:k_out],
        v=v_out[:k_out],
        series={k: s[:k_out] for k, s in series.items()},
        steady=steady,
        status=status,
        message=message,
        work=work,
    )


# run summary ---------------------------------------------------------------------------------------------


def spectrum(t: np.ndarray, signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum (Hann window, mean removed): frequencies [Hz], amplitudes [signal units]."""
    n = signal.size
    if n < 4:
        return np.zeros(0), np.zeros(0)
    dt = (t[-1] - t[0]) / (n - 1)
    w = np.hanning(n)
    x = (signal - signal.mean()) * w
    amp = 2.0 * np.abs(np.fft.rfft(x)) / w.sum()
    return np.fft.rfftfreq(n, dt), amp


def summarize(result: AbsResult, scene: AbsScene) -> dict[str, float]:
    """Bouncing 3-sigma, contact measures and spectral peaks after the settling time."""
    num = scene.numerics
    keep = result.t >= num.settle_time - 1e-15
    t = result.t[keep]
    fh = result.series["flying_height"][keep]
    fc = result.series["contact_force"][keep]
    out = {
        "bouncing_3sigma": 3.0 * float(np.std(fh)) if fh.size else float("nan"),
        "mean_flying_height": float(np.mean(fh)) if fh.size else float("nan"),
        "min_clearance": float(np.min(result.series["clearance"][keep])) if fh.size else float("nan"),
        "mean_contact_force": float(np.mean(fc)) if fc.size else float("nan"),
        "max_contact_force": float(np.max(fc)) if fc.size else float("nan"),
        "contact_fraction": float(np.mean(fc > num.contact_threshold)) if fc.size else float("nan"),
        "mean_adhesion_force": float(np.mean(result.series["adhesion_force"][keep])) if fc.size else float("nan"),
        "mean_friction_force": float(np.mean(result.series["friction_force"][keep])) if fc.size else float("nan"),
    }
    for name, signal in (("fh", fh), ("pitch", result.q[keep, 1]), ("roll", result.q[keep, 2])):
        f, amp = spectrum(t, signal)
        out[f"{name}_peak_frequency"] = float(f[1:][np.argmax(amp[1:])]) if f.size > 1 else float("nan")
        out[f"{name}_peak_amplitude"] = float(np.max(amp[1:])) if f.size > 1 else float("nan")
    return out
