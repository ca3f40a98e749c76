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
A step between regions almost never falls on a grid line.  Sampling the
depth at node and face centres (``numerics.faces = "sampled"``, the scheme
before this one) moves every step by up to half a cell, differently on every
grid: the load of the Rayleigh step converged erratically, and the flying
height of chen_bogy2007 scattered by +-0.2 nm from grid to grid.  Averaging
the depth over a face (tried first) was worse: the flux goes with h^3.

The default, ``"fitted"``, places the nodes so that every region edge along
a grid line is a control-volume face (:func:`refined_axis`): no control
volume holds two depths there, and the link across the edge joins its two
halves in series.  What no tensor grid can fit (slanted polygon sides, edges
closer than a cell) is measured exactly as cut links and cut volumes
(:mod:`solver.abs.cuts`); ``"cut"`` does that for every edge on the plain
grid.  A cut volume that holds part of the other region is a sliver the
node-centred scheme cannot represent (the sliver's flow is tied to the
node's pressure): on the plain grid the load still scattered by 3-8 %, on
the fitted one it converges monotonically (README, the grid ladder).

Grid
----
A tensor grid over [0, L] x [-W/2, W/2] whose spacing is ``refine`` times
finer over a window around ``abs.refine_region`` (the trailing pad, which
carries the flying-height point and all the contact), with tanh
transitions between the two spacings.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from solver.abs.cuts import CutLinks, no_cuts, rasterise
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


def region_loads(scene: AbsScene, x: np.ndarray, y: np.ndarray, pressure: np.ndarray) -> tuple[list[str], np.ndarray]:
    """What each region of the face carries: gauge load [N] and pitch and roll moments about the pivot [N m].

    The node quadrature of the gauge pressure on the grid (x, y) [m], every
    control volume given to the region that paints its node (later regions
    win; "cavity (base)" is the rest).  Signs as the film's forces: a
    positive pitch moment lifts the leading edge, a positive roll moment the
    y < 0 side.  The rows sum to the node quadrature of the whole face; the
    film's force (:meth:`AbsFilm.forces`) adds the cut links' exact profiles
    to it, which no region is given.  Returns the names and an (n, 3) array.
    """
    X, Y = np.meshgrid(x, y, indexing="ij")
    owner = np.full(X.shape, -1)
    for k, region in enumerate(scene.abs.regions):
        owner[inside_polygon(X, Y, region_geometry(region, scene))] = k
    load = (pressure - scene.air.ambient_pressure) * control_volume_widths(x)[:, None] * control_volume_widths(y)
    arm_x, arm_y = X - scene.slider.pivot_x, Y - scene.slider.pivot_y
    names = ["cavity (base)"] + [region.name for region in scene.abs.regions]
    out = np.zeros((len(names), 3))
    for k in range(-1, len(scene.abs.regions)):
        on = owner == k
        out[k + 1] = load[on].sum(), -(load[on] * arm_x[on]).sum(), -(load[on] * arm_y[on]).sum()
    return names, out


def shape(x: np.ndarray, y: np.ndarray, scene: AbsScene) -> np.ndarray:
    """Crown, camber and twist contribution to the spacing [m] (zero at the face centre)."""
    s = scene.slider
    xi = 2.0 * (np.asarray(x) - 0.5 * s.length) / s.length
    eta = 2.0 * np.asarray(y) / s.width
    return s.crown * xi**2 + s.camber * eta**2 + s.twist * xi * eta


def _window_bounds(scene: AbsScene) -> tuple[tuple[float, float], tuple[float, float]] | None:
    if not scene.abs.refine_region:
        return None
    region = next(r for r in scene.abs.regions if r.name == scene.abs.refine_region)
    v = region_geometry(region, scene)
    return (v[:, 0].min(), v[:, 0].max()), (v[:, 1].min(), v[:, 1].max())


def _density(lo: float, hi: float, window: tuple[float, float] | None, refine: float):
    """Fine sample points on [lo, hi] and the node density there: ``refine`` times higher over ``window``."""
    fine = np.linspace(lo, hi, 200001)
    if window is None or refine == 1.0:
        return fine, np.ones(fine.size)
    a, b = max(window[0], lo), min(window[1], hi)
    width = 0.02 * (hi - lo)
    weight = 0.5 * (np.tanh((fine - a) / width * 2.0 + 1.0) - np.tanh((fine - b) / width * 2.0 - 1.0))
    return fine, 1.0 + (refine - 1.0) * weight


def refined_axis(
    lo: float, hi: float, n: int, window: tuple[float, float] | None, refine: float, edges: np.ndarray | None = None
) -> np.ndarray:
    """n nodes on [lo, hi], ``refine`` times denser over ``window`` (smooth tanh transitions).

    With ``edges``, every edge is made a control-volume face: its two neighbouring nodes sit half the
    local spacing s either side of it, and the nodes between consecutive edges follow the density.  Two
    edges closer than 1.5 s (a strip narrower than a cell and a half, d apart) get a node at the strip's
    middle and one d / 2 outside each edge, so that both are faces and the strip is one control volume
    (at least d / 2 from an end); when the strip is under s / 4, or a third edge is that close, they stay
    between nodes, as does a lone edge closer than s to an end (the cut links handle them).
    """
    fine, density = _density(lo, hi, window, refine)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(fine))])
    step = cdf[-1] / (n - 1)  # cdf mass of one interval
    spacing = lambda e: step / np.interp(e, fine, density)  # noqa: E731
    e = np.unique(np.asarray(edges if edges is not None else [], dtype=float))
    s = spacing(e)
    close = np.diff(e) <= 1.5 * np.maximum(s[1:], s[:-1])
    # each node block: the nodes around one edge (two) or around a strip between two close edges (three)
    blocks: list[tuple[float, ...]] = []
    k = 0
    while k < e.size:
        before = k > 0 and close[k - 1]
        if k + 1 < e.size and close[k]:  # a close pair, unless it is part of a chain of three or more
            d = e[k + 1] - e[k]
            chain = before or (k + 2 < e.size and close[k + 1])
            room = e[k] - d >= lo - 1e-9 * (hi - lo) and e[k + 1] + d <= hi + 1e-9 * (hi - lo)  # d / 2 to an end
            if not chain and d >= 0.25 * max(s[k], s[k + 1]) and room:
                blocks.append((e[k] - 0.5 * d, 0.5 * (e[k] + e[k + 1]), e[k + 1] + 0.5 * d))
            k += 2 if not chain else 1
            continue
        if not before and e[k] - s[k] > lo and e[k] + s[k] < hi:
            blocks.append((e[k] - 0.5 * s[k], e[k] + 0.5 * s[k]))
        k += 1
    # A strip's outer nodes reach d / 2 beyond its edges: where that comes within a quarter cell of the next
    # block (a third edge just beyond the strip's reach of "close"), the strip stays cut, as before.
    k = 1
    while k < len(blocks):
        a, b = blocks[k - 1], blocks[k]
        if b[0] - a[-1] < 0.25 * min(a[-1] - a[-2], b[1] - b[0]):
            del blocks[k if len(b) == 3 else k - 1]
            k = max(k - 1, 1)
            continue
        k += 1
    if not blocks:
        nodes = np.interp(np.linspace(0.0, cdf[-1], n), cdf, fine)
        nodes[0], nodes[-1] = lo, hi
        return nodes
    starts = [lo] + [b[-1] for b in blocks]
    ends = [b[0] for b in blocks] + [hi]
    mass = np.array([np.interp(b, fine, cdf) - np.interp(a, fine, cdf) for a, b in zip(starts, ends, strict=True)])
    free = n - 1 - sum(len(b) - 1 for b in blocks)  # intervals left for the segments between the blocks
    share = mass / mass.sum() * free
    counts = np.maximum(np.floor(share).astype(int), 1)
    while counts.sum() < free:  # largest remainders first
        counts[np.argmax(share - counts)] += 1
    while counts.sum() > free:
        counts[np.argmax(np.where(counts > 1, counts - share, -np.inf))] -= 1
    parts = []
    for k, (a, b, m) in enumerate(zip(starts, ends, counts, strict=True)):
        c = np.linspace(np.interp(a, fine, cdf), np.interp(b, fine, cdf), m + 1)
        seg = np.interp(c, cdf, fine)
        seg[0], seg[-1] = a, b
        parts.append(seg)
        if k < len(blocks):
            parts.append(np.array(blocks[k][1:-1]))  # a strip's middle node
    nodes = np.concatenate(parts)
    nodes[0], nodes[-1] = lo, hi
    return nodes


def centred_axis(
    half: float, n: int, window: tuple[float, float] | None, refine: float, edges: np.ndarray | None
) -> np.ndarray:
    """:func:`refined_axis` on [-half, half], mirror-symmetric when the window and the edges are.

    A symmetric face must give a symmetric grid (no spurious roll): the lower half is built and
    mirrored, with the centre a node (n odd) or a control-volume face (n even).
    """
    e = np.unique(np.asarray(edges if edges is not None else [], dtype=float))
    tol = 1e-12 * half
    symmetric = (window is None or abs(window[0] + window[1]) <= tol) and np.allclose(e, -e[::-1], rtol=0, atol=tol)
    if not symmetric:
        return refined_axis(-half, half, n, window, refine, e)
    lower = e[e < -tol]
    if n % 2:
        nodes = refined_axis(-half, 0.0, (n + 1) // 2, window, refine, lower)
        return np.concatenate([nodes[:-1], [0.0], -nodes[-2::-1]])
    full = refined_axis(-half, half, n, window, refine)  # the plain spacing at the centre
    gap = 0.5 * (full[n // 2] - full[n // 2 - 1])
    nodes = refined_axis(-half, -gap, n // 2, window, refine, lower)
    return np.concatenate([nodes, -nodes[::-1]])


def axis_edges(scene: AbsScene, axis: int) -> np.ndarray:
    """Coordinates along ``axis`` of the regions' edges that run across it (x = const edges for axis 0)."""
    out = []
    for region in scene.abs.regions:
        v = region_geometry(region, scene)
        w = np.roll(v, -1, axis=0)
        tol = 1e-12 * scene.slider.length
        straight = np.abs(v[:, axis] - w[:, axis]) <= tol
        out.extend(v[straight, axis])
        # the ends of a slanted edge: a corner on a control-volume corner starts the edge where the grid does
        slanted = (np.abs(v[:, 0] - w[:, 0]) > tol) & (np.abs(v[:, 1] - w[:, 1]) > tol)
        out.extend(v[slanted, axis])
        out.extend(w[slanted, axis])
    return np.unique(np.array(out))


@dataclass(frozen=True)
class AbsGrid:
    """Tensor grid of the face and the static surface on nodes, links and contact patches.

    x : (nx,), y : (ny,) [m].  Static surfaces (etch depth + crown/camber/twist [m], to be added to the
    attitude's plane): ``surface_xf`` (nx-1, ny) and ``surface_yf`` (nx, ny-1) on the links between
    nodes at the face mid-points (where a link is cut, its segments in ``cuts_x``/``cuts_y`` replace it),
    ``surface_xe`` (2, nx-1, ny) and ``surface_ye`` (2, nx, ny-1) the same links' surface at their two nodes,
    ``storage`` (nx, ny) the control volume's mean (the squeeze term), and ``surface`` (nx, ny) on each
    control volume's contact patch, the part at its shallowest depth ``depth``, of area ``contact_area``
    [m2] and centroid (``contact_x``, ``contact_y``).  ``area`` (nx, ny): the control volumes [m2].
    """

    x: np.ndarray
    y: np.ndarray
    surface: np.ndarray
    surface_xf: np.ndarray
    surface_yf: np.ndarray
    surface_xe: np.ndarray
    surface_ye: np.ndarray
    storage: np.ndarray
    depth: np.ndarray
    area: np.ndarray
    contact_area: np.ndarray
    contact_x: np.ndarray
    contact_y: np.ndarray
    cuts_x: CutLinks
    cuts_y: CutLinks

    @property
    def shape(self) -> tuple[int, int]:
        return (self.x.size, self.y.size)

    @property
    def xf(self) -> np.ndarray:
        return 0.5 * (self.x[1:] + self.x[:-1])

    @property
    def yf(self) -> np.ndarray:
        return 0.5 * (self.y[1:] + self.y[:-1])


def grid_axes(scene: AbsScene) -> tuple[np.ndarray, np.ndarray]:
    """The grid's nodes along x (nx,) and y (ny,) [m]: refined over the window, fitted to the edges ("fitted")."""
    s, num = scene.slider, scene.numerics
    window = _window_bounds(scene)
    margin_x = 0.5 * (window[0][1] - window[0][0]) if window else 0.0
    margin_y = 0.25 * (window[1][1] - window[1][0]) if window else 0.0
    wx = (window[0][0] - margin_x, window[0][1] + margin_x) if window else None
    wy = (window[1][0] - margin_y, window[1][1] + margin_y) if window else None
    fitted = num.faces == "fitted"
    x = refined_axis(0.0, s.length, num.nx, wx, num.refine, axis_edges(scene, 0) if fitted else None)
    y = centred_axis(0.5 * s.width, num.ny, wy, num.refine, axis_edges(scene, 1) if fitted else None)
    return x, y


def abs_grid(scene: AbsScene) -> AbsGrid:
    """Grid and rasterised surface of a scene; a grid too coarse for a pad is an error naming it.

    ``numerics.faces = "fitted"`` (default) places the nodes so that every region edge along a grid
    line is a control-volume face, and measures the rest exactly (:mod:`solver.abs.cuts`); ``"cut"``
    keeps the plain grid and measures every edge as cut links and patches; ``"sampled"`` samples the
    depth at node and face centres (every step up to half a cell off: the scheme before cut cells).
    Both others are kept for comparison (README, the grid ladder).
    """
    num = scene.numerics
    x, y = grid_axes(scene)
    _check_resolution(scene, x, y)
    area = control_volume_widths(x)[:, None] * control_volume_widths(y)[None, :]
    xf, yf = 0.5 * (x[1:] + x[:-1]), 0.5 * (y[1:] + y[:-1])
    if num.faces in ("fitted", "cut"):
        polygons = [region_geometry(r, scene) for r in scene.abs.regions]
        face = rasterise(polygons, [r.depth for r in scene.abs.regions], scene.abs.base_depth, x, y)
        link_x = _fill_cut(face.link_depth_x, face.cuts_x, x.size - 1, y.size, 0)
        link_y = _fill_cut(face.link_depth_y, face.cuts_y, x.size, y.size - 1, 1)
        mean, top, fraction = face.mean_depth, face.patch_depth, face.patch_fraction
        cx, cy, cuts_x, cuts_y = face.patch_x, face.patch_y, face.cuts_x, face.cuts_y
    else:
        X, Y = np.meshgrid(x, y, indexing="ij")
        mean = top = depth(X, Y, scene)
        link_x, link_y = depth(xf[:, None], y[None, :], scene), depth(x[:, None], yf[None, :], scene)
        fraction, cx, cy, cuts_x, cuts_y = np.ones(X.shape), X, Y, no_cuts(), no_cuts()
    return AbsGrid(
        x=x,
        y=y,
        surface=top + shape(cx, cy, scene),
        surface_xf=link_x + shape(xf[:, None], y[None, :], scene),
        surface_yf=link_y + shape(x[:, None], yf[None, :], scene),
        surface_xe=np.stack(
            [link_x + shape(x[:-1, None], y[None, :], scene), link_x + shape(x[1:, None], y[None, :], scene)]
        ),
        surface_ye=np.stack(
            [link_y + shape(x[:, None], y[None, :-1], scene), link_y + shape(x[:, None], y[None, 1:], scene)]
        ),
        storage=mean + shape(x[:, None], y[None, :], scene),
        depth=top,
        area=area,
        contact_area=area * fraction,
        contact_x=cx,
        contact_y=cy,
        cuts_x=_with_surface(cuts_x, scene),
        cuts_y=_with_surface(cuts_y, scene),
    )


def _fill_cut(link_depth: np.ndarray, cuts: CutLinks, n1: int, n2: int, axis: int) -> np.ndarray:
    """Plain-link depths with the cut links (nan) set to their length-weighted mean (finite; the cuts replace them)."""
    out = link_depth.copy()
    for n, (i, j) in enumerate(cuts.face):
        p0, p1 = cuts.piece_ptr[n], cuts.piece_ptr[n + 1]
        total = 0.0
        for p in range(p0, p1):
            s0, s1 = cuts.seg_ptr[p], cuts.seg_ptr[p + 1]
            total += cuts.piece_weight[p] * float(cuts.seg_theta[s0:s1] @ cuts.seg_depth[s0:s1])
        out[i, j] = total
    assert out.shape == (n1, n2) and np.all(np.isfinite(out)), axis
    return out


def _with_surface(cuts: CutLinks, scene: AbsScene) -> CutLinks:
    """The cut links with their segments' static surface: depth + crown/camber/twist."""
    return dataclasses.replace(cuts, seg_surface=cuts.seg_depth[None, :] + shape(cuts.seg_x, cuts.seg_y, scene))


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
