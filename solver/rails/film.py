"""Air-bearing models behind one interface, chosen by name (``models.air_bearing``).

``reynolds``: the time-dependent compressible Reynolds equation with slip
solved on-line on both rails (finite volumes, :mod:`solver.kernels.reynolds`).
``none``: no film at all (zero rails), for free flight and contact-only
checks; it runs through the same kernels with empty arrays.

Time step (implicit midpoint in the conserved variable P H, second order):

    sigma/dt A (P' H' - P H) + R((P + P')/2; (H + H')/2) = 0,

solved by Newton iterations whose matrix sigma/dt A H' + J/2 is replaced by
its approximate factorisation (line solves along x, then along y: cost
linear in the number of nodes).  The factorisation error is
(J_x/2)(sigma/dt A H')^-1 (J_y/2) delta; at the source's 0.1 us step it is
~1e-4 of the squeeze term because the film is squeeze-dominated
(p h^2 dt / (12 eta dy^2) ~ 1e-3 across a rail), so one iteration (a
linearly-implicit step, still second order) is the default.

Steady state: Newton with the exact Jacobian and a sparse direct solve,
globalised by pseudo-transient continuation (switched evolution relaxation).

Generalized forces of the film on (z, pitch, roll), from virtual work with
h = z - x1 th1 - x2 th2:   (Q, -S1 Q, -S2 Q) = int (p - p0) (1, -x1, -x2) dA.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from solver.errors import SteadyFilmError
from solver.grid import RailGrid, control_volume_widths, rail_grid
from solver.kernels import motion as km
from solver.kernels import reynolds as kr
from solver.rails.geometry import rail_centres
from solver.rails.params import Scene
from solver.slip import SLIP_LAWS

log = logging.getLogger(__name__)


@dataclass
class FilmWork:
    """Work counters of the film solver."""

    reynolds_solves: int = 0
    newton_iterations: int = 0
    sparse_solves: int = 0


@dataclass
class ReynoldsFilm:
    """On-line Reynolds film on the two rails of a taper-flat slider.

    Holds the grid, the scalings and the work arrays; the algorithms are the
    kernels' plain functions.  Arrays are (nr=2, nx, ny), rail 0 at x2 < 0.
    """

    scene: Scene
    grid: RailGrid = field(init=False)
    h_ref: float = 1.0e-7
    work: FilmWork = field(default_factory=FilmWork)

    def __post_init__(self) -> None:
        s, n = self.scene.slider, self.scene.numerics
        self.grid = rail_grid(
            s.taper_length,
            s.flat_front,
            s.flat_rear,
            s.rail_width,
            n.nx,
            n.taper_nodes,
            n.ny,
            n.cluster_x,
            n.cluster_y,
        )
        air, disk = self.scene.air, self.scene.disk
        self.length = s.length
        L, href, p0 = self.length, self.h_ref, air.ambient_pressure
        self.lam = 6.0 * air.viscosity * disk.speed * L / (p0 * href**2)
        self.sigma = 12.0 * air.viscosity * L**2 / (p0 * href**2)
        self.kn = air.mean_free_path / href
        self.c1, self.c2 = SLIP_LAWS[self.scene.models.slip].coefficients
        x, y = self.grid.x, self.grid.y
        nx, ny = x.size, y.size
        centres = rail_centres(s)
        self.x = x
        self.y_abs = centres[:, None] + y[None, :]
        self.xf = 0.5 * (x[1:] + x[:-1])
        self.yf_abs = 0.5 * (self.y_abs[:, 1:] + self.y_abs[:, :-1])
        self.dx = np.diff(x) / L
        self.dy = np.diff(y) / L
        self.dxc = control_volume_widths(x) / L
        self.dyc = control_volume_widths(y) / L
        self.area = np.outer(self.dxc, self.dyc)
        nr = 0 if self.scene.models.air_bearing == "none" else 2
        self.y_abs = self.y_abs[:nr]
        self.yf_abs = self.yf_abs[:nr]

        def recess(xs: np.ndarray, ncols: int) -> np.ndarray:
            depth = np.minimum(xs + s.flat_front, 0.0) * s.taper_angle
            return np.broadcast_to(-depth[None, :, None], (nr, xs.size, ncols)).copy()

        self.recess = recess(x, ny)
        self.recess_xf = recess(self.xf, ny)
        self.recess_yf = recess(x, ny - 1)
        shape = (nr, nx, ny)
        self.H = np.empty(shape)
        self.Hx = np.empty((nr, nx - 1, ny))
        self.Hy = np.empty((nr, nx, ny - 1))
        self.H_mid = np.empty(shape)
        self.Hx_mid = np.empty((nr, nx - 1, ny))
        self.Hy_mid = np.empty((nr, nx, ny - 1))
        self._Jy = tuple(np.zeros(shape) for _ in range(3))
        self._diag = np.empty(shape)
        self._delta = np.empty(shape)
        self._work = np.empty(shape)
        self._P_mid = np.empty(shape)
        self._P_old = np.empty(shape)
        self.P = np.ones(shape)

    def kernel_args(self) -> tuple:
        """Film arguments of :func:`solver.kernels.motion.verlet_step`, after ``P``."""
        n = self.scene.numerics
        return (
            self.x, self.y_abs, self.xf, self.yf_abs, self.recess, self.recess_xf, self.recess_yf,
            1.0 / self.h_ref, self.dx, self.dy, self.dxc, self.dyc, self.area,
            self.lam, self.kn, self.c1, self.c2, self.sigma, n.newton_max_iter, n.newton_tol,
            self._P_old, self._P_mid, self.Hx_mid, self.Hy_mid, *self._Jy, self._diag, self._delta, self._work,
        )  # fmt: skip

    def force_args(self) -> tuple:
        """(force_scale, moment_scale, x_scaled, y_scaled) of the generalized-force kernel."""
        p0, L = self.scene.air.ambient_pressure, self.length
        return (p0 * L**2, p0 * L**3, self.x / L, self.y_abs / L)

    # ------------------------------------------------------------------ geometry
    def fill_spacing(self, q: np.ndarray, H: np.ndarray, Hx: np.ndarray, Hy: np.ndarray) -> None:
        """Scaled spacing at nodes and faces for q = (z, pitch, roll)."""
        kr.fill_spacing(
            float(q[0]), float(q[1]), float(q[2]), self.x, self.y_abs, self.xf, self.yf_abs,
            self.recess, self.recess_xf, self.recess_yf, 1.0 / self.h_ref, H, Hx, Hy,
        )  # fmt: skip

    def spacing(self, q: np.ndarray) -> np.ndarray:
        """Spacing h [m] at the nodes, (2, nx, ny)."""
        H = np.empty_like(self.H)
        self.fill_spacing(q, H, np.empty_like(self.Hx), np.empty_like(self.Hy))
        return H * self.h_ref

    # ------------------------------------------------------------------ loads
    def generalized_forces(self, P: np.ndarray | None = None) -> np.ndarray:
        """(Q, -S1 Q, -S2 Q) of the film on (z, pitch, roll) [N, N m, N m]."""
        P = self.P if P is None else P
        q, qx, qy = kr.load_moments(P, self.area, self.x / self.length, self.y_abs / self.length)
        scale = self.scene.air.ambient_pressure * self.length**2
        return np.array([q * scale, -qx * scale * self.length, -qy * scale * self.length])

    # ------------------------------------------------------------------ steady
    def solve_steady(self, q: np.ndarray, P0: np.ndarray | None = None) -> np.ndarray:
        """Steady pressure (2, nx, ny) [p0 units] at attitude q; stored in ``self.P``."""
        if self.P.shape[0] == 0:
            return self.P
        self.fill_spacing(q, self.H, self.Hx, self.Hy)
        if np.any(self.H <= 0.0):
            raise SteadyFilmError(f"the slider touches the disk plane at attitude {q.tolist()}: spacing <= 0")
        try:
            P, its = steady_newton(
                self.H, self.Hx, self.Hy, self.dx, self.dy, self.dxc, self.dyc, self.lam, self.kn,
                self.c1, self.c2, self.scene.numerics.steady_tol, P0=P0,
            )  # fmt: skip
        except SteadyFilmError as err:
            raise SteadyFilmError(f"{err} at attitude {np.asarray(q).tolist()}") from None
        self.work.reynolds_solves += 1
        self.work.newton_iterations += its
        self.work.sparse_solves += its
        self.P = P
        return P

    # ------------------------------------------------------------------ air-bearing interface
    @property
    def reynolds(self) -> ReynoldsFilm:
        """The film that computes steady flight (itself)."""
        return self

    def start(self, steady) -> None:
        """Begin a run from steady flight (its pressure field)."""
        if steady.pressure.shape != self.P.shape:
            raise ValueError("the steady flight was computed on another grid than this scene's")
        self.P = steady.pressure / self.scene.air.ambient_pressure
        self._force_args = self.force_args()
        self._film_args = self.kernel_args()
        self._saved = self.P.copy()

    def forces(self, q: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:
        """Generalized film forces of the current pressure into ``out``."""
        fa = self._force_args
        km.generalized_forces(self.P, self.area, fa[2], fa[3], fa[0], fa[1], out)

    def advance(self, s, q, v, acc, f_air, minv, suspension) -> int:
        """One Verlet step of the slider on the film (in place); returns Newton iterations."""
        return km.verlet_step(s, q, v, acc, f_air, minv, suspension, *self._force_args, self.P, *self._film_args)

    def save(self) -> None:
        """Remember the film state (for a rejected step)."""
        self._saved[...] = self.P

    def restore(self) -> None:
        self.P[...] = self._saved

    # ------------------------------------------------------------------ dynamics
    def step(self, q_old: np.ndarray, q_new: np.ndarray, dt: float) -> int:
        """Advance ``self.P`` over dt while the attitude moves linearly from q_old to q_new.

        Returns the number of Newton iterations taken.
        """
        n = self.scene.numerics
        its = kr.film_step(
            self.P, np.asarray(q_old, dtype=float), np.asarray(q_new, dtype=float),
            self.x, self.y_abs, self.xf, self.yf_abs, self.recess, self.recess_xf, self.recess_yf,
            1.0 / self.h_ref, self.dx, self.dy, self.dxc, self.dyc, self.area,
            self.lam, self.kn, self.c1, self.c2, self.sigma / dt, n.newton_max_iter, n.newton_tol,
            self._P_old, self._P_mid, self.Hx_mid, self.Hy_mid, *self._Jy, self._diag, self._delta, self._work,
        )  # fmt: skip
        self.work.reynolds_solves += 1
        self.work.newton_iterations += its
        return its


def steady_newton(
    H: np.ndarray,
    Hx: np.ndarray,
    Hy: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dxc: np.ndarray,
    dyc: np.ndarray,
    lam: float,
    kn: float,
    c1: float,
    c2: float,
    tol: float,
    *,
    P0: np.ndarray | None = None,
    y_flux: bool = True,
    max_iter: int = 200,
) -> tuple[np.ndarray, int]:
    """Solve the steady scaled Reynolds equation R(P; H) = 0 with P = 1 on the edges.

    Newton's method with the exact Jacobian and a sparse direct solve,
    globalised by pseudo-transient continuation: each step solves
    (A H / tau + J) delta = -R, with the pseudo time step tau growing as
    the residual falls (switched evolution relaxation) until it is a pure
    Newton step.  Converged when tau > 1e6 and max |delta| < tol.

    Returns the pressure (nr, nx, ny) [p0] and the number of iterations.
    """
    shape = H.shape
    nr, nx, ny = shape
    R = np.zeros(shape)
    Jcx, Jxm, Jxp, Jcy, Jym, Jyp = (np.zeros(shape) for _ in range(6))
    interior = np.zeros(shape, dtype=bool)
    interior[:, 1:-1, 1:-1] = True
    area_h = (np.outer(dxc, dyc)[None, :, :] * H)[interior]
    P = np.ones(shape) if P0 is None else np.array(P0, dtype=float)
    tau = 1.0e-3 if P0 is None else 1.0e2
    res_prev = None
    step = np.inf
    for it in range(1, max_iter + 1):
        kr.assemble(P, H, Hx, Hy, dx, dy, dxc, dyc, lam, kn, c1, c2, R, Jcx, Jxm, Jxp, Jcy, Jym, Jyp, y_flux)
        res = float(np.abs(R[interior]).max())
        if res_prev is not None:
            tau = min(tau * min(1.0e3, max(2.0, res_prev / max(res, 1e-300))), 1.0e30)
        res_prev = res
        rhs = np.where(interior, -R, 0.0).ravel()
        delta = banded_solve(Jcx + Jcy, Jxm, Jxp, Jym, Jyp, interior, area_h / tau, rhs).reshape(shape)
        # keep the pressure positive: never let a node lose more than 90 %
        ratio = np.min(np.where(delta < 0.0, -0.9 * P / np.where(delta < 0.0, delta, -1.0), np.inf))
        P += min(1.0, ratio) * delta
        step = float(np.abs(delta).max())
        if step < tol and tau > 1.0e6:
            return P, it
    raise SteadyFilmError(
        f"steady Reynolds solve did not converge in {max_iter} iterations (last pressure change {step:.3g} p0)"
    )


def banded_solve(
    Jc: np.ndarray,
    Jxm: np.ndarray,
    Jxp: np.ndarray,
    Jym: np.ndarray,
    Jyp: np.ndarray,
    interior: np.ndarray,
    extra_diag: np.ndarray,
    rhs: np.ndarray,
) -> np.ndarray:
    """Solve the five-point Newton system (identity rows on the boundary) as one banded LU.

    Nodes are numbered (rail, x, y), so the couplings sit on the diagonals
    -ny, -1, +1, +ny: a LAPACK band solve with ny sub- and super-diagonals
    costs O(N ny^2), several times less than a general sparse LU here.
    """
    ny = Jc.shape[2]
    n = Jc.size
    ab = np.zeros((2 * ny + 1, n))
    main = np.ones(n)
    main[interior.ravel()] = Jc[interior] + extra_diag
    ab[ny] = main
    ab[ny + 1, :-1] = Jym.ravel()[1:]
    ab[ny - 1, 1:] = Jyp.ravel()[:-1]
    ab[2 * ny, :-ny] = Jxm.ravel()[ny:]
    ab[0, ny:] = Jxp.ravel()[:-ny]
    return sla.solve_banded((ny, ny), ab, rhs, overwrite_ab=True, check_finite=False)


def make_film(scene: Scene) -> ReynoldsFilm:
    """The on-line Reynolds film of ``scene`` (no rails when ``models.air_bearing = 'none'``)."""
    return ReynoldsFilm(scene)
