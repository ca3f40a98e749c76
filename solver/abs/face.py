"""Air-bearing surface (ABS) of scene kind "abs": regions at etch depths, crown, camber, twist, grid.

The face is painted in order: every point starts at ``abs.base_depth``
(the deep cavity) and each region, rectangle or polygon, sets the depth of
the points inside it; later regions win.  Depth is measured from the pad
top (depth 0) away from the disk.  The static surface adds the crown,
camber and twist, relative to the face's centre:

    s(x, y) = depth(x, y) + crown xi^2 + camber eta^2 + twist xi eta,
    xi = 2 (x - L/2) / L,  eta = 2 y / W,

so a positive crown puts the middle of the face ``crown`` closer to the
disk than its leading and trailing edges.

Steps on a grid
---------------
A step between regions almost never falls on a grid line.  By default
(``subcells = 1``) node and face depths are sampled at the node and face
centres, so a step acts at the nearest face: its position is off by at most
half a cell and the load converges at first order (a Rayleigh step: load
error 0.89, 0.33, 0.18, 0.03 cells at nx = 41, 81, 161, 241; tests/test_abs.py).
``subcells`` > 1 averages the depth over ``subcells``^2 sub-samples of the
control volume and dual cell; we tried it first, and it is wrong for the
fluxes: a face straddling a step gets an intermediate spacing, while the flux
goes with h^3, and the error stayed at 2.4-7 cells under refinement.

Grid
----
A tensor grid over [0, L] x [-W/2, W/2] whose spacing is ``refine`` times
finer over a window around ``abs.refine_region`` (the trailing pad, which
carries the flying-height point and all the contact), with tanh
transitions between the two spacings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.abs.params import AbsScene, Region
from solver.grid import control_volume_widths
from solver.params import ParameterError


def region_geometry(region: Region, scene: AbsScene) -> np.ndarray:
    """Vertices (k, 2) of a region [m], rectangles resolved (``width_from``) to 4 corners."""
    if region.polygon is not None:
        return np.asarray(region.polygon, dtype=float)
    x0, x1, y0, y1 = region.rect
    if region.width_from:
        centre = 0.5 * (y0 + y1)
        half = 0.5 * getattr(scene.slider, region.width_from)
        y0, y1 = centre - half, centre + half
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def inside_polygon(x: np.ndarray, y: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Even-odd rule: which points (x, y) lie inside the polygon (boundary points count half-open)."""
    inside = np.zeros(np.broadcast(x, y).shape, dtype=bool)
    n = len(vertices)
    for k in range(n):
        xa, ya = vertices[k]
        xb, yb = vertices[(k + 1) % n]
        crosses = (ya > y) != (yb > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = xa + (y - ya) * (xb - xa) / (yb - ya)
        inside ^= crosses & (x < x_cross)
    return inside


def depth(x: np.ndarray, y: np.ndarray, scene: AbsScene) -> np.ndarray:
    """Etch depth [m] at points (x from the leading edge, y from the centre line)."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    out = np.full(x.shape, scene.abs.base_depth)
    for region in scene.abs.regions:
        out[inside_polygon(x, y, region_geometry(region, scene))] = region.depth
    return out


def shape(x: np.ndarray, y: np.ndarray, scene: AbsScene) -> np.ndarray:
    """Crown, camber and twist contribution to the spacing [m] (zero at the face centre)."""
    s = scene.slider
    xi = 2.0 * (np.asarray(x) - 0.5 * s.length) / s.length
    eta = 2.0 * np.asarray(y) / s.width
    return s.crown * xi**2 + s.camber * eta**2 + s.twist * xi * eta


def _averaged_depth(x0: np.ndarray, x1: np.ndarray, y0: np.ndarray, y1: np.ndarray, scene: AbsScene, n: int):
    """Mean depth over the boxes [x0_i, x1_i] x [y0_j, y1_j] from n x n midpoint sub-samples: (len x0, len y0)."""
    u = (np.arange(n) + 0.5) / n
    xs = x0[:, None] + (x1 - x0)[:, None] * u[None, :]  # (nx, n)
    ys = y0[:, None] + (y1 - y0)[:, None] * u[None, :]  # (ny, n)
    X = np.broadcast_to(xs[:, None, :, None], (len(x0), len(y0), n, n))
    Y = np.broadcast_to(ys[None, :, None, :], (len(x0), len(y0), n, n))
    return depth(X, Y, scene).mean(axis=(2, 3))


def _window_bounds(scene: AbsScene) -> tuple[tuple[float, float], tuple[float, float]] | None:
    if not scene.abs.refine_region:
        return None
    region = next(r for r in scene.abs.regions if r.name == scene.abs.refine_region)
    v = region_geometry(region, scene)
    return (v[:, 0].min(), v[:, 0].max()), (v[:, 1].min(), v[:, 1].max())


def refined_axis(lo: float, hi: float, n: int, window: tuple[float, float] | None, refine: float) -> np.ndarray:
    """n nodes on [lo, hi], ``refine`` times denser over ``window`` (smooth tanh transitions)."""
    if window is None or refine == 1.0:
        return np.linspace(lo, hi, n)
    a, b = max(window[0], lo), min(window[1], hi)
    fine = np.linspace(lo, hi, 20001)
    width = 0.02 * (hi - lo)
    weight = 0.5 * (np.tanh((fine - a) / width * 2.0 + 1.0) - np.tanh((fine - b) / width * 2.0 - 1.0))
    density = 1.0 + (refine - 1.0) * weight
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(fine))])
    nodes = np.interp(np.linspace(0.0, cdf[-1], n), cdf, fine)
    nodes[0], nodes[-1] = lo, hi
    return nodes


@dataclass(frozen=True)
class AbsGrid:
    """Tensor grid of the face and the static surface on nodes and faces.

    x : (nx,), y : (ny,) [m]; surface (nx, ny), surface_xf (nx-1, ny),
    surface_yf (nx, ny-1) [m]: depth + crown/camber/twist, to be added to
    the attitude's plane.  area (nx, ny) control volumes [m2].
    """

    x: np.ndarray
    y: np.ndarray
    surface: np.ndarray
    surface_xf: np.ndarray
    surface_yf: np.ndarray
    depth: np.ndarray
    area: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return (self.x.size, self.y.size)

    @property
    def xf(self) -> np.ndarray:
        return 0.5 * (self.x[1:] + self.x[:-1])

    @property
    def yf(self) -> np.ndarray:
        return 0.5 * (self.y[1:] + self.y[:-1])


def abs_grid(scene: AbsScene) -> AbsGrid:
    """Grid and rasterised surface of a scene; a grid too coarse for a pad is an error naming it."""
    s, num = scene.slider, scene.numerics
    window = _window_bounds(scene)
    margin_x = 0.5 * (window[0][1] - window[0][0]) if window else 0.0
    margin_y = 0.25 * (window[1][1] - window[1][0]) if window else 0.0
    wx = (window[0][0] - margin_x, window[0][1] + margin_x) if window else None
    wy = (window[1][0] - margin_y, window[1][1] + margin_y) if window else None
    x = refined_axis(0.0, s.length, num.nx, wx, num.refine)
    y = refined_axis(-0.5 * s.width, 0.5 * s.width, num.ny, wy, num.refine)
    _check_resolution(scene, x, y)
    dxc, dyc = control_volume_widths(x), control_volume_widths(y)
    xf, yf = 0.5 * (x[1:] + x[:-1]), 0.5 * (y[1:] + y[:-1])
    xl = np.concatenate([[x[0]], xf])  # control-volume bounds
    xr = np.concatenate([xf, [x[-1]]])
    yl = np.concatenate([[y[0]], yf])
    yr = np.concatenate([yf, [y[-1]]])
    n = num.subcells
    node_depth = _averaged_depth(xl, xr, yl, yr, scene, n)
    xf_depth = _averaged_depth(x[:-1], x[1:], yl, yr, scene, n)
    yf_depth = _averaged_depth(xl, xr, y[:-1], y[1:], scene, n)
    return AbsGrid(
        x=x,
        y=y,
        surface=node_depth + shape(x[:, None], y[None, :], scene),
        surface_xf=xf_depth + shape(xf[:, None], y[None, :], scene),
        surface_yf=yf_depth + shape(x[:, None], yf[None, :], scene),
        depth=node_depth,
        area=dxc[:, None] * dyc[None, :],
    )


def _check_resolution(scene: AbsScene, x: np.ndarray, y: np.ndarray) -> None:
    """Every region must span at least ``refine_nodes`` grid intervals along both axes it occupies."""
    need = scene.numerics.refine_nodes
    for k, region in enumerate(scene.abs.regions):
        v = region_geometry(region, scene)
        for axis, nodes, key in ((0, x, "nx"), (1, y, "ny")):
            lo, hi = v[:, axis].min(), v[:, axis].max()
            inside = np.count_nonzero((nodes >= lo) & (nodes <= hi))
            if inside < min(need, nodes.size):
                raise ParameterError(
                    f"numerics.{key} = {nodes.size} is too coarse for abs.regions[{k}] ({region.name!r}, "
                    f"{(hi - lo) * 1e6:.1f} um along {'xy'[axis]}): {inside} nodes fall on it, at least "
                    f"numerics.refine_nodes = {need} are needed; raise numerics.{key} or numerics.refine"
                )
