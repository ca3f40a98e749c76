"""Where the film's time error on the rough track comes from: variants of one film step, at a fixed attitude.

The film alone, at the default flight's attitude, over the moving rough track (the default grid and track, as
``tests/test_film_coupling.py::test_the_film_on_a_rough_track_converges_in_its_own_step``): 25 intervals of 0.4 us,
each in m film steps, the mean air force sampled at the intervals' ends against m = 64 with the solver's step.  The
solver's step (:func:`solver.kernels.film.film_advance`) is linearly implicit midpoint: its fluxes and Jacobian at the
old pressure over the mid-step spacing, whose disk is the mean of the step's two ends.  The variants change one
thing each:

* ``mid time``: the mid-step disk sampled at the mid time instead of the mean of the ends;
* ``step mean``: the mid-step disk averaged over the step (32 samples): the Couette flux's exact mean;
* ``gauss 2``, ``gauss 3``: the fluxes and Jacobian averaged over 2 or 3 Gauss points of the step, each over the
  disk at its time (the flux term's quadrature in time);
* ``newton 2``: the implicit midpoint solved by two Newton passes (the fluxes at P_n + delta / 2), not one;
* ``theta X``: the theta method (fluxes at P_n over the disk at theta, Jacobian weight theta; 1: backward Euler);
* ``bdf2``, ``trapezoid``: the solver's BDF2 and trapezoidal steps (``numerics.film_scheme``), each on a film of its
  own over the same track; ``trap. eval`` the trapezoid with its start flux evaluated every step
  (``numerics.film_start_flux``; ``trapezoid`` carries it from the last step).

    python bench/film_time_error.py                            # 10 s
    python bench/film_time_error.py --set numerics.refine=2    # any scene override

Measured after a76fa90 (2026-11-29), error of the mean force [uN] at film steps of 0.4, 0.2, 0.1 and 0.05 us: the
solver's step 12.28, 7.87, 3.37, 1.04; mid time 16.82, 8.36, 2.50, 0.67; step mean 17.40, 8.39, 2.82, 0.80; gauss 2
16.78, 8.26, 2.78, 0.79; gauss 3 17.34, 8.31, 2.79, 0.79; newton 2 12.20, 7.84, 3.36, 1.04; theta 0.75 11.60, 7.06,
3.09, 1.06; theta 1 5.35, 2.36, 1.13, 0.54; bdf2 6.12, 0.28, 0.21, 0.11; trapezoid 0.52, 0.08, 0.05, 0.03 (its start
flux evaluated; carried, 0.55, 0.06, 0.04, 0.03).
Sampling the track finer within a step and solving the step exactly leave the error at 0.2 us as it was; the
schemes of stage order 2 (BDF2, the trapezoid) cut it (README, "The film's time scheme").
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # conftest's scene loader
sys.path.insert(0, str(ROOT))

from conftest import chen_bogy  # noqa: E402

from solver.abs.film import AbsFilm  # noqa: E402
from solver.abs.steady import fly_start  # noqa: E402
from solver.abs.track import Track  # noqa: E402
from solver.kernels import film as kf  # noqa: E402
from solver.kernels import reynolds as kr  # noqa: E402

INTERVAL, INTERVALS = 0.4e-6, 25
GAUSS = {
    2: ((0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0)), (0.5, 0.5)),
    3: ((0.5 - 0.5 * np.sqrt(0.6), 0.5, 0.5 + 0.5 * np.sqrt(0.6)), (5 / 18, 8 / 18, 5 / 18)),
}
#: The solver's other schemes, each on a film of its own: name, scene overrides.
OTHERS = (
    ("bdf2", {"numerics.film_scheme": "bdf2"}),
    ("trapezoid", {"numerics.film_scheme": "trapezoid"}),
    ("trap. eval", {"numerics.film_scheme": "trapezoid", "numerics.film_start_flux": "evaluated"}),
)
VARIANTS = ("solver", "mid time", "step mean", "gauss 2", "gauss 3", "newton 2", "theta 0.55", "theta 0.6",
            "theta 0.75", "theta 1.0")  # fmt: skip


class Bench:
    """The film, its steady pressure at the flight's attitude, and the moving track."""

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        scene = chen_bogy({"numerics.t_end": 12e-6, "numerics.settle_time": 0.0, **(overrides or {})})
        self.film = AbsFilm(scene)
        self.q = fly_start(scene, self.film).q
        self.track = Track(scene, self.film.grid)
        self.P0 = self.film.P.copy()

    def disk(self, t: float) -> np.ndarray:
        return self.track.at(t)[0]

    def set_links(self, disk: np.ndarray, edges_only: bool) -> None:
        """The links' and cut segments' spacings at the attitude over the node disk ``disk``."""
        f = self.film
        (x, y, px, py, _, sxf, syf, sxe, sye, ih, floor, xsx, xsy, xss, ysx, ysy, yss) = f._advance_geometry
        cuts = kf.AbsFilmCuts(*f._kernel_film[2])
        kf.set_disk(np.ascontiguousarray(disk), f.disk, f.disk_xf, f.disk_yf)
        kf.fill_links(self.q, x, y, px, py, sxf, syf, sxe, sye, f.disk, ih, floor, f.Hx, f.Hy, f.Hxe, f.Hye,
                      edges_only)  # fmt: skip
        kf.fill_cut_points(self.q, xsx, xsy, px, py, xss, f.disk_xf, cuts.xcell, ih, floor, cuts.xH)
        kf.fill_cut_points(self.q, ysx, ysy, px, py, yss, f.disk_yf, cuts.ycell, ih, floor, cuts.yH)

    def step(self, t0: float, h: float, variant: str) -> None:
        """One film step of ``variant`` from t0 to t0 + h (the solver's own call for "solver")."""
        f, a, b = self.film, self.disk(t0), self.disk(t0 + h)
        if variant == "solver":
            assert f.step(self.q, self.q, a, b, h)
            f.commit_step()  # BDF2's history (numerics.film_scheme 'bdf2'); nothing for the midpoint
            return
        geometry = f._advance_geometry
        x, y, px, py, storage, ih, floor = *geometry[:5], geometry[9], geometry[10]
        kf.fill_spacing(self.q, x, y, px, py, storage, a[None], ih, floor, f.H)
        kf.fill_spacing(self.q, x, y, px, py, storage, b[None], ih, floor, f.H_new)
        if variant == "mid time":
            points = [(self.disk(t0 + 0.5 * h), 1.0)]
        elif variant == "step mean":
            points = [(np.mean([self.disk(t0 + (k + 0.5) * h / 32) for k in range(32)], axis=0), 1.0)]
        elif variant.startswith("gauss"):
            taus, weights = GAUSS[int(variant.split()[1])]
            points = [(self.disk(t0 + tau * h), w) for tau, w in zip(taus, weights, strict=True)]
        elif variant.startswith("theta"):
            theta = float(variant.split()[1])
            points = [((1.0 - theta) * a + theta * b, 1.0)]
        else:
            points = [(0.5 * (a + b), 1.0)]
        weight = theta if variant.startswith("theta") else 0.5
        passes = 2 if variant == "newton 2" else 1
        constants, scratch, cuts = f._kernel_film
        s, c = kf.AbsFilmScratch(*scratch), kf.AbsFilmConstants(*constants)
        parts = (s.R, s.Jcx, s.Jxm, s.Jxp, s.Jcy, s.Jym, s.Jyp)
        ca = f.sigma / h * c.area[None]
        inner = (slice(None), slice(1, -1), slice(1, -1))
        Pn, delta = f.P.copy(), np.zeros_like(f.P)
        for _ in range(passes):
            total = [np.zeros_like(p) for p in parts]
            for disk, w in points:
                self.set_links(disk, False)
                kf.assemble(Pn + 0.5 * delta, f.Hx, f.Hy, f.Hxe, f.Hye, constants, scratch, cuts)
                for acc, part in zip(total, parts, strict=True):
                    acc += w * part
            diag, rhs = np.zeros_like(Pn), np.zeros_like(Pn)
            diag[inner] = (ca * f.H_new)[inner]
            rhs[inner] = -(ca * ((Pn + delta) * f.H_new - Pn * f.H) + total[0])[inner]
            change, work = np.zeros_like(Pn), np.zeros_like(Pn)
            kr.af_solve(diag, *total[1:], rhs, weight, change, work)
            delta += change
        f.P[:] = Pn + delta
        assert np.all(f.P > 0.0)
        self.set_links(b, True)  # what the force reads at the end of the step, as the solver's step leaves it

    def mean_force(self, m: int, variant: str) -> float:
        """Mean air force [N] at the ends of the intervals, each in m steps of ``variant``."""
        self.film.P[:] = self.P0
        self.film.set_history((np.zeros_like(self.P0), 0.0))  # BDF2 starts with backward Euler
        forces = []
        for i in range(INTERVALS):
            for k in range(m):
                self.step(i * INTERVAL + k * INTERVAL / m, INTERVAL / m, variant)
            forces.append(self.film.forces()[0])
        return float(np.mean(forces))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a scene override, e.g. numerics.refine=2 (numbers as numbers)")  # fmt: skip
    args = parser.parse_args(argv)
    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = json.loads(value) if value[:1].isdigit() or value[:1] in "-." else value
    bench = Bench(overrides)
    ends = []
    for variant in ("solver", "plain"):  # the harness's plain step (no variant) is the solver's, to round-off
        bench.film.P[:] = bench.P0
        bench.step(0.0, INTERVAL, variant)
        ends.append(bench.film.P.copy())
    assert np.allclose(*ends, rtol=1e-12, atol=0.0), "the harness's plain step differs from the solver's"
    reference = bench.mean_force(64, "solver")
    print(f"reference: 64 film steps per {INTERVAL * 1e6:.1f} us, mean force {reference * 1e3:.4f} mN")
    print("error of the mean force [uN] at film steps of 0.4, 0.2, 0.1, 0.05 us")
    others = [(name, Bench({**overrides, **more})) for name, more in OTHERS]
    for variant, runner, name in [(v, bench, v) for v in VARIANTS] + [("solver", b, name) for name, b in others]:
        errors = [abs(runner.mean_force(m, variant) - reference) * 1e6 for m in (1, 2, 4, 8)]
        print(f"  {name:10s}  " + "  ".join(f"{e:6.2f}" for e in errors))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
