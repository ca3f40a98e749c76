"""Rigid-body motion of the slider in (z, pitch, roll).

Kinetic energy with the mass centre at x1 = -a (its height z + a th1):

    T = m z'^2 / 2 + m a z' th1' + I1 th1'^2 / 2 + I2 th2'^2 / 2,

so the mass matrix is M = [[m, m a, 0], [m a, I1, 0], [0, 0, I2]] with I1
about the gimbal.  Generalized forces (virtual work with h = z - x1 th1 -
x2 th2): film (Q, -S1 Q, -S2 Q); preload (-F, 0, 0); suspension moments
(0, M1 - k1 th1, M2 - k2 th2).  Equations of motion: M q'' = f_film + f_susp.
"""

from __future__ import annotations

import numpy as np

from solver.rails.params import Slider, Suspension


def mass_matrix(slider: Slider) -> np.ndarray:
    """3 x 3 mass matrix of (z, pitch, roll) [kg, kg m, kg m2]."""
    m, a = slider.mass, slider.cg_offset
    return np.array([[m, m * a, 0.0], [m * a, slider.pitch_inertia, 0.0], [0.0, 0.0, slider.roll_inertia]])


def suspension_forces(suspension: Suspension, q: np.ndarray) -> np.ndarray:
    """Generalized forces of preload and gimbal on (z, pitch, roll) [N, N m, N m]."""
    return np.array(
        [
            -suspension.preload,
            suspension.static_pitch_moment - suspension.pitch_stiffness * q[1],
            suspension.static_roll_moment - suspension.roll_stiffness * q[2],
        ]
    )


def kinetic_energy(slider: Slider, v: np.ndarray) -> float:
    """Kinetic energy [J] of generalized velocities v = (z', pitch', roll')."""
    return 0.5 * float(v @ mass_matrix(slider) @ v)


def momentum(slider: Slider, v: np.ndarray) -> np.ndarray:
    """Generalized momenta M v: vertical momentum [kg m/s], angular momenta about the gimbal [kg m2/s]."""
    return mass_matrix(slider) @ v
