"""Air-bearing fidelity levels behind one interface, chosen by name (``models.air_bearing``).

``reynolds``     the time-dependent Reynolds film solved on-line
                 (:class:`solver.rails.film.ReynoldsFilm`); squeeze damping,
                 film memory and the nonlinear stiffening near contact are all in.
``quasi_static`` a table of the *steady* film force and moments over
                 (z, pitch, roll), built once per scene and interpolated (the
                 method Benson, Chiang & Talke improved upon): nonlinear
                 stiffness, but no squeeze damping and no film memory.
``linearized``   f = f_s - K (q - q_s) - C q' about steady flight, with the
                 stiffness K and damping C of the film at the slider's lowest
                 natural frequency (from forced harmonic motion of the on-line
                 film): damping in, but the stiffening near contact out.
``none``         no film (zero rails), for free flight and contact-only checks.

Every model has the same interface, used by :func:`solver.rails.integrate.simulate`:

* ``reynolds``: the on-line film, which computes steady flight for all levels;
* ``start(steady)``: prepare a run from steady flight (builds or loads tables);
* ``forces(q, v, out)``: the film's generalized forces now;
* ``advance(s, q, v, acc, f_air, minv, suspension)``: one Verlet step in place,
  returning its Newton iterations (0 for the reduced models);
* ``save()`` / ``restore()``: the film state, for a rejected adaptive step;
* ``work``: counters (Reynolds solves, Newton iterations, ...).

Tables and coefficients are built once and kept in a store (:mod:`solver.store`)
under a key of every input they depend on and the source of the film solver
and kernels: by default in this process's memory; the pipeline passes a store
on disk (``pipeline.run.cache.DiskStore``) through ``make_air_bearing(scene, store=...)``.
The solver itself reads and writes no files.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from solver.jit import kernels_fingerprint, source_fingerprint
from solver.kernels import forcemodels as kf
from solver.rails.dynamics import mass_matrix
from solver.rails.film import ReynoldsFilm, SteadyFilmError
from solver.rails.geometry import corner_positions
from solver.rails.params import Scene
from solver.store import ArrayStore, MemoryStore

log = logging.getLogger(__name__)

#: The Python sources (relative to solver/) a table depends on; every kernel module counts as well.
FILM_SOURCES = ("rails/film.py", "rails/bearings.py", "grid.py", "rails/geometry.py")
#: Where tables go when a caller passes no store: this process's memory.
DEFAULT_STORE = MemoryStore()
#: Table z axis: this fraction of the nodes below steady flight (uniform), the rest above (geometric).
Z_NODES_BELOW = 0.25
#: Bisection for the growth ratio of the z axis above steady flight: its upper bound and the halvings.
MAX_Z_GROWTH = 10.0
Z_GROWTH_BISECTIONS = 200
#: Table nodes whose minimum spacing is below this [m], or this fraction of the asperity height, are
#: extrapolated instead of solved (a run's corners stay above the asperities).
TABLE_FLOOR = 2e-9
TABLE_FLOOR_FRACTION = 0.1
#: Linearized film: amplitude of the forced motion, a fraction of the minimum spacing (over L for the angles).
DRIVE_AMPLITUDE = 0.01


def _film_key(scene: Scene, kind: str, q_s: np.ndarray) -> str:
    """Hash of everything a table or a coefficient set depends on."""
    d = scene.to_dict()
    data = {k: d[k] for k in ("slider", "air", "disk")}
    data["slip"] = d["models"]["slip"]
    data["numerics"] = {k: v for k, v in d["numerics"].items() if k.startswith(("nx", "ny", "cluster", "table_"))}
    data["kind"] = kind
    data["q_s"] = [float(x) for x in q_s]
    here = Path(__file__).parents[1]
    data["code"] = source_fingerprint(here / f for f in FILM_SOURCES)
    data["kernels"] = kernels_fingerprint()
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:24]


def _cached(store: ArrayStore, key: str, build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The arrays stored under ``key``, built (and stored) when the store does not hold them."""
    data = store.get(key)
    if data is None:
        data = build()
        store.put(key, data)
    return data


def two_sided_axis(centre: float, below: float, above: float, n: int) -> np.ndarray:
    """n nodes from centre - below to centre + above with one node at centre.

    Below: uniform; above: geometric growth from the same first step, so a
    long range above stays resolved near the centre.
    """
    n_below = max(2, round(Z_NODES_BELOW * (n - 1)))
    n_above = n - 1 - n_below
    h = below / n_below
    lo = centre - below + h * np.arange(n_below)
    # h (r^n_above - 1) / (r - 1) = above: bisection on r >= 1
    r_lo, r_hi = 1.0, MAX_Z_GROWTH
    for _ in range(Z_GROWTH_BISECTIONS):
        r = 0.5 * (r_lo + r_hi)
        total = h * n_above if r == 1.0 else h * (r**n_above - 1.0) / (r - 1.0)
        r_lo, r_hi = (r, r_hi) if total < above else (r_lo, r)
    steps = h * r ** np.arange(n_above)
    hi = centre + np.cumsum(steps) * (above / steps.sum())
    return np.concatenate([lo, [centre], hi])


def symmetric_axis(centre: float, span: float, n: int, stretch: float = 3.0) -> np.ndarray:
    """n nodes in centre +- span, clustered at the centre (sinh map); a node at the centre when n is odd."""
    s = np.linspace(-1.0, 1.0, n)
    return centre + span * np.sinh(stretch * s) / np.sinh(stretch)


class ReducedBearing:
    """Shared part of the reduced levels: the on-line film for steady flight and set-up, no film state."""

    name = ""

    def __init__(self, scene: Scene, store: ArrayStore | None = None) -> None:
        self.scene = scene
        self.store = DEFAULT_STORE if store is None else store
        self.film = ReynoldsFilm(scene)
        self.work = self.film.work
        self.build_seconds = 0.0

    @property
    def reynolds(self) -> ReynoldsFilm:
        return self.film

    def save(self) -> None:
        """Nothing to keep: the force depends on the attitude (and velocity) only."""

    def restore(self) -> None:
        """Nothing to restore."""


class QuasiStaticTable(ReducedBearing):
    """Steady film force and moments tabulated over (z, pitch, roll), interpolated during a run."""

    name = "quasi_static"

    def __init__(self, scene: Scene, store: ArrayStore | None = None) -> None:
        super().__init__(scene, store)
        self.outside_steps = 0

    def axes(self, q_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = self.scene.numerics
        # the top row must be solvable at every (pitch, roll) of the box: lift it if needed
        corners = corner_positions(self.scene.slider)
        tilt = max(abs(x1) * (abs(q_s[1]) + n.table_pitch_span) + abs(x2) * n.table_roll_span for x1, x2 in corners)
        above = max(n.table_z_above, tilt + 2.0 * self.scene.disk.asperity_height - q_s[0])
        az = two_sided_axis(q_s[0], n.table_z_below, above, n.table_nz)
        ap = symmetric_axis(q_s[1], n.table_pitch_span, n.table_npitch)
        ar = symmetric_axis(0.0, n.table_roll_span, n.table_nroll)
        return az, ap, ar

    def build(self, q_s: np.ndarray) -> dict[str, np.ndarray]:
        """Steady solves at every node (roll >= 0; the rails are mirror images, so roll < 0 is mirrored).

        Nodes whose minimum spacing is below ``floor`` (:data:`TABLE_FLOOR` or
        :data:`TABLE_FLOOR_FRACTION` of the asperity height) cannot touch a run, whose corners stay above the
        asperities; they are filled by linear extrapolation along z.
        """
        t0 = time.perf_counter()
        az, ap, ar = self.axes(q_s)
        nz, npch, nrl = az.size, ap.size, ar.size
        mid = nrl // 2
        table = np.full((nz, npch, nrl, 3), np.nan)
        floor = max(TABLE_FLOOR, TABLE_FLOOR_FRACTION * self.scene.disk.asperity_height)
        film = self.film
        P_top = None
        for j, pitch in enumerate(ap):
            for r in range(mid, nrl):
                P = P_top
                for i in range(nz - 1, -1, -1):
                    q = np.array([az[i], pitch, ar[r]])
                    if film.spacing(q).min() < floor:
                        break
                    try:
                        film.solve_steady(q, P)
                    except SteadyFilmError:
                        break
                    P = film.P.copy()
                    if i == nz - 1:
                        P_top = P
                    table[i, j, r] = film.generalized_forces()
        for j in range(npch):
            for r in range(mid, nrl):
                col = table[:, j, r]
                ok = np.flatnonzero(np.isfinite(col[:, 0]))
                if ok.size == 0:
                    raise SteadyFilmError(
                        f"quasi_static table: no solvable node at pitch {ap[j]:.3g}, roll {ar[r]:.3g}"
                    )
                first = ok[0]
                if first > 0:
                    if ok.size > 1:
                        slope = (col[ok[1]] - col[first]) / (az[ok[1]] - az[first])
                    else:
                        slope = np.zeros(3)
                    col[:first] = col[first] + (az[:first, None] - az[first]) * slope
        mirror = np.array([1.0, 1.0, -1.0])
        for r in range(mid):
            table[:, :, r] = table[:, :, nrl - 1 - r] * mirror
        table[:, :, mid, 2] = 0.0
        self.build_seconds = time.perf_counter() - t0
        log.info("quasi_static table %dx%dx%d built in %.1f s", nz, npch, nrl, self.build_seconds)
        return {"table": table, "az": az, "ap": ap, "ar": ar, "build_seconds": np.array(self.build_seconds)}

    def start(self, steady) -> None:
        q_s = steady.q
        data = _cached(self.store, _film_key(self.scene, self.name, q_s), lambda: self.build(q_s))
        self.table, self.az, self.ap, self.ar = data["table"], data["az"], data["ap"], data["ar"]
        self.build_seconds = float(data["build_seconds"])

    def forces(self, q: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:
        kf.table_forces(q, self.table, self.az, self.ap, self.ar, out)

    def advance(self, s, q, v, acc, f_air, minv, suspension) -> int:
        self.outside_steps += kf.verlet_step_table(
            s, q, v, acc, f_air, minv, suspension, self.table, self.az, self.ap, self.ar
        )
        return 0


class LinearizedBearing(ReducedBearing):
    """Stiffness and damping of the film about steady flight: f = f_s - K (q - q_s) - C q'."""

    name = "linearized"

    def coefficients(self, q_s: np.ndarray, periods: int = 3, steps_per_period: int = 200) -> dict[str, np.ndarray]:
        """K from central differences of steady solves; K and C at the lowest natural frequency.

        The static K gives the slider's natural frequencies with its mass
        matrix; the film is then driven harmonically in each coordinate at
        the lowest one (amplitude :data:`DRIVE_AMPLITUDE` of the minimum spacing) and the force
        over the last ``periods - 1`` periods is fitted to -K dq - C dq'.
        """
        t0 = time.perf_counter()
        film = self.film
        film.solve_steady(q_s)
        P_s = film.P.copy()
        f_s = film.generalized_forces()
        h_min = film.spacing(q_s).min()
        L = film.length
        amp = np.array([DRIVE_AMPLITUDE * h_min, DRIVE_AMPLITUDE * h_min / L, DRIVE_AMPLITUDE * h_min / L])
        K_static = np.empty((3, 3))
        for j in range(3):
            dq = np.zeros(3)
            dq[j] = amp[j]
            film.solve_steady(q_s + dq, P_s)
            f_plus = film.generalized_forces()
            film.solve_steady(q_s - dq, P_s)
            f_minus = film.generalized_forces()
            K_static[:, j] = -(f_plus - f_minus) / (2.0 * amp[j])
        M = mass_matrix(self.scene.slider)
        eig = np.linalg.eigvals(np.linalg.solve(M, K_static)).real
        omega = float(np.sqrt(eig[eig > 0].min()))
        period = 2.0 * np.pi / omega
        dt = period / steps_per_period
        K = np.empty((3, 3))
        C = np.empty((3, 3))
        n_steps = periods * steps_per_period
        times = dt * np.arange(1, n_steps + 1)
        fit = times > period
        basis = np.column_stack([np.sin(omega * times[fit]), np.cos(omega * times[fit])])
        for j in range(3):
            film.P = P_s.copy()
            forces = np.empty((n_steps, 3))
            q_old = q_s.copy()
            for k, t in enumerate(times):
                q_new = q_s.copy()
                q_new[j] += amp[j] * np.sin(omega * t)
                film.step(q_old, q_new, dt)
                forces[k] = film.generalized_forces()
                q_old = q_new
            coef, *_ = np.linalg.lstsq(basis, forces[fit] - f_s, rcond=None)
            K[:, j] = -coef[0] / amp[j]
            C[:, j] = -coef[1] / (amp[j] * omega)
        film.P = P_s
        self.build_seconds = time.perf_counter() - t0
        return {
            "K": K,
            "C": C,
            "K_static": K_static,
            "f_s": f_s,
            "q_s": np.asarray(q_s, dtype=float),
            "omega": np.array(omega),
            "build_seconds": np.array(self.build_seconds),
        }

    def start(self, steady) -> None:
        q_s = steady.q
        data = _cached(self.store, _film_key(self.scene, self.name, q_s), lambda: self.coefficients(q_s))
        self.K, self.C, self.f_s, self.q_s = data["K"], data["C"], data["f_s"], data["q_s"]
        self.K_static = data["K_static"]
        self.omega = float(data["omega"])
        self.build_seconds = float(data["build_seconds"])

    def forces(self, q: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:
        kf.linear_forces(q, v, self.f_s, self.q_s, self.K, self.C, out)

    def advance(self, s, q, v, acc, f_air, minv, suspension) -> int:
        return kf.verlet_step_linear(s, q, v, acc, f_air, minv, suspension, self.f_s, self.q_s, self.K, self.C)


AIR_BEARINGS = {
    "reynolds": ReynoldsFilm,
    "none": ReynoldsFilm,
    "quasi_static": QuasiStaticTable,
    "linearized": LinearizedBearing,
}


def make_air_bearing(scene: Scene, store: ArrayStore | None = None):
    """The air-bearing model named by ``scene.models.air_bearing``.

    ``store`` keeps the reduced models' tables and coefficients (:mod:`solver.store`; None: this process's
    memory, :data:`DEFAULT_STORE`); the on-line film has none.
    """
    model = AIR_BEARINGS[scene.models.air_bearing]
    return model(scene, store) if issubclass(model, ReducedBearing) else model(scene)
