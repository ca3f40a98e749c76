"""Can any taper length c0 reproduce the source's steady state?  (README, "Steady flight")

Part 1: film load and centre of pressure at the source's attitude
(z = 0.115 um, pitch = 13.5 urad) for a range of c0, per slip law.
Part 2: the attitude the printed preload (0.0932 N, no suspension moment)
actually flies at, for the same c0 values.

    python bench/taper_calibration.py            (about a minute)
"""

from __future__ import annotations

import numpy as np

from pipeline.config import DEFAULT_SCENE, load_scene
from solver.rails.film import make_film
from solver.rails.steady import fly

C0_MM = (0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0)


def main() -> None:
    q = np.array([0.115e-6, 13.5e-6, 0.0])
    print("film at the source attitude z = 0.115 um, pitch = 13.5 urad (printed preload 0.0932 N)")
    print(f"{'slip':13s} {'c0 [mm]':>8s} {'load [N]':>9s} {'cop x1 [mm]':>12s} {'moment needed [N m]':>20s}")
    for slip in ("first_order", "continuum", "second_order"):
        for c0 in C0_MM:
            scene = load_scene(DEFAULT_SCENE, [f"slider.taper_length={c0 * 1e-3}", f"models.slip={slip}"])
            film = make_film(scene)
            film.solve_steady(q)
            f = film.generalized_forces()
            print(f"{slip:13s} {c0:8.2f} {f[0]:9.5f} {-f[1] / f[0] * 1e3:12.4f} {-f[1]:20.4e}")
    print("\nuncalibrated: printed preload 0.0932 N, no suspension moment (first-order slip)")
    print(f"{'c0 [mm]':>8s} {'z [um]':>8s} {'pitch [urad]':>13s} {'h_min [um]':>11s}")
    for c0 in C0_MM:
        scene = load_scene(DEFAULT_SCENE, [f"slider.taper_length={c0 * 1e-3}", "calibration.mode=none"])
        s = fly(scene)
        print(f"{c0:8.2f} {s.z * 1e6:8.4f} {s.pitch * 1e6:13.2f} {s.min_spacing * 1e6:11.4f}")


if __name__ == "__main__":
    main()
