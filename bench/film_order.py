"""Where scene 2's film loses its order of convergence: Richardson on grids whose spacing halves.

The grids 81 x 67, 161 x 135 and 321 x 271 halve the spacing exactly along x (within 2-3 % along y), so three
values f1, f2, f3 give the observed order p = log2((f1 - f2) / (f2 - f3)) and the limit f3 - (f2 - f3) / (2^p - 1)
without a fit.  Two measures (README, "Where the error comes from"):

* ``load``: the film's force and moments at a fixed attitude (no dynamics, no surface forces), for a face variant;
* ``fly``: the flying height at the element of the steady flight, at 81, 121, 161 and 321 nodes along x.

Face variants of ``studies/scenes/chen_bogy2007.toml`` (``--face``):

* ``default``: the face as it is;
* ``keep:NAME|NAME``: only the named regions (the rest is the 1.5-um cavity);
* ``pad-to-edge``: the trailing pad alone, run out to the trailing edge (850 um);
* ``--rect-step``: the trailing step's polygon (slanted sides) replaced by a rectangle of its mean width;
* ``--unfitted-step``: the same rectangle written as a polygon whose sides along x tilt by 0.1 nm over its
  length, so that the grid is not fitted to them: an edge along the links that lies inside a strip of
  control volumes (a sliver of the cavity in the step's strip), without any slant.

    python bench/film_order.py load                                            # the default face
    python bench/film_order.py load --face "keep:trailing pad|trailing step"   # order 0.64
    python bench/film_order.py load --face "keep:trailing pad|trailing step" --rect-step
    python bench/film_order.py fly --delta-gamma 0 --rect-step                 # order 1.79, default 2.4 % off
    python bench/film_order.py load --face "keep:trailing pad|trailing step" --unfitted-step   # order 0.81

About 40 s per ``load`` variant and 50 s per ``fly`` ladder on one core.
"""

from __future__ import annotations

import argparse
import math
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"
TRIPLE = ((81, 67), (161, 135), (321, 271))
#: The fixed attitude of ``load``: the steady flight without adhesion on 241 x 201 (z [m], pitch, roll [rad]).
ATTITUDE = (4.0606928347874265e-08, 1.3369764855088122e-04, -1.425000269405531e-05)
#: The trailing step as a rectangle of the polygon's mean width [m].
RECT_STEP = [0.70e-3, 0.80e-3, -0.11e-3, 0.11e-3]


#: The tilt of ``--unfitted-step``'s sides along x [m]: far below anything the film sees, enough that the
#: sides are no longer grid lines.
UNFIT_TILT = 1e-10


def scene_data(face: str, rect_step: bool, nx: int, ny: int, delta_gamma: float | None,
               unfitted_step: bool = False) -> dict:  # fmt: skip
    """The scene file's tables with the face variant, the grid and (if given) delta_gamma."""
    data = tomllib.loads(SCENE.read_text())
    data["numerics"].update(nx=nx, ny=ny, refine_nodes=2)
    if delta_gamma is not None:
        data["contact"]["delta_gamma"] = delta_gamma
    regions = data["abs"]["regions"]
    if face.startswith("keep:"):
        names = face[5:].split("|")
        unknown = set(names) - {r["name"] for r in regions}
        if unknown:
            raise SystemExit(f"--face {face!r}: no region named {sorted(unknown)} in {SCENE.name}")
        regions = [r for r in regions if r["name"] in names]
    elif face == "pad-to-edge":
        pad = next(r for r in regions if r["name"] == "trailing pad")
        pad.pop("width_from", None)
        pad["rect"] = [0.745e-3, 0.85e-3, -0.05e-3, 0.05e-3]
        regions = [pad]
    elif face != "default":
        raise SystemExit(f"--face {face!r} is not allowed: default, keep:NAME|NAME or pad-to-edge")
    if rect_step or unfitted_step:
        if not any(r["name"] == "trailing step" for r in regions):
            flag = "--unfitted-step" if unfitted_step else "--rect-step"
            raise SystemExit(f"{flag} with --face {face!r}: the face has no region named 'trailing step' to replace")
        x0, x1, y0, y1 = RECT_STEP
        for r in regions:
            if r["name"] == "trailing step":
                r.pop("polygon")
                if unfitted_step:
                    r["polygon"] = [[x0, y0], [x1, y0 + UNFIT_TILT], [x1, y1 - UNFIT_TILT], [x0, y1]]
                else:
                    r["rect"] = list(RECT_STEP)
    data["abs"]["regions"] = regions
    return data


def richardson(f1: np.ndarray, f2: np.ndarray, f3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Observed order and limit from three values on grids whose spacing halves."""
    d1, d2 = f1 - f2, f2 - f3
    p = np.log2(np.abs(d1 / d2))
    return p, f3 - d2 / (2.0**p - 1.0)


def load(args: argparse.Namespace) -> None:
    from solver.abs.film import AbsFilm
    from solver.kinds import scene_from_dict

    q = np.array(ATTITUDE)
    values = []
    for nx, ny in TRIPLE:
        film = AbsFilm(scene_from_dict(scene_data(args.face, args.rect_step, nx, ny, None, args.unfitted_step)))
        film.set_disk(np.zeros(film.shape))
        film.solve_steady(q, tol=1e-12)
        f = film.forces()
        values.append(f)
        print(f"{nx:4d} x {ny:<4d} load {f[0] * 1e3:.6f} mN  pitch moment {f[1]:.6e}  roll moment {f[2]:.6e} N m")
    p, limit = richardson(*values)
    err = (values[1][0] - limit[0]) / limit[0]
    print(f"orders (load, pitch, roll moments) {np.round(p, 2)}; load limit {limit[0] * 1e3:.5f} mN, "
          f"161 x 135 off by {100 * err:+.2f} %")  # fmt: skip


def fly(args: argparse.Namespace) -> None:
    from solver.abs.steady import fly_start
    from solver.kinds import scene_from_dict

    fh = {}
    for nx, ny in ((81, 67), (121, 101), (161, 135), (321, 271)):
        steady = fly_start(
            scene_from_dict(scene_data(args.face, args.rect_step, nx, ny, args.delta_gamma, args.unfitted_step))
        )
        fh[nx] = steady.element_spacing * 1e9
        note = f"  ({steady.note})" if steady.note else ""
        print(f"{nx:4d} x {ny:<4d} flying height {fh[nx]:.4f} nm  pitch {steady.q[1] * 1e6:.3f} urad{note}")
    p, limit = richardson(np.array(fh[81]), np.array(fh[161]), np.array(fh[321]))
    if not math.isfinite(float(p)):
        print("no order: the ladder is not monotone")
        return
    print(f"order {float(p):.2f}, limit {float(limit):.4f} nm; 121 x 101 off by {100 * (fh[121] / limit - 1):+.2f} %, "
          f"161 x 135 by {100 * (fh[161] / limit - 1):+.2f} %")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("measure", choices=("load", "fly"))
    parser.add_argument("--face", default="default", help="default, keep:NAME|NAME or pad-to-edge")
    parser.add_argument("--rect-step", action="store_true", help="the trailing step as a rectangle")
    parser.add_argument("--unfitted-step", action="store_true",
                        help="the rectangle with its sides along x tilted by 0.1 nm: not grid lines")  # fmt: skip
    parser.add_argument("--delta-gamma", type=float, default=None, help="fly: contact.delta_gamma [J/m2]")
    args = parser.parse_args()
    load(args) if args.measure == "load" else fly(args)


if __name__ == "__main__":
    main()
