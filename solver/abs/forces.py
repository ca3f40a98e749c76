"""Surface forces on every cell of the face: asperity or elastic contact, adhesion, friction."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from solver.abs.face import AbsGrid
from solver.abs.params import AbsScene
from solver.kernels import surface as ksurf
from solver.surface import ADHESION_LAWS, summit_coefficient

log = logging.getLogger(__name__)

#: Summits beyond this many RMS heights above the mean carry no load: cells farther than the force reach plus
#: this many sigma are skipped.
REACH_SIGMAS = 6.0
#: Relative tolerance of the elastic contact solve.
ELASTIC_TOLERANCE = 1e-12


@dataclass
class SurfaceForces:
    """Surface forces of one evaluation: generalized force (3,), its Jacobian (3, 3), and totals [N].

    With contact damping (:meth:`SurfaceModel.forces_on` given the velocities) ``f``, ``contact`` and
    ``friction`` include the damping's force and ``damping`` is its matrix -d f / d v (3, 3); ``dfdq`` is the
    undamped forces' Jacobian.
    """

    f: np.ndarray
    dfdq: np.ndarray
    contact: float
    adhesion: float
    friction: float
    cells: int
    damping: np.ndarray | None = None


@dataclass
class Candidates:
    """Cells near the disk for one step: grid index, offset (surface - disk) [m], sigma [m], b (3, k), area [m2]."""

    index: np.ndarray
    base: np.ndarray
    sigma: np.ndarray
    b: np.ndarray
    area: np.ndarray


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
        self.adhesion_law = ADHESION_LAWS[scene.models.adhesion]
        self.summit_coef = summit_coefficient(c.summit_density, c.summit_radius)
        self.mu = c.mu
        psi = math.radians(scene.disk.skew)
        t = scene.slider.thickness
        self.friction_arm = np.array([0.0, -t * math.cos(psi), -t * math.sin(psi)])
        self.reach = self.eps + c.candidate_gap
        s = scene.slider
        X, Y = grid.contact_x - s.pivot_x, grid.contact_y - s.pivot_y  # each control volume's contact patch
        self.b = np.stack([np.ones(X.size), -X.ravel(), -Y.ravel()])  # (3, n) d(spacing)/dq per patch
        self.area = grid.contact_area.ravel()
        self.surface = grid.surface.ravel()  # the face's static surface at the patches [m]
        self.b_max = np.abs(self.b).max(axis=1)  # largest |d spacing / dq| over the face
        self.near = np.empty(self.area.size, dtype=np.int64)  # work array of :meth:`candidates`
        self.xc, self.yc = grid.x, grid.y
        self.grid = grid
        #: The Greenwood-Williamson law's and the adhesion law's constants as the kernels take them
        #: (:func:`solver.kernels.surface.generalized_forces`).
        self.kernel_law = (self.eps, self.gw_coef, self.adh_coef, self.adhesion_law, self.summit_coef, self.mu,
                           self.friction_arm, self.reach, REACH_SIGMAS)  # fmt: skip

    def forces(self, d: np.ndarray, sigma: np.ndarray) -> SurfaceForces:
        """Surface forces for node spacings d (nx, ny) [m] and unresolved RMS sigma (nx, ny) [m]."""
        if self.law == "none":
            return SurfaceForces(np.zeros(3), np.zeros((3, 3)), 0.0, 0.0, 0.0, 0)
        d_flat, s_flat = d.ravel(), sigma.ravel()
        near = np.flatnonzero(d_flat < self.reach + REACH_SIGMAS * s_flat)
        return self._on(near, d_flat[near], s_flat[near])

    def touchdown_adhesion(self, d: np.ndarray, sigma: np.ndarray) -> tuple[float, float]:
        """The fold estimate: adhesion force [N] (<= 0) of the whole face lowered to touch, and the lowering [m].

        The face is moved towards the disk along z only (pitch and roll kept)
        until its lowest contact patch sits at d = eps from the disk's mean
        plane, and the scene's adhesion law is summed over every patch (no
        reach: the whole face), with roughness ``sigma`` (nx, ny) [m].  Against
        the preload it says, before any run, whether adhesion can out-pull the
        suspension: near one preload or above expect no flying equilibrium
        (:func:`solver.abs.steady.fly_abs` then reports the fold).  It is an
        estimate, not the fold: on chen_bogy2007 (121 x 101) the branch folds
        where it reads 0.77 preloads with the flat law and 1.42 with
        asperity_dmt (the film's stiffness, not the preload, holds the pad).
        """
        if self.law == "none":
            return 0.0, 0.0
        d_flat = d.ravel()
        lowering = float(d_flat.min()) - self.eps
        out = np.empty((4, d_flat.size))
        ksurf.surface_pressures(
            np.ascontiguousarray(d_flat - lowering), np.ascontiguousarray(sigma.ravel()), self.eps, self.gw_coef,
            self.adh_coef, self.adhesion_law, self.summit_coef, out,
        )  # fmt: skip
        return float(out[2] @ self.area), lowering

    def candidates(self, disk: np.ndarray, sigma: np.ndarray, q: np.ndarray, margin: float) -> Candidates:
        """The cells within reach (plus ``margin``) at attitude q over the disk heights ``disk`` (nx, ny) [m].

        A time step's Newton iterations then evaluate only these cells
        (:meth:`forces_on`), instead of the whole face.
        """
        cells = ksurf.candidate_cells(
            self.surface, disk.ravel(), sigma.ravel(), self.b, self.area, q, self.reach, REACH_SIGMAS, margin, self.near
        )  # fmt: skip
        return Candidates(*cells)

    def forces_on(self, cells: Candidates, q: np.ndarray, damping: tuple | None = None) -> SurfaceForces:
        """Surface forces at attitude q from the candidate cells only.

        ``damping`` = (zeta, M^-1, v, disk rate at the cells) adds the contact damping: the Greenwood-Williamson
        law's (:func:`solver.kernels.surface.contact_damping`, with its attitude derivative, as the Newton kernel
        has it) or the elastic law's (:meth:`_elastic_damping`).
        """
        if self.law == "none":
            return SurfaceForces(np.zeros(3), np.zeros((3, 3)), 0.0, 0.0, 0.0, 0)
        return self._on(cells.index, cells.base + q @ cells.b, cells.sigma, cells.b, damping)

    def _on(
        self,
        near: np.ndarray,
        dn: np.ndarray,
        sn: np.ndarray,
        b: np.ndarray | None = None,
        damping: tuple | None = None,
    ) -> SurfaceForces:
        if near.size == 0:
            return SurfaceForces(np.zeros(3), np.zeros((3, 3)), 0.0, 0.0, 0.0, 0, np.zeros((3, 3)))
        dn, sn = np.ascontiguousarray(dn), np.ascontiguousarray(sn)
        out = np.empty((4, near.size))
        ksurf.surface_pressures(dn, sn, self.eps, self.gw_coef, self.adh_coef, self.adhesion_law, self.summit_coef, out)
        pc, dpc, pa, dpa = out
        if self.law == "elastic":
            pc, dpc_matrix = self._elastic_pressure(near, dn, sn, pc)
        area = self.area[near]
        b = self.b[:, near] if b is None else b
        if self.law == "elastic":
            dfdq = (b * (dpa * area)) @ b.T
            dfdq += (b * area) @ dpc_matrix @ b.T + self.mu * np.outer(self.friction_arm, area @ dpc_matrix @ b.T)
        else:
            w = dpc * area
            dfdq = (b * (w + dpa * area)) @ b.T + self.mu * np.outer(self.friction_arm, b @ w)
        c_d, damped = None, 0.0
        if damping is not None and self.law == "elastic":
            pd, c_d = self._elastic_damping(pc, dpc_matrix, area, b, damping)
            pc = pc + pd
        fc = pc * area
        fa = pa * area
        f = b @ (fc + fa) + self.mu * fc.sum() * self.friction_arm
        if damping is not None and self.law == "greenwood_williamson":
            zeta, m_inv, v, disk_rate = damping
            c_d = np.empty((3, 3))
            damped = ksurf.contact_damping(
                dn, sn, np.ascontiguousarray(b), area, np.zeros(3), v, disk_rate, self.eps, self.gw_coef, m_inv,
                zeta, self.mu, self.friction_arm, f, dfdq, c_d,
            )  # fmt: skip
        contact = float(fc.sum()) + damped
        in_reach = int(np.count_nonzero(dn < self.reach + REACH_SIGMAS * sn))
        return SurfaceForces(f, dfdq, contact, float(fa.sum()), self.mu * contact, in_reach, c_d)

    def _elastic_damping(
        self, pc: np.ndarray, dpc: np.ndarray, area: np.ndarray, b: np.ndarray, damping: tuple
    ) -> tuple[np.ndarray, np.ndarray]:
        """The elastic law's contact damping: pressures p_d on the cells and the matrix -d f_d / d v (3, 3).

        The Greenwood-Williamson law's damping (:func:`solver.kernels.surface.contact_damping`) with the cells'
        coupled stiffness: the cells' forces have the stiffness k_ij = -A_i dp_i/dd_j, the face's contact
        stiffness is K_c = B k B^T, and the damping is stiffness-proportional,

            p_d = (2 zeta / omega_c) (dp/dd) r,   omega_c^2 = trace(M^-1 K_c),

        with r_j = b_j . v - (disk rate)_j the cells' spacing rates, so that a contact on one patch has the
        damping ratio zeta exactly and a contact spread over the face damps its contact mode j with
        zeta omega_j / omega_c (on a diagonal k this is the Greenwood-Williamson law's definition).  A contact
        cannot pull: where p_c + p_d < 0, p_d = -p_c (the cell's contact pressure is zero).  The force is
        f_d = sum_i A_i p_d,i l_i (l_i = b_i + mu arm: friction acts on the damped normal force too) and
        -d f_d / d v = -(2 zeta / omega_c) sum_{i free} A_i l_i (dp/dd)_i,: B^T.
        """
        zeta, m_inv, v, disk_rate = damping
        k_face = -(b * area) @ dpc @ b.T  # K_c = B k B^T
        omega2 = float(np.trace(m_inv @ k_face))
        if zeta == 0.0 or omega2 <= ksurf.CONTACT_OMEGA2_FLOOR:
            return np.zeros(pc.size), np.zeros((3, 3))
        scale = 2.0 * zeta / math.sqrt(omega2)
        rate = v @ b - disk_rate
        pd = scale * (dpc @ rate)
        free = pc + pd >= 0.0
        pd = np.where(free, pd, -pc)
        lever = b + self.mu * self.friction_arm[:, None]
        c_d = -scale * (lever[:, free] * area[free]) @ dpc[free] @ b.T
        return pd, c_d

    def _elastic_pressure(
        self, near: np.ndarray, d: np.ndarray, sigma: np.ndarray, rigid: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Elastic half-space contact on the cells near the disk: contact pressures and their Jacobian d p / d d.

        On a rough disk (every cell's unresolved sigma > 0) the cells' asperities sit on the half-spaces
        (:func:`solver.elastic.solve_rough_contact`), on the cells closer than eps + REACH_SIGMAS sigma, whose rigid
        asperity pressure ``rigid`` is not 0 (the deflection only lowers a pressure; beyond 6 sigma a cell carries
        less than 1e-9 of a touching cell's pressure and is left out).
        On a smooth disk it is the complementarity problem on the cells whose rigid gap d - eps is negative.
        """
        from solver.elastic import influence_matrix, solve_contact, solve_rough_contact
        from solver.grid import control_volume_widths

        pc = np.zeros(d.size)
        dp = np.zeros((d.size, d.size))
        rough = bool(np.all(sigma > 0.0))
        if rough:
            cells = np.flatnonzero((d - self.eps < REACH_SIGMAS * sigma) & (rigid > 0.0))
        else:
            cells = np.flatnonzero(d - self.eps < 0.0)
        if cells.size == 0:
            return pc, dp
        i, j = np.divmod(near[cells], self.grid.y.size)
        wx, wy = control_volume_widths(self.grid.x), control_volume_widths(self.grid.y)
        C = influence_matrix(self.grid.x[i], self.grid.y[j], 0.5 * wx[i], 0.5 * wy[j], self.e_composite)
        if rough:
            p, dpdd, _ = solve_rough_contact(d[cells], sigma[cells], C, self.eps, self.gw_coef)
            pc[cells] = p
            dp[np.ix_(cells, cells)] = dpdd
            return pc, dp
        p, active = solve_contact(d[cells] - self.eps, C, ELASTIC_TOLERANCE)
        pc[cells] = p
        act = cells[np.asarray(active, dtype=bool)]
        if act.size:
            sub = np.flatnonzero(np.asarray(active, dtype=bool))
            dp[np.ix_(act, act)] = -np.linalg.inv(C[np.ix_(sub, sub)])
        return pc, dp
