"""Scene kind "abs": a slider with an arbitrary air-bearing surface in partial contact with a rough disk."""

from __future__ import annotations

import os

from ..kind import SceneKind
from .params import ABS_SECTIONS, SERIES, AbsScene

#: Keys a run may change and still reuse a steady flight (the steady flight sees the roughness only through
#: its RMS, so the track's realisation and correlation are free; it is static, so the contact damping, which acts
#: on velocities, is free too).
STEADY_FREE = {
    "initial": None,
    "contact": ("damping_ratio",),
    "numerics": ("dt", "t_end", "settle_time", "output_interval", "rho_infinity", "rho_infinity_contact",
                 "contact_omega_dt", "film_omega_dt", "film_refresh_gap", "film_update", "film_dt", "film_scheme",
                 "film_start_flux", "contact_splits", "film_coupling", "film_predictor", "film_jacobian_every",
                 "film_repass", "newton_tol", "newton_max_iter", "contact_threshold"),
    "disk": ("correlation_length", "acf", "seed", "profile_file", "profile_spacing"),
}  # fmt: skip

#: The tiny run that loads every kernel a run uses (warm-up): a femto face with a stepped front pad and a
#: trailing pad on a stepped island (the layout of studies/scenes/chen_bogy2007.toml, without side rails) on a
#: 31 x 25 grid, two steps.
WARM_UP_NUMERICS = {"nx": 31, "ny": 25, "refine": 1.0, "refine_nodes": 2, "dt": 0.2e-6, "t_end": 0.4e-6,
                    "settle_time": 0.0, "output_interval": 0.2e-6}  # fmt: skip
WARM_UP_REGIONS = (
    {"name": "leading step", "depth": 0.15e-6, "rect": [0.0, 0.06e-3, -0.33e-3, 0.33e-3]},
    {"name": "front pad", "depth": 0.0, "rect": [0.06e-3, 0.20e-3, -0.30e-3, 0.30e-3]},
    {"name": "trailing step", "depth": 0.15e-6, "rect": [0.70e-3, 0.80e-3, -0.13e-3, 0.13e-3]},
    {"name": "trailing pad", "depth": 0.0, "rect": [0.745e-3, 0.845e-3, -0.05e-3, 0.05e-3]},
)


def fly_abs(scene: AbsScene, **kwargs):
    """Steady flight (:func:`solver.abs.steady.fly_abs`): an error where there is none."""
    from .steady import fly_abs

    return fly_abs(scene, **kwargs)


def fly_start(scene: AbsScene, **kwargs):
    """The steady flight a run starts from (:func:`solver.abs.steady.fly_start`)."""
    from .steady import fly_start

    return fly_start(scene, **kwargs)


def simulate_abs(scene: AbsScene, steady=None, **inputs):
    """One run over the moving track (:func:`solver.abs.integrate.simulate_abs`)."""
    from .integrate import simulate_abs

    return simulate_abs(scene, steady, **inputs)


def tiny() -> AbsScene:
    """A stepped femto face on 31 x 25 nodes, two steps of 0.2 us."""
    from .params import Abs, AbsNumerics

    return AbsScene(abs=Abs(regions=WARM_UP_REGIONS), numerics=AbsNumerics(**WARM_UP_NUMERICS))


def warm_up() -> None:
    """Load (or compile) the film, slip, surface-force and disk kernels on a tiny run, one thread, and again with the
    film's trapezoidal step (``film_scheme`` "trapezoid", whose kernels BDF2 shares); and the two a flying run does
    not reach: the contact's frequency and the film's secant update (``film_update`` "secant")."""
    import dataclasses

    import numpy as np

    from ..kernels.film import secant_update
    from ..kernels.newmark import contact_frequency_squared

    os.environ["NUMBA_NUM_THREADS"] = "1"
    scene = tiny()
    simulate_abs(scene)
    simulate_abs(dataclasses.replace(scene, numerics=dataclasses.replace(scene.numerics, film_scheme="trapezoid")))
    contact_frequency_squared(np.eye(3), -np.eye(3))
    secant_update(np.zeros((3, 1, 2, 2)), np.ones((1, 2, 2)), np.zeros((1, 2, 2)), np.ones(3), np.ones(3))


KIND = SceneKind(
    name="abs",
    title="arbitrary air-bearing surface in partial contact with a rough disk",
    scene_type=AbsScene,
    sections=ABS_SECTIONS,
    fly=fly_abs,
    start=fly_start,
    simulate=simulate_abs,
    steady_free=STEADY_FREE,
    series=SERIES,
    tiny=tiny,
    seed_key="disk.seed",
    warm_up=warm_up,
)
