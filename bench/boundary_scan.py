"""Where does the stable/unstable boundary lie at mu = 0.5?  (README, "Contact sequences")

Runs the source's disturbance at mu = 0.5 for alpha = 0, 0.05, ..., 1 and
prints the impulse-growth classification and the corner sequence of each
run.  Extra arguments are scene overrides, e.g. a finer grid:

    python bench/boundary_scan.py
    python bench/boundary_scan.py numerics.nx=401 numerics.nx_taper=61 numerics.ny=41
"""

from __future__ import annotations

import sys

import numpy as np

from pipeline.classify import classify_impulses
from pipeline.config import DEFAULT_SCENE, load_scene
from solver.rails.integrate import simulate
from solver.rails.steady import fly


def main(overrides: list[str]) -> None:
    steady = fly(load_scene(DEFAULT_SCENE, overrides))
    for alpha in np.round(np.arange(0.0, 1.0001, 0.05), 2):
        scene = load_scene(DEFAULT_SCENE, [*overrides, f"contact.alpha={alpha}", "contact.mu=0.5"])
        r = simulate(scene, steady)
        g = classify_impulses(
            [i.impulse for i in r.impacts], [i.corner for i in r.impacts], [i.time for i in r.impacts]
        )
        first_front = next((i.time * 1e6 for i in r.impacts if i.corner in (0, 2)), float("nan"))
        print(
            f"alpha {alpha:.2f}  {'stable  ' if g.stable else 'UNSTABLE'}  impacts {g.n_impacts:3d}  "
            f"larger {g.n_larger_than_first:3d}  front {g.n_front_corner_impacts:3d}  "
            f"max ratio {g.max_impulse_ratio:6.3f}  first front impact {first_front:6.1f} us  "
            f"corners {''.join(i.corner_letter for i in r.impacts)[:24]}",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1:])
