"""Mass, suspension springs and dampers, and static forces of an "abs" slider about its pivot."""

from __future__ import annotations

import logging

import numpy as np

from solver.abs.params import AbsScene

log = logging.getLogger(__name__)


def mass_matrix(scene: AbsScene) -> np.ndarray:
    """3 x 3 mass matrix of (z, pitch, roll) about the pivot, mass centre at the face's centre."""
    s = scene.slider
    m = s.mass
    dx, dy = 0.5 * s.length - s.pivot_x, 0.0 - s.pivot_y
    return np.array(
        [
            [m, -m * dx, -m * dy],
            [-m * dx, s.pitch_inertia, m * dx * dy],
            [-m * dy, m * dx * dy, s.roll_inertia],
        ]
    )


def stiffness_damping(scene: AbsScene) -> tuple[np.ndarray, np.ndarray]:
    sus = scene.suspension
    K = np.diag([sus.vertical_stiffness, sus.pitch_stiffness, sus.roll_stiffness])
    C = np.diag([sus.vertical_damping, sus.pitch_damping, sus.roll_damping])
    return K, C


def static_forces(scene: AbsScene) -> np.ndarray:
    sus = scene.suspension
    return np.array([-sus.preload, sus.static_pitch_moment, sus.static_roll_moment])
