"""Partial-contact dynamics of an ABS slider over a moving rough track (scene kind "abs").

State q = (z, pitch, roll) about the pivot (:mod:`solver.abs.params`).
Equations of motion

    M q'' + C q' + K (q - q_s) = f_s + f_air(q, t) + f_surface(q, t),

with the suspension's springs K and dampers C acting about the steady
attitude q_s, its preload and static moments f_s = (-F, M_p, M_r), the
film's generalized forces f_air and the surface forces on every cell of
the face: asperity (Greenwood-Williamson) or elastic (influence-coefficient)
contact pressure p_c, adhesion p_a and Coulomb friction mu p_c along the
disk's motion.  With the cell's spacing derivative b = (1, -(x - xp),
-(y - yp)) and the pivot a height t above the face,

    f_surface = sum_cells A [(p_c + p_a) b + mu p_c (0, -t cos psi, -t sin psi)].

Time integration: the generalized-alpha method (Chung & Hulbert 1993), a
Newmark-beta scheme whose equation of motion is balanced between the ends
of the step,

    M [(1 - am) a_n+1 + am a_n] + C [...] + K [...] = (1 - af) f_n+1 + af f_n,
    am = (2 rho - 1)/(rho + 1), af = rho/(rho + 1), gamma = 1/2 - am + af, beta = (1 - am + af)^2 / 4,

second order, with spectral radius rho (``numerics.rho_infinity``) at
infinite frequency: rho = 1 is the trapezoidal (average-acceleration)
Newmark rule.  The asperity contact's rotational modes (MHz, far above any
step we can afford) are stiff and hardening, and the trapezoidal rule
feeds them energy (a free bounce on a smooth disk with no air and no
friction rebounded with 5x its kinetic energy, 11x at dt / 4; 2.7x with
rho = 0.5).  The default rho = 0 annihilates them (the bounce keeps 28-44 %
of its kinetic energy: the rest went into the damped contact modes) at the
price of 2 % algorithmic damping at omega dt = 0.4 (300 kHz at dt = 0.2 us),
0.6 % at 200 kHz and 0.05 % below 80 kHz.  One step
t_n -> t_n+1:

1. predictor q* = q_n + dt v_n + dt^2 a_n / 2; the film is advanced along
   the attitude path it has followed (q*_n -> q*_n+1) with the disk moved
   to t_n+1 (:meth:`solver.abs.film.AbsFilm.step`), giving f_air at t_n+1;
2. Newton's method on a_n+1 with the Newmark relations
   q = q_n + dt v_n + dt^2 ((1/2 - beta) a_n + beta a_n+1),
   v = v_n + dt ((1 - gamma) a_n + gamma a_n+1), the surface forces and
   their exact Jacobian implicit, the film force explicit.

The surface stiffness (asperities: 1e7-1e9 N/m) is far above the film's,
and the implicit treatment keeps the step stable with dt set by the film
and the disk's features, not by the contact.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from solver.abs.dynamics import mass_matrix, static_forces, stiffness_damping
from solver.abs.film import AbsFilm
from solver.abs.forces import SurfaceForces, SurfaceModel
from solver.abs.params import AbsScene
from solver.abs.steady import AbsSteady, element_row, element_spacing, fly_start
from solver.abs.track import Track

log = logging.getLogger(__name__)


#: A step whose Newton solve fails is halved at most this many times (dt / 256).
MAX_HALVINGS = 8


@dataclass
class AbsResult:
    """Time series and summary of one partial-contact run."""

    t: np.ndarray
    q: np.ndarray  # (n, 3)
    v: np.ndarray  # (n, 3)
    series: dict[str, np.ndarray]
    steady: AbsSteady
    status: int
    message: str
    work: dict[str, float] = field(default_factory=dict)


SERIES = {
    "flying_height": ("m", "flying height at the read/write element above the disk mean plane"),
    "clearance": ("m", "smallest spacing of the face to the resolved disk surface"),
    "contact_force": ("N", "normal contact force"),
    "adhesion_force": ("N", "adhesion force (negative: towards the disk)"),
    "friction_force": ("N", "friction force along the disk motion"),
    "air_force": ("N", "air-bearing force"),
    "contact_cells": ("1", "cells within reach of the surface forces"),
}


def simulate_abs(scene: AbsScene, steady: AbsSteady | None = None, profile=None) -> AbsResult:
    """Integrate one run from steady flight over the moving track; never raises for a physical failure.

    status 0: reached t_end; -1: the film or the Newton solve failed (message says where).
    """
    wall0 = time.perf_counter()
    num = scene.numerics
    film = AbsFilm(scene)
    grid = film.grid
    if steady is None:
        steady = fly_start(scene, film)
    else:
        film.set_disk(np.zeros(grid.shape))
        film.solve_steady(steady.q)
    track = Track(scene, grid, profile)
    surface = SurfaceModel(scene, grid)
    M = mass_matrix(scene)
    K, C = stiffness_damping(scene)
    f_static = static_forces(scene)
    q_ref = steady.q.copy()
    dt = num.dt
    rho = num.rho_infinity
    alpha_m, alpha_f = (2.0 * rho - 1.0) / (rho + 1.0), rho / (rho + 1.0)
    gamma = 0.5 - alpha_m + alpha_f
    beta = 0.25 * (1.0 - alpha_m + alpha_f) ** 2
    n_steps = int(round(num.t_end / dt))
    every = num.output_every
    use_air = scene.models.air_bearing == "reynolds"

    q = steady.q.copy()
    v = np.array([scene.initial.zdot, scene.initial.pitch_rate, scene.initial.roll_rate])
    zd, sd = track.at(0.0)
    film.set_disk(zd)
    f_air = film.forces() if use_air else np.zeros(3)
    sf = surface.forces(film.spacing(q), sd)
    a = np.linalg.solve(M, f_static + f_air + sf.f - C @ v - K @ (q - q_ref))
    q_film = q.copy()
    n_out = n_steps // every + 1
    t_out = np.empty(n_out)
    q_out = np.empty((n_out, 3))
    v_out = np.empty((n_out, 3))
    series = {k: np.empty(n_out) for k in SERIES}
    newton_total = 0
    status, message = 0, "reached t_end"
    tol = num.newton_tol * max(scene.suspension.preload, 1e-6)
    weights = np.array([1.0, 1.0 / scene.slider.length, 1.0 / scene.slider.length])

    fh_row = element_row(scene)
    offset_base = grid.surface  # the face's static surface; the disk height is subtracted per step

    def track_zd(zd_nodes: np.ndarray) -> np.ndarray:
        return zd_nodes

    def record(k: int, t: float, sf: SurfaceForces, f_air: np.ndarray, zd: np.ndarray) -> None:
        t_out[k] = t
        q_out[k] = q
        v_out[k] = v
        series["flying_height"][k] = element_spacing(scene, q, fh_row)
        series["clearance"][k] = float(np.min(film.spacing(q)))
        series["contact_force"][k] = sf.contact
        series["adhesion_force"][k] = sf.adhesion
        series["friction_force"][k] = sf.friction
        series["air_force"][k] = f_air[0]
        series["contact_cells"][k] = sf.cells

    record(0, 0.0, sf, f_air, zd)
    k_out = 1
    state = {"q": q, "v": v, "a": a, "q_film": q_film, "zd": zd, "f_air": f_air, "sf": sf}
    counters = {"newton": 0, "substeps": 0, "halvings": 0}

    def advance(t0: float, h: float, depth: int) -> str:
        """Advance ``state`` from t0 by h; on a failed Newton solve, restore the film and take two halves."""
        st = state
        q, v, a = st["q"], st["v"], st["a"]
        t1 = t0 + h
        zd1, sd1 = track.at(t1)
        q_pred = q + h * v + 0.5 * h * h * a
        P_saved = film.P.copy()

        def halve() -> str:
            film.P[:] = P_saved
            film.set_disk(st["zd"])
            counters["halvings"] += 1
            message = advance(t0, 0.5 * h, depth + 1)
            return message or advance(t0 + 0.5 * h, 0.5 * h, depth + 1)

        f_old = st["f_air"] + st["sf"].f
        margin = 2.0e-9 + float(np.abs(h * v + 2.0 * h * h * a) @ np.abs(surface.b).max(axis=1))
        cells = surface.candidates(offset_base - track_zd(zd1), sd1, q, margin)

        def newmark(a_trial: np.ndarray, f_air: np.ndarray):
            q1 = q + h * v + h * h * ((0.5 - beta) * a + beta * a_trial)
            v1 = v + h * ((1.0 - gamma) * a + gamma * a_trial)
            sf = surface.forces_on(cells, q1)
            G = (
                M @ ((1.0 - alpha_m) * a_trial + alpha_m * a)
                + C @ ((1.0 - alpha_f) * v1 + alpha_f * v)
                + K @ ((1.0 - alpha_f) * q1 + alpha_f * q - q_ref)
                - f_static
                - (1.0 - alpha_f) * (f_air + sf.f)
                - alpha_f * f_old
            )
            return q1, v1, sf, G

        # Two passes: the film moves along the predicted path, then again along the corrected one, so that
        # a hard contact (accelerations of 1e5 m/s2) never leaves the film on a path the slider did not take.
        q_path = q_pred
        a_new = a.copy()
        for sweep in range(2):
            f_air = st["f_air"]
            if use_air:
                if sweep:
                    film.P[:] = P_saved
                film.step(q, q_path, st["zd"], zd1, h)
                f_air = film.forces()
                if not (np.all(np.isfinite(f_air)) and np.all(film.P > 0.0)):
                    if depth >= MAX_HALVINGS:
                        return f"film failed (pressure not positive and finite) at t = {t1:.4g} s, dt / 2^{depth}"
                    return halve()
            else:
                film.set_disk(zd1)
            q1, v1, sf, G = newmark(a_new, f_air)
            norm = np.max(np.abs(G * weights))
            for it in range(num.newton_max_iter):
                counters["newton"] += 1
                if norm < tol or norm <= 1e-12 * (np.max(np.abs(sf.f * weights)) + np.max(np.abs(f_air * weights))):
                    break  # converged, absolutely or to round-off of the forces
                Jn = (1.0 - alpha_m) * M + (1.0 - alpha_f) * (gamma * h * C + beta * h * h * (K - sf.dfdq))
                step_a = np.linalg.solve(Jn, G)
                lam = 1.0
                for _ in range(12):  # backtracking: the contact and adhesion laws are steep power laws
                    trial = newmark(a_new - lam * step_a, f_air)
                    trial_norm = np.max(np.abs(trial[3] * weights))
                    if trial_norm < norm or lam < 1e-3:
                        break
                    lam *= 0.5
                a_new = a_new - lam * step_a
                q1, v1, sf, G = trial
                norm = trial_norm
                log.debug("t = %.4g Newton %d: |G| = %.3e (lambda %.3g)", t1, it, norm, lam)
            if norm >= tol and norm > 1e-12 * (np.max(np.abs(sf.f * weights)) + np.max(np.abs(f_air * weights))):
                if depth >= MAX_HALVINGS:
                    return f"Newton did not converge at t = {t1:.4g} s (|G| = {norm:.2e}) with dt / 2^{depth}"
                # A snap (adhesion pulling the pad in, a hard landing) outruns the step: restore, take two halves.
                return halve()
            if not use_air:
                break
            q_path = q1
        counters["substeps"] += 1
        state.update(q=q1, v=v1, a=a_new, q_film=q_path, zd=zd1, f_air=f_air, sf=sf)
        return ""

    n = -1
    for n in range(n_steps):
        t1 = (n + 1) * dt
        message_n = advance(n * dt, dt, 0)
        if message_n:
            status, message = -1, message_n
            break
        q, v = state["q"], state["v"]
        if (n + 1) % every == 0 and k_out < n_out:
            record(k_out, t1, state["sf"], state["f_air"], state["zd"])
            k_out += 1
    newton_total = counters["newton"]
    work = {
        "steps": n + 1 if n_steps else 0,
        "substeps": counters["substeps"],
        "step_halvings": counters["halvings"],
        "newton_iterations": newton_total,
        "reynolds_solves": film.reynolds_solves,
        "nodes": grid.x.size * grid.y.size,
        "wall_time": time.perf_counter() - wall0,
    }
    return AbsResult(
        t=t_out[:k_out],
        q=q_out[:k_out],
        v=v_out[:k_out],
        series={k: s[:k_out] for k, s in series.items()},
        steady=steady,
        status=status,
        message=message,
        work=work,
    )


def spectrum(t: np.ndarray, signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum (Hann window, mean removed): frequencies [Hz], amplitudes [signal units]."""
    n = signal.size
    if n < 4:
        return np.zeros(0), np.zeros(0)
    dt = (t[-1] - t[0]) / (n - 1)
    w = np.hanning(n)
    x = (signal - signal.mean()) * w
    amp = 2.0 * np.abs(np.fft.rfft(x)) / w.sum()
    return np.fft.rfftfreq(n, dt), amp


def summarize(result: AbsResult, scene: AbsScene) -> dict[str, float]:
    """Bouncing 3-sigma, contact measures and spectral peaks after the settling time."""
    num = scene.numerics
    keep = result.t >= num.settle_time - 1e-15
    t = result.t[keep]
    fh = result.series["flying_height"][keep]
    fc = result.series["contact_force"][keep]
    out = {
        "bouncing_3sigma": 3.0 * float(np.std(fh)) if fh.size else float("nan"),
        "mean_flying_height": float(np.mean(fh)) if fh.size else float("nan"),
        "min_clearance": float(np.min(result.series["clearance"][keep])) if fh.size else float("nan"),
        "mean_contact_force": float(np.mean(fc)) if fc.size else float("nan"),
        "max_contact_force": float(np.max(fc)) if fc.size else float("nan"),
        "contact_fraction": float(np.mean(fc > num.contact_threshold)) if fc.size else float("nan"),
        "mean_adhesion_force": float(np.mean(result.series["adhesion_force"][keep])) if fc.size else float("nan"),
        "mean_friction_force": float(np.mean(result.series["friction_force"][keep])) if fc.size else float("nan"),
    }
    for name, signal in (("fh", fh), ("pitch", result.q[keep, 1]), ("roll", result.q[keep, 2])):
        f, amp = spectrum(t, signal)
        out[f"{name}_peak_frequency"] = float(f[1:][np.argmax(amp[1:])]) if f.size > 1 else float("nan")
        out[f"{name}_peak_amplitude"] = float(np.max(amp[1:])) if f.size > 1 else float("nan")
    return out
