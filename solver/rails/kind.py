"""Scene kind "rails": Benson, Chiang & Talke (1989), a taper-flat slider with impacts at the rail corners."""

from __future__ import annotations

import os

import numpy as np

from ..kind import SceneKind
from .params import SECTIONS, SERIES, Scene

#: Keys a run may change and still reuse a steady flight: the disturbance, the contact law and the stepping.
STEADY_FREE = {
    "contact": None,
    "initial": None,
    "numerics": ("dt", "t_end", "output_interval", "newton_max_iter", "newton_tol"),
}

#: The tiny scene that loads every kernel a run uses (warm-up): 21 x 5 nodes, three steps.
WARM_UP_NUMERICS = {"nx": 21, "nx_taper": 5, "ny": 5, "dt": 1e-7, "t_end": 3e-7, "output_interval": 1e-7}


def fly(scene: Scene, **kwargs):
    """Steady flight (:func:`solver.rails.steady.fly`)."""
    from .steady import fly

    return fly(scene, **kwargs)


def simulate(scene: Scene, steady=None, **inputs):
    """One run from steady flight (:func:`solver.rails.integrate.simulate`)."""
    from .integrate import simulate

    return simulate(scene, steady, **inputs)


def tiny() -> Scene:
    """The source's scene on 21 x 5 nodes per rail, three steps of 0.1 us."""
    from .params import Numerics

    return Scene(numerics=Numerics(**WARM_UP_NUMERICS))


def warm_up() -> None:
    """Load (or compile) the film, motion and reduced air-bearing kernels on a tiny scene, one thread."""
    from ..kernels import forcemodels as kf

    os.environ["NUMBA_NUM_THREADS"] = "1"
    simulate(tiny())
    axis = np.linspace(0.0, 1.0, 4)
    q, v, acc, f = np.full(3, 0.5), np.zeros(3), np.zeros(3), np.zeros(3)
    eye, sus = np.eye(3), np.zeros(5)
    kf.verlet_step_table(1e-9, q, v, acc, f, eye, sus, np.zeros((4, 4, 4, 3)), axis, axis, axis)
    kf.verlet_step_linear(1e-9, q, v, acc, f, eye, sus, np.zeros(3), np.zeros(3), eye, eye)


KIND = SceneKind(
    name="rails",
    title="taper-flat slider on two rails with impacts at the rail corners (Benson, Chiang & Talke 1989)",
    scene_type=Scene,
    sections=SECTIONS,
    fly=fly,
    start=fly,
    simulate=simulate,
    steady_free=STEADY_FREE,
    series=SERIES,
    tiny=tiny,
    seed_key=None,
    warm_up=warm_up,
)
