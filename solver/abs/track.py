"""The moving disk under the face: the track profile sampled on the grid at time t."""

from __future__ import annotations

import logging
import math

import numpy as np

from solver.abs.face import AbsGrid
from solver.abs.params import AbsScene
from solver.kernels.disk import fill_disk_heights

log = logging.getLogger(__name__)


class Track:
    """The disk under the slider: resolved heights z_d and unresolved RMS at the nodes at time t."""

    def __init__(self, scene: AbsScene, grid: AbsGrid, profile=None) -> None:
        from solver.disk import disk_tables, synthetic_profile
        from solver.grid import control_volume_widths

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
                    f"disk.profile_file = {disk.profile_file!r}: read it with pipeline.data.profiles.read_profile and "
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
        self.table_of_node = np.ascontiguousarray(self.tables.table_of_column)  # per node: width is (nx, ny)

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(z_d, sigma) at the nodes at time t: (nx, ny) each [m]; a smooth disk gives zeros.

        The tables are sampled as :func:`solver.disk.disk_surface` does, without its per-call checks.
        """
        if self.smooth:
            return self.zero, self.zero
        tables = self.tables
        zd, sd = np.empty(self.zero.shape), np.empty(self.zero.shape)  # new arrays: the caller keeps them
        fill_disk_heights(
            tables.mean, tables.residual_rms, self.table_of_node, tables.spacing, self.s_nodes, self.speed * t, zd, sd
        )  # fmt: skip
        return zd, sd
