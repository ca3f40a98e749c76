"""Cut cells: where the region edges of an ABS cross the control volumes and the links between nodes.

The face's depth is piecewise constant: regions are polygons (rectangles
included) painted in order over the deep cavity.  On a tensor grid an edge
almost never falls on a control-volume face, and sampling the depth at
node and face centres moves every step by up to half a cell, differently
on every grid: the flying height then scatters under refinement instead of
converging.  This module measures the geometry exactly instead, along
lines:

* a *strip* is the band of one row of control volumes, y in [yl_j, yr_j]
  (or one column, x in [xl_i, xr_i], for the y-links); it is split into
  *pieces* at the y of every polygon vertex inside it, so that inside a
  piece every edge crossing the strip is a straight line that neither
  starts nor ends;
* on the mid-line of each piece the depth along x is a step function,
  exact (:func:`line_profile`); the piece's weight is its share of the
  strip's height.  Within a piece, edge positions are linear in y, so the
  mid-line is exact for lengths and second order for what depends
  smoothly on them.

From these profiles:

* a *link* (node i to i+1 along row j) whose pieces all see one depth is
  a plain face; otherwise it is a *cut link*, described by its pieces and,
  per piece, its segments along the link (length fraction, mid-point,
  depth).  The film joins the segments in series and the pieces in
  parallel (:func:`solver.kernels.film.cut_fluxes`); the pieces of one
  link that see the same steps are one piece there (:func:`_merged`);
* a control volume gets its mean depth (what the squeeze term stores) and
  its *contact patch*: the part at its shallowest depth, with its area and
  centroid, where the surface forces act.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Breakpoints closer than this fraction of the axis length are one.
MERGE = 1e-12


@dataclass(frozen=True)
class Line:
    """A step function along one axis at a fixed other coordinate: depth[k] on [edges[k], edges[k+1]]."""

    edges: np.ndarray
    depth: np.ndarray


def crossings(vertices: np.ndarray, axis: int, c: float) -> np.ndarray:
    """Coordinates along ``axis`` where the polygon's edges cross the line {other coordinate = c}."""
    a, b = vertices, np.roll(vertices, -1, axis=0)
    u, v = 1 - axis, axis  # u: the fixed coordinate's column, v: the coordinate along the line
    hit = (a[:, u] > c) != (b[:, u] > c)
    a, b = a[hit], b[hit]
    return a[:, v] + (c - a[:, u]) * (b[:, v] - a[:, v]) / (b[:, u] - a[:, u])


def line_profile(polygons: list[np.ndarray], depths: list[float], base: float, axis: int, c: float,
                 lo: float, hi: float) -> Line:  # fmt: skip
    """Depth along ``axis`` (0: x, 1: y) on [lo, hi] at the other coordinate c: regions painted in order."""
    points = [np.array([lo, hi])] + [crossings(p, axis, c) for p in polygons]
    edges = np.unique(np.clip(np.concatenate(points), lo, hi))
    edges = edges[np.concatenate([[True], np.diff(edges) > MERGE * (hi - lo)])]
    edges[-1] = hi
    mid = 0.5 * (edges[1:] + edges[:-1])
    depth = np.full(mid.size, base)
    for poly, d in zip(polygons, depths, strict=True):
        inside = np.zeros(mid.size, dtype=bool)
        for x in crossings(poly, axis, c):
            inside ^= mid > x  # even-odd rule along the line
        depth[inside] = d
    keep = np.concatenate([[True], depth[1:] != depth[:-1]])  # merge neighbours of equal depth
    return Line(np.append(edges[:-1][keep], hi), depth[keep])


def pieces(lo: float, hi: float, vertex_coords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mid-lines and weights (share of [lo, hi]) of the strip [lo, hi] split at the vertex coordinates inside it."""
    inner = vertex_coords[(vertex_coords > lo + MERGE * (hi - lo)) & (vertex_coords < hi - MERGE * (hi - lo))]
    cuts = np.concatenate([[lo], np.unique(inner), [hi]])
    return 0.5 * (cuts[1:] + cuts[:-1]), np.diff(cuts) / (hi - lo)


def slanted_crossings(polygons: list[np.ndarray], axis: int, coords: np.ndarray) -> np.ndarray:
    """Across-coordinates where the polygons' slanted edges cross the lines {``axis`` coordinate = coords}.

    Splitting a strip there as well keeps every slanted edge inside one link
    and one control volume per piece, so a piece's mid-line sees each edge
    in the link it really crosses: without it, the mid-line puts all of a
    strip's edge in the one link it crosses at mid-height (a staircase that
    jumps from link to link as the grid moves), whatever the slope.
    """
    out = []
    for poly in polygons:
        a, b = poly, np.roll(poly, -1, axis=0)
        v, u = axis, 1 - axis
        slanted = (a[:, v] != b[:, v]) & (a[:, u] != b[:, u])
        for pa, pb in zip(a[slanted], b[slanted], strict=True):
            lo, hi = min(pa[v], pb[v]), max(pa[v], pb[v])
            g = coords[(coords > lo) & (coords < hi)]
            out.append(pa[u] + (g - pa[v]) * (pb[u] - pa[u]) / (pb[v] - pa[v]))
    return np.concatenate(out) if out else np.zeros(0)


def clip(line: Line, a: float, b: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The segments of the step function on [a, b]: lengths, mid-points and depths."""
    k0 = max(int(np.searchsorted(line.edges, a, side="right")) - 1, 0)
    k1 = min(int(np.searchsorted(line.edges, b, side="left")) - 1, line.depth.size - 1)
    lo = np.maximum(line.edges[k0 : k1 + 1], a)
    hi = np.minimum(line.edges[k0 + 1 : k1 + 2], b)
    keep = hi - lo > MERGE * (b - a)
    return (hi - lo)[keep], 0.5 * (hi + lo)[keep], line.depth[k0 : k1 + 1][keep]


@dataclass(frozen=True)
class CutLinks:
    """The cut links along one axis, flattened for the kernels.

    face (n, 2): node-pair index (i, j) of the link's lower node; piece_ptr (n + 1,) into the pieces;
    piece_weight (m,); seg_ptr (m + 1,) into the segments; seg_theta (k,) length fraction of the link;
    seg_x, seg_y (3, k) the segment's mid-point, lower and upper end [m]; seg_depth (k,) etch depth [m];
    seg_surface (3, k) the static surface at those points [m] (the depth here;
    :func:`solver.abs.face.abs_grid` adds crown, camber and twist).
    """

    face: np.ndarray
    piece_ptr: np.ndarray
    piece_weight: np.ndarray
    seg_ptr: np.ndarray
    seg_theta: np.ndarray
    seg_x: np.ndarray
    seg_y: np.ndarray
    seg_depth: np.ndarray
    seg_surface: np.ndarray

    @property
    def count(self) -> int:
        return self.face.shape[0]

    @property
    def owner(self) -> np.ndarray:
        """The cut link (index into ``face``) of every segment (k,)."""
        per_piece = np.repeat(np.arange(self.count), np.diff(self.piece_ptr))
        return np.repeat(per_piece, np.diff(self.seg_ptr)).astype(np.int64)


def no_cuts() -> CutLinks:
    """No cut links (a face sampled at the node and face centres)."""
    f, f3, i = np.zeros(0), np.zeros((3, 0)), np.zeros(1, dtype=np.int64)
    return CutLinks(np.zeros((0, 2), dtype=np.int64), i, f, i, f, f3, f3, f, f3)


@dataclass(frozen=True)
class Rasterised:
    """The exact face on a tensor grid (see the module docstring).

    link_depth_x (nx-1, ny), link_depth_y (nx, ny-1): depth of the plain links (nan where cut);
    cuts_x, cuts_y: the cut links; mean_depth (nx, ny) over each control volume;
    patch_depth, patch_fraction, patch_x, patch_y (nx, ny): the contact patch of each control volume.
    """

    link_depth_x: np.ndarray
    link_depth_y: np.ndarray
    cuts_x: CutLinks
    cuts_y: CutLinks
    mean_depth: np.ndarray
    patch_depth: np.ndarray
    patch_fraction: np.ndarray
    patch_x: np.ndarray
    patch_y: np.ndarray


def _strip_lines(polygons, depths, base, axis, bounds, along, vertex_coords):
    """Per strip (the control volumes' extent across ``axis``): its pieces' mid-lines, weights and profiles."""
    out = []
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        mids, weights = pieces(lo, hi, vertex_coords)
        lines = [line_profile(polygons, depths, base, axis, c, along[0], along[-1]) for c in mids]
        out.append((mids, weights, lines))
    return out


def _plain(lines: list[Line], a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Depth of each interval [a_k, b_k] that every line crosses without a step at one depth; nan elsewhere."""
    out = np.full(a.size, np.nan)
    plain = np.ones(a.size, dtype=bool)
    for n, line in enumerate(lines):
        tol = MERGE * (b - a)
        k0 = np.clip(np.searchsorted(line.edges, a + tol, side="right") - 1, 0, line.depth.size - 1)
        k1 = np.clip(np.searchsorted(line.edges, b - tol, side="left") - 1, 0, line.depth.size - 1)
        d = line.depth[k0]
        plain &= (k0 == k1) & ((d == out) if n else True)
        out = d if n == 0 else out
    return np.where(plain, out, np.nan)


def _merged(mids: np.ndarray, weights: np.ndarray, parts: list, length: float) -> list:
    """A cut link's pieces with one profile merged: [(mid-line, weight, (length, mid, depth))].

    A strip is split at every polygon vertex and slanted crossing inside it, for all of its links; on most links
    many of its pieces see the same steps at the same places (the same depths, breakpoints within MERGE of the
    link).  Such pieces are one piece of their summed weight on their weighted mid-line, where what varies across
    the strip smoothly (the crown, camber and twist, the roll) is taken: the midpoint rule over the merged band, as
    over each piece before (on chen_bogy2007, 2673 pieces of 437 cut x links become 703).
    """
    out: list = []
    tol = MERGE * length
    for c, w, (seg_len, seg_mid, depth) in zip(mids, weights, parts, strict=True):
        for k, (c0, w0, (len0, mid0, depth0)) in enumerate(out):
            if (depth0.size == depth.size and np.array_equal(depth0, depth) and np.all(np.abs(len0 - seg_len) <= tol)
                    and np.all(np.abs(mid0 - seg_mid) <= tol)):  # fmt: skip
                out[k] = ((w0 * c0 + w * c) / (w0 + w), w0 + w, (len0, mid0, depth0))
                break
        else:
            out.append((c, w, (seg_len, seg_mid, depth)))
    return out


def _links(strips, nodes: np.ndarray, axis: int) -> tuple[np.ndarray, CutLinks]:
    """Plain-link depths (n_nodes - 1, n_strips) and the cut links along ``axis``."""
    link_depth = np.empty((nodes.size - 1, len(strips)))
    face, piece_ptr, weight, seg_ptr = [], [0], [], [0]
    theta, sx, sy, sd = [], [], [], []
    for j, (mids, weights, lines) in enumerate(strips):
        link_depth[:, j] = _plain(lines, nodes[:-1], nodes[1:])
        for i in np.flatnonzero(np.isnan(link_depth[:, j])):
            a, b = nodes[i], nodes[i + 1]
            face.append((i, j) if axis == 0 else (j, i))
            for c, w, (length, mid, depth) in _merged(mids, weights, [clip(line, a, b) for line in lines], b - a):
                weight.append(w)
                theta.extend(length / (b - a))
                along = np.stack([mid, mid - 0.5 * length, mid + 0.5 * length])
                across = np.full(along.shape, c)
                sx.append(along if axis == 0 else across)
                sy.append(across if axis == 0 else along)
                sd.extend(depth)
                seg_ptr.append(len(theta))
            piece_ptr.append(len(weight))
    cuts = CutLinks(
        face=np.array(face, dtype=np.int64).reshape(-1, 2),
        piece_ptr=np.array(piece_ptr, dtype=np.int64),
        piece_weight=np.array(weight, dtype=float),
        seg_ptr=np.array(seg_ptr, dtype=np.int64),
        seg_theta=np.array(theta, dtype=float),
        seg_x=np.concatenate(sx, axis=1) if sx else np.zeros((3, 0)),
        seg_y=np.concatenate(sy, axis=1) if sy else np.zeros((3, 0)),
        seg_depth=np.array(sd, dtype=float),
        seg_surface=np.tile(np.array(sd, dtype=float), (3, 1)),
    )
    return (link_depth if axis == 0 else link_depth.T), cuts


def _volumes(strips, xl: np.ndarray, xr: np.ndarray, yl: np.ndarray, yr: np.ndarray):
    """Mean depth and contact patch (depth, area fraction, centroid) of every control volume: (nx, ny) each."""
    nx, ny = xl.size, len(strips)
    mean = np.empty((nx, ny))
    patch_d, patch_f = np.empty((nx, ny)), np.ones((nx, ny))
    patch_x = np.broadcast_to(0.5 * (xl + xr)[:, None], (nx, ny)).copy()
    patch_y = np.broadcast_to(0.5 * (yl + yr)[None, :], (nx, ny)).copy()
    for j, (mids, weights, lines) in enumerate(strips):
        mean[:, j] = patch_d[:, j] = _plain(lines, xl, xr)
        for i in np.flatnonzero(np.isnan(mean[:, j])):
            width = xr[i] - xl[i]
            parts = [clip(line, xl[i], xr[i]) for line in lines]
            top = min(float(p[2].min()) for p in parts)
            total = area = cx = cy = 0.0
            for c, w, (length, mid, depth) in zip(mids, weights, parts, strict=True):
                share = w * length / width
                total += float(share @ depth)
                on = depth == top
                area += float(share[on].sum())
                cx += float(share[on] @ mid[on])
                cy += float(share[on].sum()) * c
            mean[i, j], patch_d[i, j], patch_f[i, j] = total, top, area
            patch_x[i, j], patch_y[i, j] = cx / area, cy / area
    return mean, patch_d, patch_f, patch_x, patch_y


def rasterise(polygons: list[np.ndarray], depths: list[float], base: float, x: np.ndarray, y: np.ndarray) -> Rasterised:
    """The exact face (painted ``polygons`` at ``depths`` over ``base``) on the tensor grid x (nx,), y (ny,) [m]."""
    xl = np.concatenate([[x[0]], 0.5 * (x[1:] + x[:-1])])
    xr = np.concatenate([0.5 * (x[1:] + x[:-1]), [x[-1]]])
    yl = np.concatenate([[y[0]], 0.5 * (y[1:] + y[:-1])])
    yr = np.concatenate([0.5 * (y[1:] + y[:-1]), [y[-1]]])
    vx = np.concatenate([p[:, 0] for p in polygons]) if polygons else np.zeros(0)
    vy = np.concatenate([p[:, 1] for p in polygons]) if polygons else np.zeros(0)
    gx, gy = np.union1d(x, xl), np.union1d(y, yl)  # nodes and control-volume faces
    rows = _strip_lines(polygons, depths, base, 0, np.append(yl, yr[-1]), x,
                        np.concatenate([vy, slanted_crossings(polygons, 0, gx)]))  # fmt: skip
    cols = _strip_lines(polygons, depths, base, 1, np.append(xl, xr[-1]), y,
                        np.concatenate([vx, slanted_crossings(polygons, 1, gy)]))  # fmt: skip
    link_x, cuts_x = _links(rows, x, 0)
    link_y, cuts_y = _links(cols, y, 1)
    mean, patch_d, patch_f, patch_x, patch_y = _volumes(rows, xl, xr, yl, yr)
    return Rasterised(link_x, link_y, cuts_x, cuts_y, mean, patch_d, patch_f, patch_x, patch_y)
