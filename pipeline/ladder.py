"""The grid ladder of a steady flight: ``hdi fly SCENE --ladder [GRIDS]`` (kind abs).

A flight on one grid carries the grid's error, and for a slider that flies
at 2 nm it is most of the physics (issue 13): the flying height of the
default face falls by 0.15 nm from 121 x 101 to 321 x 271.  The ladder
solves the scene's steady flight on a list of grids (default: the scene's
grid with its intervals scaled by 2/3, 1, 4/3, 2 and 8/3) and, for the
flying height at the element, the pitch, the roll and the smallest spacing,

* fits f(h) = f_0 + b h^p by least squares over the grids that fly
  (h = 1 / (nx - 1), the x interval of the uniform grid before refinement),
  and gives the fitted limit f_0, the observed order p and the scene grid's
  departure from f_0;
* takes Richardson's three-point estimate from the first triple whose x
  intervals halve (81, 161, 321 nodes for the default face), which needs
  no fit: p = ln((f1 - f2) / (f2 - f3)) / ln 2, f_0 = f3 - (f2 - f3) / (2^p - 1),
  or says why it has none (not monotone);
* says whether each quantity is monotone over the ladder.

A grid whose flight fails (no flying equilibrium, a stalled solve) is
recorded with its message and left out of the fits.  The dataset's
dimension is ``nx`` (one grid per nx); its file is a product "ladder".
"""

from __future__ import annotations

import dataclasses
import math
import re
import time
from typing import Any

import numpy as np
import xarray as xr

#: Scale factors of the scene's grid intervals in the default ladder.
DEFAULT_FACTORS = (2.0 / 3.0, 1.0, 4.0 / 3.0, 2.0, 8.0 / 3.0)
#: The quantities fitted, with their display unit and scale.
QUANTITIES = {
    "flying_height": ("nm", 1e9, "flying height at the read/write element"),
    "pitch": ("urad", 1e6, "pitch"),
    "roll": ("urad", 1e6, "roll"),
    "min_spacing": ("nm", 1e9, "smallest spacing over the pads"),
}
#: The range of orders the least-squares fit searches; a fit at either end has found no order.
ORDER_RANGE = (0.25, 6.0)
#: Below this observed order neither the fit nor Richardson's estimate extrapolates (the limit would lie far
#: beyond the grids: at p = 0.25 the step from 321 nodes to the limit is 5.7 times the step from 161 to 321).
MIN_ORDER = 0.5
#: Fewest grid nodes along an axis the ladder accepts (the face's regions need three intervals each).
MIN_NODES = 11
GRID_PATTERN = re.compile(r"^\s*(\d+)\s*x\s*(\d+)\s*$")


def parse_grids(text: str) -> list[tuple[int, int]]:
    """``"81x67,121x101"`` -> [(81, 67), (121, 101)]; a clear error for anything else."""
    grids = []
    for item in text.split(","):
        match = GRID_PATTERN.match(item)
        if not match:
            raise ValueError(
                f"--ladder: grid {item.strip()!r} is not NXxNY (e.g. 121x101); give a comma-separated list"
            )
        nx, ny = int(match.group(1)), int(match.group(2))
        if nx < MIN_NODES or ny < MIN_NODES:
            raise ValueError(f"--ladder: grid {nx}x{ny} has fewer than {MIN_NODES} nodes along an axis")
        grids.append((nx, ny))
    if len(set(grids)) != len(grids) or len({nx for nx, _ in grids}) != len(grids):
        raise ValueError(f"--ladder: grids {text!r} repeat an nx; each grid needs its own x interval")
    if len(grids) < 3:
        raise ValueError(f"--ladder: {len(grids)} grid(s) given; a fit of f0 + b h^p needs at least 3")
    return sorted(grids)


def default_grids(nx: int, ny: int) -> list[tuple[int, int]]:
    """The scene's grid with its intervals scaled by :data:`DEFAULT_FACTORS` (121 x 101: 81 x 67 .. 321 x 267)."""
    return [(round((nx - 1) * f) + 1, round((ny - 1) * f) + 1) for f in DEFAULT_FACTORS]


def fit_power(h: np.ndarray, f: np.ndarray) -> tuple[float, float, float]:
    """Least-squares f0 + b h^p over p in ORDER_RANGE (f0 and b linear for each p): (f0, b, p); NaN if < 3 points
    or if the best p lies at either end of the range (no order: the points do not follow a power law in h)."""
    ok = np.isfinite(f)
    h, f = h[ok], f[ok]
    if h.size < 3:
        return math.nan, math.nan, math.nan
    best = (math.inf, math.nan, math.nan, math.nan)
    for p in np.linspace(*ORDER_RANGE, 2301):
        A = np.stack([np.ones_like(h), h**p], axis=1)
        coef, *_ = np.linalg.lstsq(A, f, rcond=None)
        sse = float(np.sum((A @ coef - f) ** 2))
        if sse < best[0]:
            best = (sse, float(coef[0]), float(coef[1]), float(p))
    if best[3] in ORDER_RANGE or best[3] < MIN_ORDER:
        return math.nan, math.nan, math.nan
    return best[1], best[2], best[3]


def richardson(
    f1: float, f2: float, f3: float, ratio: float = 2.0, scale: float = 1.0, unit: str = ""
) -> tuple[float, float, str]:
    """Observed order and limit from three grids whose intervals shrink by ``ratio`` each: (p, f0, ""), or NaNs
    and why there is no estimate (the differences change sign or vanish)."""
    d1, d2 = f1 - f2, f2 - f3
    if not (np.isfinite(d1) and np.isfinite(d2)):
        return math.nan, math.nan, "a grid of the triple has no flight"
    if d1 == 0.0 or d2 == 0.0 or (d1 > 0) != (d2 > 0):
        return math.nan, math.nan, "not monotone over the triple"
    if abs(d2) >= abs(d1):
        return (
            math.nan,
            math.nan,
            (f"the change does not shrink under refinement ({d1 * scale:.3g}, then {d2 * scale:.3g} {unit})"),
        )
    p = math.log(d1 / d2) / math.log(ratio)
    if p < MIN_ORDER:
        return math.nan, math.nan, f"observed order {p:.2f} is below {MIN_ORDER}: no extrapolation"
    return p, f3 - d2 / (ratio**p - 1.0), ""


def halving_triple(nx: list[int]) -> tuple[int, int, int] | None:
    """Indices of the first three grids whose x intervals halve exactly (nx - 1 doubling), or None."""
    intervals = [n - 1 for n in nx]
    for i, a in enumerate(intervals):
        if 2 * a in intervals and 4 * a in intervals:
            return i, intervals.index(2 * a), intervals.index(4 * a)
    return None


def grid_ladder(scene: Any, grids: list[tuple[int, int]], quiet: bool = False) -> xr.Dataset:
    """Steady flight of ``scene`` on each grid, the fits and Richardson's estimate (module docstring)."""
    from solver.abs.face import abs_grid
    from solver.abs.steady import fly_abs

    from .data.netcdf import product_attrs, var

    for nx, ny in grids:  # every grid resolves the face (an error naming the region) before any flight
        abs_grid(_with_grid(scene, nx, ny))
    rows: list[dict[str, Any]] = []
    for nx, ny in grids:
        t0 = time.perf_counter()
        try:
            steady = fly_abs(_with_grid(scene, nx, ny))
            row = {
                "flying_height": steady.element_spacing,
                "pitch": steady.q[1],
                "roll": steady.q[2],
                "min_spacing": steady.min_spacing,
                "contact_force": steady.surface.contact,
                "adhesion_force": steady.surface.adhesion,
                "message": f"contact branch: {steady.branch}" if steady.branch else "",
                "status": 0,
            }
        except Exception as err:  # a grid without a flight is a result of the ladder, not its end
            row = {name: math.nan for name in (*QUANTITIES, "contact_force", "adhesion_force")}
            row.update(message=f"{type(err).__name__}: {err}", status=1)
        row.update(nx=nx, ny=ny, wall_time=time.perf_counter() - t0)
        rows.append(row)
        if not quiet:
            print(_row_line(row), flush=True)
    nx = np.array([r["nx"] for r in rows])
    h = 1.0 / (nx - 1.0)
    variables: dict[str, xr.Variable] = {
        "ny": var(np.array([r["ny"] for r in rows]), ("nx",), "1", "grid nodes along y"),
        "h": var(h, ("nx",), "1", "grid interval along x before refinement, 1 / (nx - 1)"),
        "status": var(
            np.array([r["status"] for r in rows], dtype=np.int8),
            ("nx",),
            "1",
            "0: the flight converged; 1: it failed (message)",
        ),  # fmt: skip
        "message": xr.Variable(
            ("nx",),
            np.array([r["message"] for r in rows], dtype=object),
            attrs={"long_name": "why a grid has no flight, or the contact branch it flies on"},
        ),  # fmt: skip
        "contact_force": var(np.array([r["contact_force"] for r in rows]), ("nx",), "N", "steady contact force"),
        "adhesion_force": var(np.array([r["adhesion_force"] for r in rows]), ("nx",), "N", "steady adhesion force"),
        "wall_time": var(np.array([r["wall_time"] for r in rows]), ("nx",), "s", "wall time of the steady solve"),
    }
    scene_index = int(np.argmin(np.abs(nx - scene.numerics.nx))) if scene.numerics.nx in nx else -1
    triple = halving_triple(list(nx))
    for name, (shown, scale, long_name) in QUANTITIES.items():
        unit = "rad" if name in ("pitch", "roll") else "m"
        f = np.array([r[name] for r in rows], dtype=float)
        f0, b, p = fit_power(h, f)
        finite = f[np.isfinite(f)]
        steps = np.diff(finite)
        monotone = bool(steps.size and (np.all(steps > 0) or np.all(steps < 0)))
        variables[name] = var(f, ("nx",), unit, long_name)
        variables[f"{name}_fit_limit"] = var(f0, (), unit, f"least-squares f0 of f0 + b h^p: {long_name}")
        variables[f"{name}_fit_order"] = var(p, (), "1", f"least-squares p of f0 + b h^p: {long_name}",
                                             monotone=int(monotone))  # fmt: skip
        if triple is not None:
            rp, rf0, why = richardson(*(f[i] for i in triple), scale=scale, unit=shown)
            triple_nx = ", ".join(f"{nx[i]}" for i in triple)
            variables[f"{name}_richardson_order"] = var(rp, (), "1", f"Richardson's observed order: {long_name}",
                                                        grids=triple_nx, why=why)  # fmt: skip
            variables[f"{name}_richardson_limit"] = var(rf0, (), unit, f"Richardson's limit: {long_name}")
        if scene_index >= 0:
            ref = rf0 if triple is not None and np.isfinite(rf0) else f0
            err = (f[scene_index] - ref) / abs(ref) if np.isfinite(ref) and ref != 0.0 else math.nan
            what = f"the scene grid's departure from the limit (Richardson's, else the fit), relative: {long_name}"
            variables[f"{name}_scene_grid_error"] = var(err, (), "1", what)
    ds = xr.Dataset(variables, coords={"nx": ("nx", nx, {"units": "1", "long_name": "grid nodes along x"})})
    ds.attrs.update(product_attrs(f"Grid ladder of the steady flight of scene {scene.name}", scene, "ladder"))
    ds.attrs["ladder_grids"] = ", ".join(f"{a}x{b}" for a, b in grids)
    return ds


def _with_grid(scene: Any, nx: int, ny: int) -> Any:
    """The scene on an nx x ny grid (its numerics validated again)."""
    return dataclasses.replace(scene, numerics=dataclasses.replace(scene.numerics, nx=nx, ny=ny))


def _row_line(row: dict[str, Any]) -> str:
    head = f"  {row['nx']:4d} x {row['ny']:<4d}"
    if row["status"]:
        return f"{head}  no flight: {row['message']}  ({row['wall_time']:.1f} s)"
    return (
        f"{head}  FH {row['flying_height'] * 1e9:7.4f} nm  pitch {row['pitch'] * 1e6:8.3f} urad  "
        f"roll {row['roll'] * 1e6:8.3f} urad  min spacing {row['min_spacing'] * 1e9:6.4f} nm  "
        f"contact {row['contact_force'] * 1e3:.3g} mN  ({row['wall_time']:.1f} s)"
    )


def ladder_report(ds: xr.Dataset) -> list[str]:
    """Per quantity: its values over the grids, the fit, Richardson's estimate, the scene grid's departure."""
    lines = []
    for name, (unit, scale, _) in QUANTITIES.items():
        values = ", ".join(f"{v * scale:.4f}" for v in ds[name].values)
        mono = "monotone" if ds[f"{name}_fit_order"].attrs.get("monotone") else "not monotone"
        p = float(ds[f"{name}_fit_order"])
        fit = (
            f"fit f0 + b h^p: {float(ds[f'{name}_fit_limit']) * scale:.4f} {unit} (p = {p:.2f})"
            if np.isfinite(p)
            else "fit: no power law in h (best order at the end of the range searched)"
        )
        rich = "Richardson: no grids whose x intervals halve"
        if f"{name}_richardson_order" in ds:
            rv = ds[f"{name}_richardson_order"]
            grids = rv.attrs.get("grids", "")
            if np.isfinite(float(rv)):
                limit = float(ds[f"{name}_richardson_limit"]) * scale
                rich = f"Richardson ({grids}): {limit:.4f} {unit} (p = {float(rv):.2f})"
            else:
                rich = f"Richardson ({grids}): none, {rv.attrs.get('why', '')}"
        err = ds.get(f"{name}_scene_grid_error")
        err_text = (
            f"; the scene's grid {float(err) * 100:+.2f} % off that limit"
            if err is not None and np.isfinite(float(err))
            else ""
        )
        lines.append(f"{name} [{unit}]: {values} ({mono})")
        lines.append(f"    {fit}; {rich}{err_text}")
    return lines
