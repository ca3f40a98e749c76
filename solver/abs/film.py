"""The air film under an arbitrary air-bearing surface: steady solves and time steps.

:class:`AbsFilm` owns the grid, the scalings and the work arrays of
:mod:`solver.kernels.film` for one scene of kind "abs".  The film sees the
spacing

    h = max(z - (x - xp) pitch - (y - yp) roll + s(x, y) - z_d(x, y, t), film_floor),

where z_d is the resolved disk height under each node (the moving track
profile, :mod:`solver.disk`); nodes where the slider touches the disk keep
a film of ``numerics.film_floor`` so that the Reynolds equation stays
defined (the contact itself is the surface model's business).

Steady solves use Newton's method with the exact Jacobian (sparse direct,
SuperLU); time steps use a linearly implicit step (``numerics.film_scheme``: the
midpoint rule, or BDF2 over the film's last two steps) with approximate
factorisation, whose cost is linear in the number of nodes.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from solver.abs.face import AbsGrid, abs_grid
from solver.abs.params import FILM_SCHEMES, AbsScene
from solver.errors import SteadyFilmError
from solver.grid import control_volume_widths
from solver.kernels import film as kf
from solver.slip import slip_code

#: A chord iteration of :meth:`AbsFilm.solve_steady` keeps its LU while each residual falls to this share of
#: the last one; beyond it the Jacobian is factorized afresh.
CHORD_CONTRACTION = 0.3
#: Column ordering of the steady Jacobian's sparse LU (SuperLU): minimum degree on A^T + A, the 5-point
#: Jacobian's pattern being symmetric (about half of COLAMD's fill on the default face).
STEADY_ORDERING = "MMD_AT_PLUS_A"
#: Newton's step counts as stalled when the positivity limit cuts it below STALL_STEP this many times in a row;
#: :meth:`AbsFilm.solve_steady` then starts again with pseudo-transient continuation, at most PTC_MAX_ITER
#: iterations, until its pseudo-time factor reaches PTC_TAU_MAX (plain Newton).
STALL_STEP = 0.05
STALL_STEP_COUNT = 3
PTC_MAX_ITER = 200
PTC_TAU_MAX = 1e12

#: Reference spacing of the scaled equation [m].
H_REF = 10.0e-9
#: BDF2 (``numerics.film_scheme``) takes a step at most this much longer than the film's last one; a longer step
#: (after a contact's substeps) is backward Euler.  Variable-step BDF2 is zero-stable for ratios below 1 + sqrt(2);
#: 2 made no difference to the coupled instability it was suspected of (README, "The film's time scheme").
BDF2_MAX_RATIO = 1.0


class AbsFilm:
    """Reynolds film of an ABS scene on its tensor grid."""

    def __init__(self, scene: AbsScene, grid: AbsGrid | None = None) -> None:
        self.scene = scene
        self.grid = grid if grid is not None else abs_grid(scene)
        g = self.grid
        s, air = scene.slider, scene.air
        self.length = s.length
        self.p0 = air.ambient_pressure
        self.h_ref = H_REF
        self.inv_href = 1.0 / H_REF
        ux, uy = scene.disk.velocity
        scale = 6.0 * air.viscosity * s.length / (air.ambient_pressure * H_REF**2)
        self.lamx, self.lamy = scale * ux, scale * uy
        self.sigma = 12.0 * air.viscosity * s.length**2 / (air.ambient_pressure * H_REF**2)
        self.kn = air.mean_free_path / H_REF
        self.code = slip_code(scene.models.slip)
        self.h_switch = scene.models.slip_switch
        self.floor = scene.numerics.film_floor
        self.pivot = (s.pivot_x, s.pivot_y)
        X, Y = g.x / s.length, g.y / s.length
        self.dx, self.dy = np.diff(X), np.diff(Y)
        self.dxc, self.dyc = control_volume_widths(X), control_volume_widths(Y)
        self.area_scaled = self.dxc[:, None] * self.dyc[None, :]
        nx, ny = g.shape
        self.shape = (nx, ny)
        z3 = lambda *shape: np.zeros((1, *shape))  # noqa: E731
        self.storage = g.storage[None]
        self.surface_xf = g.surface_xf[None]
        self.surface_yf = g.surface_yf[None]
        self.P = np.ones((1, nx, ny))
        self.H = z3(nx, ny)
        self.H_new = z3(nx, ny)
        self.Hx = z3(nx - 1, ny)
        self.Hy = z3(nx, ny - 1)
        self.Hxe = np.zeros((2, nx - 1, ny))  # spacings at the two nodes of each link, on its surface
        self.Hye = np.zeros((2, nx, ny - 1))
        self.disk = z3(nx, ny)
        self.disk_xf = z3(nx - 1, ny)
        self.disk_yf = z3(nx, ny - 1)
        self._disk_mid = np.zeros((nx, ny))
        self.constants = kf.AbsFilmConstants(
            dx=self.dx, dy=self.dy, dxc=self.dxc, dyc=self.dyc, area=self.area_scaled, lamx=self.lamx,
            lamy=self.lamy, kn=self.kn, h_ref=self.h_ref, h_switch=self.h_switch, code=self.code,
        )  # fmt: skip
        self.scratch = kf.AbsFilmScratch(
            R=z3(nx, ny), Jcx=z3(nx, ny), Jxm=z3(nx, ny), Jxp=z3(nx, ny), Jcy=z3(nx, ny), Jym=z3(nx, ny),
            Jyp=z3(nx, ny), xface=np.zeros((3, nx - 1, ny)), yface=np.zeros((3, nx, ny - 1)),
            diag=z3(nx, ny), rhs=z3(nx, ny), delta=z3(nx, ny), work=z3(nx, ny),
        )  # fmt: skip
        cx, cy = g.cuts_x, g.cuts_y
        self._owner = (cx.owner, cy.owner)
        self.cuts = kf.AbsFilmCuts(
            xface=cx.face, xpiece_ptr=cx.piece_ptr, xweight=cx.piece_weight, xseg_ptr=cx.seg_ptr,
            xtheta=cx.seg_theta, xH=np.zeros((3, cx.seg_theta.size)), yface=cy.face, ypiece_ptr=cy.piece_ptr,
            yweight=cy.piece_weight, yseg_ptr=cy.seg_ptr, ytheta=cy.seg_theta, yH=np.zeros((3, cy.seg_theta.size)),
            xowner=self._owner[0], xcoef=np.zeros((6, cx.seg_theta.size)), yowner=self._owner[1],
            ycoef=np.zeros((6, cy.seg_theta.size)), xcell=kf.segment_cells(cx.face, cx.owner, ny),
            ycell=kf.segment_cells(cy.face, cy.owner, ny - 1),
        )  # fmt: skip
        # the force's link corrections get coefficient scratch of their own (the step's are read after it)
        self._coef = (np.zeros((6, cx.seg_theta.size)), np.zeros((6, cy.seg_theta.size)))
        self._edges = (self._edge_links(0, cx.face), self._edge_links(1, cy.face))
        self._width_x, self._width_y = control_volume_widths(g.x), control_volume_widths(g.y)  # [m]
        self._links = self._link_arguments()
        self._advance_geometry = (
            g.x, g.y, *self.pivot, self.storage, self.surface_xf, self.surface_yf, g.surface_xe, g.surface_ye,
            self.inv_href, self.floor, cx.seg_x, cx.seg_y, cx.seg_surface, cy.seg_x, cy.seg_y, cy.seg_surface,
        )  # fmt: skip
        # the kernels take them as plain tuples, which numba dispatches faster (see AbsFilmConstants)
        self._kernel_film = (tuple(self.constants), tuple(self.scratch), tuple(self.cuts))
        self._pattern = _jacobian_pattern(nx, ny)
        # BDF2's history: m = P H at the nodes at the start of the last accepted film step and that step's size
        # (0: none), and what the last call of step() would make of it (commit_step() accepts it)
        self.scheme = FILM_SCHEMES.index(scene.numerics.film_scheme)  # kf.SCHEME_*
        self.bdf2 = self.scheme == kf.SCHEME_BDF2
        # The trapezoid's history: R(P_n) at the start of the next step, the last accepted step's end residual
        # carried to its pressure (numerics.film_start_flux 'carried'; valid where _history_h > 0 and P is still
        # _P_history, the pressure it was carried to), and the pressure the last kept step left (commit_step carries
        # the residual on to the pressure the slider's correction leaves).
        self.carried = self.scheme == kf.SCHEME_TRAPEZOID and scene.numerics.film_start_flux == "carried"
        self._flux_start = z3(nx, ny)  # the trapezoid's R(P_n) at the step's start (scratch)
        self._carries = (z3(nx, ny), z3(nx, ny))  # the trapezoid's carried residuals: kept steps', probes'
        self._P_left, self._P_history = z3(nx, ny), z3(nx, ny)
        self._history, self._history_h = z3(nx, ny), 0.0
        self._pending, self._pending_h = z3(nx, ny), 0.0
        self.last_ratio = 0.0  # BDF2's step ratio of the last step() (of its first film step); 0: backward Euler
        self.reynolds_solves = 0
        self.newton_iterations = 0
        self.factorizations = 0  # sparse LUs of the steady Jacobian (solve_steady reuses one while it contracts)
        self._steady_lu = None
        self.pseudo_transient_restarts = 0  # solve_steady's restarts once Newton's steps stalled

    # spacing ------------------------------------------------------------------------------------------

    def set_disk(self, disk_nodes: np.ndarray) -> None:
        """Resolved disk heights z_d at the nodes (nx, ny) [m]; faces take the mean of their two nodes."""
        kf.set_disk(np.ascontiguousarray(disk_nodes, dtype=float), self.disk, self.disk_xf, self.disk_yf)

    def fill_faces(self, q: np.ndarray) -> None:
        """The links' spacings at attitude q over the current disk (:func:`solver.kernels.film.fill_links`), and the
        cut links' segments' (the disk of their link)."""
        g = self.grid
        kf.fill_links(q, g.x, g.y, *self.pivot, self.surface_xf, self.surface_yf, g.surface_xe, g.surface_ye,
                      self.disk, self.inv_href, self.floor, self.Hx, self.Hy, self.Hxe, self.Hye)  # fmt: skip
        for cuts, disk, cell, H in ((g.cuts_x, self.disk_xf, self.cuts.xcell, self.cuts.xH),
                                    (g.cuts_y, self.disk_yf, self.cuts.ycell, self.cuts.yH)):  # fmt: skip
            kf.fill_cut_points(q, cuts.seg_x, cuts.seg_y, *self.pivot, cuts.seg_surface, disk, cell, self.inv_href,
                               self.floor, H)  # fmt: skip

    def fill_nodes(self, q: np.ndarray, out: np.ndarray) -> None:
        """Scaled spacing of each control volume's mean surface (what its squeeze term stores)."""
        g = self.grid
        kf.fill_spacing(q, g.x, g.y, *self.pivot, self.storage, self.disk, self.inv_href, self.floor, out)

    def spacing(self, q: np.ndarray) -> np.ndarray:
        """Physical spacing at each control volume's contact patch (nx, ny) [m], without the floor."""
        g = self.grid
        z, pitch, roll = q
        return (
            z - (g.contact_x - self.pivot[0]) * pitch - (g.contact_y - self.pivot[1]) * roll + g.surface - self.disk[0]
        )

    # forces -------------------------------------------------------------------------------------------

    def forces(self) -> np.ndarray:
        """Generalized film forces on (z, pitch, roll) [N, N m, N m] from the current pressure.

        The node quadrature, with the exact segment profiles in place of its trapezoids
        (:func:`solver.kernels.film.cut_corrections`) on the cut links and on the links to the edge of the face.
        An edge link of a thin film holds the pressure's boundary layer against P = 1 (the trailing edge of a
        pad that reaches it): the quadrature gives the edge node's half cell the ambient pressure, a first-order
        error in the load (order 0.99 on a plane wedge at Lambda 9571, against 1.97 at Lambda 61).
        """
        g, (xp, yp) = self.grid, self.pivot
        return self.p0 * np.array(kf.film_forces_linked(self.P, g.area, g.x, g.y, xp, yp, *self._links))

    def force_gradient(self) -> np.ndarray:
        """d(:meth:`forces`)/dP at the current pressure and spacings: (3, nx, ny) [N, N m, N m per unit P].

        The node quadrature's weights, plus the link corrections' derivatives by central differences at the
        nodes of the cut and edge links (each correction depends on its link's two node pressures only).
        """
        g, (xp, yp) = self.grid, self.pivot
        grad = np.stack([g.area, -(g.x[:, None] - xp) * g.area, -(g.y[None, :] - yp) * g.area])
        links = [self.cuts.xface, self.cuts.yface, self._edges[0], self._edges[1]]
        shift = [np.array([[1, 0]]), np.array([[0, 1]]), np.array([[1, 0]]), np.array([[0, 1]])]
        nodes = np.unique(np.concatenate([np.concatenate([f, f + d]) for f, d in zip(links, shift, strict=True)]),
                          axis=0)  # fmt: skip
        P = self.P
        for i, j in nodes:
            p = P[0, i, j]
            step = 1e-6 * p
            P[0, i, j] = p + step
            up = self._link_corrections()
            P[0, i, j] = p - step
            down = self._link_corrections()
            P[0, i, j] = p
            grad[:, i, j] += (up - down) / (2.0 * step)
        return self.p0 * grad

    def _link_corrections(self) -> np.ndarray:
        """What the cut links' and edge links' segment profiles change in the node quadrature's integrals of
        P - 1, -(x - xp)(P - 1) and -(y - yp)(P - 1) (3,) [m2, m3, m3]: :func:`solver.kernels.film.link_corrections`."""
        return np.array(kf.link_corrections(self.P, *self._links))

    def _link_arguments(self) -> tuple[tuple, tuple]:
        """Per axis, what :func:`solver.kernels.film.link_corrections` reads besides P: the cut links along the
        axis, the positions of their segments, the nodes along and across, the strip widths, spacings, bearing
        number, slip law, arms, scratch, then the edge links and the spacings at their mid-points and nodes."""
        g, c, (xp, yp) = self.grid, self.cuts, self.pivot
        law = (self.kn, self.h_ref, self.h_switch, self.code)
        x = (*c[0:6], g.cuts_x.seg_x[0], g.x, g.y, self._width_y, self.dx, self.lamx, *law, xp, yp, self._owner[0],
             self._coef[0], self._edges[0], self.Hx, self.Hxe)  # fmt: skip
        y = (*c[6:12], g.cuts_y.seg_y[0], g.y, g.x, self._width_x, self.dy, self.lamy, *law, yp, xp, self._owner[1],
             self._coef[1], self._edges[1], self.Hy, self.Hye)  # fmt: skip
        return x, y

    def _edge_links(self, axis: int, cut: np.ndarray) -> np.ndarray:
        """The links from the edge of the face along ``axis`` that are not cut links (m, 2): their lower nodes.

        Links i = 0 and nx - 2 (axis 0; j = 0 and ny - 2 for axis 1) between interior strips; ``cut`` (n, 2)
        the axis's cut links, which already carry their profiles.
        """
        nx, ny = self.shape
        if axis == 0:
            faces = [(i, j) for i in sorted({0, nx - 2}) for j in range(1, ny - 1)]
        else:
            faces = [(i, j) for j in sorted({0, ny - 2}) for i in range(1, nx - 1)]
        taken = {(int(a), int(b)) for a, b in cut}
        return np.array([f for f in faces if f not in taken], dtype=np.int64).reshape(-1, 2)

    # steady -------------------------------------------------------------------------------------------

    def residual(self) -> np.ndarray:
        """Steady flux residual at the current P and face spacings (1, nx, ny)."""
        kf.assemble(self.P, self.Hx, self.Hy, self.Hxe, self.Hye, *self._kernel_film)
        return self.scratch.R

    def solve_steady(self, q: np.ndarray, tol: float = 1e-10, max_iter: int = 60, chord: bool = True) -> int:
        """Steady film at attitude q (warm start from the current P); returns the Newton iterations.

        Newton's method with the exact Jacobian, a step shortened so that no
        node pressure falls below a fifth of its value.  With ``chord`` the
        last call's sparse LU is tried first (the attitude search and the
        continuation call this at nearby attitudes): its steps are kept while
        each cuts the residual to CHORD_CONTRACTION of the last; the first
        that does not is taken back, and Newton's method goes on from there.
        Converged when the scaled residual max |R| / (sum of |flux terms|) is
        below tol, with or without the chord steps.

        When Newton's steps are cut short by the positivity limit
        STALL_STEP_COUNT times in a row (from a cold start some node's
        pressure can be driven towards zero and creep there: a coarse grid of
        the micro-pad face with the continuum law does), the search starts
        again from the warm start with pseudo-transient continuation: the
        Jacobian's diagonal is raised by |J_ii| / tau, with tau growing as the
        residual falls (switched evolution relaxation), so the first steps
        are small relaxation steps and the last are Newton's.
        """
        self.fill_faces(q)
        self._history_h = 0.0  # the film is no longer where its history left it
        nx, ny = self.shape
        history: list[float] = []
        P = self.P[0, 1:-1, 1:-1]
        P_start = P.copy()
        lu = self._steady_lu if chord else None
        on_chord, P_before = lu is not None, None
        tau, short_steps, budget = None, 0, max_iter  # pseudo-time factor once Newton stalls
        it = 0
        while it < budget:
            it += 1
            R = self.residual()
            scale = np.max(np.abs(self.scratch.Jcx) + np.abs(self.scratch.Jcy)) + 1e-300
            err = np.max(np.abs(R)) / scale
            if tau is not None and history:
                tau = min(tau * max(history[-1] / err, 0.5), PTC_TAU_MAX)
                history.append(err)
            elif on_chord and history and err > CHORD_CONTRACTION * history[-1]:
                P[:] = P_before  # the old Jacobian no longer contracts: take its step back, Newton from here
                R = self.residual()
                err, on_chord = history[-1], False
            else:
                history.append(err)
            # Converged at tol, or at the round-off floor: below 1e-7 and no longer falling.
            stalled = len(history) > 3 and err < 1e-7 and err > 0.5 * history[-4]
            if err < tol or stalled:
                self.newton_iterations += it - 1
                return it - 1
            if not on_chord:
                J = self.sparse_jacobian()
                if tau is not None:  # pseudo-transient: the LU is not the steady Jacobian's, so it is not kept
                    J = (J + sp.diags(np.abs(J.diagonal()) / tau)).tocsc()
                lu = spla.splu(J, permc_spec=STEADY_ORDERING)
                self.factorizations += 1
                self._steady_lu = lu if chord and tau is None else None
            delta = lu.solve(-R[0, 1:-1, 1:-1].ravel()).reshape(nx - 2, ny - 2)
            self.reynolds_solves += 1
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(delta < 0, -0.8 * P / delta, np.inf)
            step = min(1.0, float(ratio.min()))
            short_steps = short_steps + 1 if step < STALL_STEP and tau is None else 0
            if short_steps >= STALL_STEP_COUNT:  # Newton creeps: start again, pseudo-transient
                P[:] = P_start
                self.pseudo_transient_restarts += 1
                tau, short_steps, on_chord, history = 1.0, 0, False, []
                budget = it + PTC_MAX_ITER
                continue
            P_before = P.copy()
            P += step * delta
            if not np.all(np.isfinite(P)):
                self._steady_lu = None
                raise SteadyFilmError(f"steady film diverged at q = {q} (non-finite pressure)")
        self._steady_lu = None
        how = "Newton iterations" if tau is None else "iterations, the last pseudo-transient"
        raise SteadyFilmError(f"steady film did not converge in {it} {how} at q = {q} (scaled residual {err:.2e})")

    def keep_steady_lu(self, lu) -> None:
        """Hand :meth:`solve_steady` an LU of the steady Jacobian (``scipy.sparse.linalg.splu``) to start from."""
        self._steady_lu = lu

    def sparse_jacobian(self) -> sp.csc_matrix:
        """dR/dP at the interior nodes of the last :meth:`residual` (sparse, (nx - 2)(ny - 2) square)."""
        nx, ny = self.shape
        b = self.scratch
        Jcx, Jxm, Jxp, Jcy, Jym, Jyp = (a[0, 1:-1, 1:-1] for a in (b.Jcx, b.Jxm, b.Jxp, b.Jcy, b.Jym, b.Jyp))
        rows, cols, order = self._pattern
        m = (nx - 2) * (ny - 2)
        data = np.concatenate([(Jcx + Jcy).ravel(), Jxm.ravel(), Jxp.ravel(), Jym.ravel(), Jyp.ravel()])
        J = sp.csc_matrix((data[order], (rows, cols)), shape=(m, m))
        return J

    # time step ----------------------------------------------------------------------------------------

    def step(
        self, q_old: np.ndarray, q_new: np.ndarray, disk_old: np.ndarray, disk_new: np.ndarray, dt: float,
        inner: tuple[np.ndarray, ...] = (), keep: bool = True,
    ) -> bool:  # fmt: skip
        """Advance P over dt while the attitude moves q_old -> q_new and the disk disk_old -> disk_new (nx, ny) [m];
        True if every node pressure after it is positive.

        ``inner``: the disk at m - 1 equally spaced times inside the step (``numerics.film_dt``); the film then
        takes m equal steps of dt / m, the attitude moving linearly from q_old to q_new, each one this step.

        With ``numerics.film_scheme`` "bdf2" each film step is a BDF2 step over the committed history
        (:meth:`commit_step`), or backward Euler where there is none or the step is more than BDF2_MAX_RATIO
        times the last; the history this step would leave is kept aside until :meth:`commit_step`.  With
        "trapezoid" and ``numerics.film_start_flux`` "carried" the committed history is the start's flux
        residual, where there is one (else it is evaluated); the end residual carried to the new pressure is
        kept aside the same way.  ``keep`` False (a probe of the step, which is not taken) keeps aside nothing.

        One kernel call (:func:`solver.kernels.film.film_advance`): the links' spacings at mid-step, the step,
        then the force's link profiles (cut and edge links) at the end of the step, with its pressure: left at
        mid-step they lag the attitude by dt / 2, a first-order error that took 17 % of the 728-kHz mode's
        damping at dt 0.05 us (README, "The film force's time error").  The other links keep their mid-step
        spacings (what the next step or :meth:`fill_faces` overwrites).  BDF2 and the trapezoid have a kernel of
        their own (``film_advance_at_ends``), which leaves every link at the step's end.
        """
        state = (self.P, self.H, self.H_new, self.Hx, self.Hy, self.Hxe, self.Hye, self.disk, self.disk_xf,
                 self.disk_yf, self._disk_mid)  # fmt: skip
        disks = [np.ascontiguousarray(d, dtype=float)[None] for d in (disk_old, *inner, disk_new)]
        m = len(disks) - 1
        ok = True
        history, h_last, h = self._history, self._history_h, dt / m
        self.last_ratio = h / h_last if self.bdf2 and 0.0 < h <= BDF2_MAX_RATIO * h_last else 0.0
        # carried in where the film is where its history left it (a P set from outside, as a test may, is not)
        carried = self.carried and h_last > 0.0 and np.array_equal(self.P, self._P_history)
        for k in range(m):
            qa = q_old if k == 0 else q_old + (k / m) * (q_new - q_old)
            qb = q_new if k == m - 1 else q_old + ((k + 1) / m) * (q_new - q_old)
            ratio = h / h_last if self.bdf2 and 0.0 < h <= BDF2_MAX_RATIO * h_last else 0.0
            start = self.P.copy() if self.bdf2 else None
            if self.bdf2:
                aux = history
            else:  # the start's flux: carried in (the committed one, or the last film step's), or evaluated
                aux = history if carried else self._flux_start
            carry = self._carries[0 if keep else 1]  # (the kernel reads aux before it writes carry)
            if self.scheme == kf.SCHEME_MIDPOINT:
                ok = kf.film_advance(qa, qb, disks[k], disks[k + 1], m * self.sigma / dt, self._advance_geometry,
                                     state, *self._kernel_film)  # fmt: skip
            else:
                ok = kf.film_advance_at_ends(qa, qb, disks[k], disks[k + 1], m * self.sigma / dt,
                                             self._advance_geometry, state, *self._kernel_film, aux, ratio,
                                             self.scheme, carried, carry)  # fmt: skip
            self.reynolds_solves += 1
            if not ok:
                break
            if self.bdf2:  # the next film step's history: this one's start (H holds its starting spacing)
                np.multiply(start, self.H, out=self._pending)
                history, h_last = self._pending, h
            elif self.carried:  # the next film step's start flux: this one's end residual, carried
                history, h_last, carried = carry, h, True
        if keep:
            self._pending_h = h_last
            if self.carried and ok:
                self._pending = history
                self._P_left[...] = self.P
        return ok

    def commit_step(self) -> None:
        """Accept the last kept :meth:`step` as the film's history: BDF2's m_n-1 and step size, the trapezoid's
        carried start flux (carried on to the pressure the slider's correction has left since); nothing for the
        midpoint."""
        if self.bdf2:
            self._history, self._pending = self._pending, self._history
            self._history_h = self._pending_h
        elif self.carried:
            np.subtract(self.P, self._P_left, out=self._P_left)
            kf.linearized_residual(self._pending, self._kernel_film[1], self._P_left, self._history)
            self._history_h = self._pending_h
            self._P_history[...] = self.P

    def history(self) -> tuple[np.ndarray, float, np.ndarray]:
        """A copy of the committed history, for :meth:`set_history` (a step taken back): BDF2's m_n-1 or the
        trapezoid's start flux, the last step's size (0: none) and the pressure the trapezoid's flux belongs to."""
        return self._history.copy(), self._history_h, self._P_history.copy()

    def set_history(self, saved: tuple) -> None:
        """Restore :meth:`history`'s copy; (array, 0.0) clears the history."""
        self._history[...] = saved[0]
        self._history_h = saved[1]
        if len(saved) > 2:
            self._P_history[...] = saved[2]

    @property
    def bearing_number(self) -> float:
        """Lambda = 6 eta V L / (p0 h_ref^2) with the full disk speed."""
        return math.hypot(self.lamx, self.lamy)


def _jacobian_pattern(nx: int, ny: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row/column indices of the interior 5-point Jacobian in the order of :meth:`AbsFilm.sparse_jacobian`.

    Couplings to Dirichlet nodes are dropped (their P is fixed).  Returns
    rows, cols and the index of each kept entry into the concatenated data.
    """
    mx, my = nx - 2, ny - 2
    idx = np.arange(mx * my).reshape(mx, my)
    I, Jj = np.meshgrid(np.arange(mx), np.arange(my), indexing="ij")
    parts = [
        (idx, idx, np.ones((mx, my), bool)),
        (idx, np.roll(idx, 1, axis=0), I > 0),  # x-minus
        (idx, np.roll(idx, -1, axis=0), I < mx - 1),  # x-plus
        (idx, np.roll(idx, 1, axis=1), Jj > 0),  # y-minus
        (idx, np.roll(idx, -1, axis=1), Jj < my - 1),  # y-plus
    ]
    rows, cols, order = [], [], []
    for k, (r, c, keep) in enumerate(parts):
        rows.append(r[keep])
        cols.append(c[keep])
        order.append(k * mx * my + idx[keep])
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(order)
