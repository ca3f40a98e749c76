"""Clustered 1-D grids and node-centred control volumes.

Along a rail the grid has two segments: the taper [-(c + c0), -c] with
nodes clustered towards the taper/flat juncture, and the flat [-c, d] with
nodes clustered towards both the juncture and the trailing edge.  Across a
rail the nodes may be clustered towards both rail edges.  Clustering uses a
tanh map of a uniform parameter s in [0, 1]; strength 0 is uniform.

Control volumes are node-centred: the faces sit half-way between nodes, a
node's volume width is ``(x[i+1] - x[i-1]) / 2`` (half of that at an end).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def cluster_both_ends(n: int, strength: float) -> np.ndarray:
    """n points in [0, 1] clustered symmetrically towards both ends."""
    s = np.linspace(0.0, 1.0, n)
    if strength <= 0.0:
        return s
    return 0.5 * (1.0 + np.tanh(strength * (2.0 * s - 1.0)) / np.tanh(strength))


def cluster_right_end(n: int, strength: float) -> np.ndarray:
    """n points in [0, 1] clustered towards 1: x = tanh(k s) / tanh(k), whose slope is smallest at s = 1."""
    s = np.linspace(0.0, 1.0, n)
    if strength <= 0.0:
        return s
    return np.tanh(strength * s) / np.tanh(strength)


def control_volume_widths(x: np.ndarray) -> np.ndarray:
    """Width of each node's control volume: half-way to each neighbour."""
    widths = np.empty_like(x)
    widths[1:-1] = 0.5 * (x[2:] - x[:-2])
    widths[0] = 0.5 * (x[1] - x[0])
    widths[-1] = 0.5 * (x[-1] - x[-2])
    return widths


@dataclass(frozen=True)
class RailGrid:
    """Node coordinates of one rail (both rails share it) [m].

    x : ndarray (nx,)  along the slider, leading edge first
    y : ndarray (ny,)  across the rail, relative to the rail centre line
    """

    x: np.ndarray
    y: np.ndarray
    juncture_index: int

    @property
    def shape(self) -> tuple[int, int]:
        return (self.x.size, self.y.size)


def rail_grid(
    taper_length: float,
    flat_front: float,
    flat_rear: float,
    rail_width: float,
    nx: int,
    nx_taper: int,
    ny: int,
    cluster_x: float,
    cluster_y: float,
) -> RailGrid:
    """Grid of one taper-flat rail, juncture at x = -flat_front exactly on a node."""
    x_le = -(flat_front + taper_length)
    taper = x_le + taper_length * cluster_right_end(nx_taper, cluster_x)
    n_flat = nx - nx_taper + 1
    flat = -flat_front + (flat_front + flat_rear) * cluster_both_ends(n_flat, cluster_x)
    x = np.concatenate([taper[:-1], flat])
    x[nx_taper - 1] = -flat_front
    y = rail_width * (cluster_both_ends(ny, cluster_y) - 0.5)
    return RailGrid(x=x, y=y, juncture_index=nx_taper - 1)
