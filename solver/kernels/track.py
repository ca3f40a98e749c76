"""The moving track under the grid: window-filtered disk heights and unresolved RMS at every node."""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit


@njit
def fill_class_heights(
    means: np.ndarray,
    rmss: np.ndarray,
    width_class: np.ndarray,
    spacing: float,
    s_nodes: np.ndarray,
    shift: float,
    zd: np.ndarray,
    sd: np.ndarray,
) -> None:
    """z_d and sigma at every node by periodic linear interpolation at s - shift.

    means, rmss : (k, n) the profile's window mean and residual RMS for k
    window widths, sampled every ``spacing`` [m] on a periodic track;
    width_class : (nx, ny) int, the window of each node; s_nodes : (nx, ny)
    along-track coordinates [m]; shift = V t [m].  zd, sd : (nx, ny) out.
    """
    n = means.shape[1]
    inv = 1.0 / spacing
    nx, ny = s_nodes.shape
    for i in range(nx):
        for j in range(ny):
            u = (s_nodes[i, j] - shift) * inv
            f = math.floor(u)
            w = u - f
            k0 = int(f) % n
            if k0 < 0:
                k0 += n
            k1 = k0 + 1
            if k1 == n:
                k1 = 0
            c = width_class[i, j]
            zd[i, j] = (1.0 - w) * means[c, k0] + w * means[c, k1]
            sd[i, j] = (1.0 - w) * rmss[c, k0] + w * rmss[c, k1]
