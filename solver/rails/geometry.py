"""Slider geometry: rails, corners and the spacing h(x1, x2; z, pitch, roll).

    flat:   h = z - x1*th1 - x2*th2
    taper:  h = z - x1*th1 - x2*th2 - (x1 + c)*theta0      (x1 < -c)

Rail 0 is the x2 < 0 rail (corners A front-left, B rear-left), rail 1 the
x2 > 0 rail (corners C front-right, D rear-right).
"""

from __future__ import annotations

import numpy as np

from solver.rails.params import Slider

CORNERS = ("A", "B", "C", "D")


def rail_centres(slider: Slider) -> np.ndarray:
    """x2 of the two rail centre lines [m], rail 0 first (x2 < 0)."""
    offset = 0.5 * slider.width - 0.5 * slider.rail_width
    return np.array([-offset, offset])


def corner_positions(slider: Slider) -> np.ndarray:
    """(4, 2) array of the flat corners' (x1, x2) [m], in the order A, B, C, D."""
    c, d, half = slider.flat_front, slider.flat_rear, 0.5 * slider.width
    return np.array([[-c, -half], [d, -half], [-c, half], [d, half]])


def corner_is_front(slider: Slider) -> np.ndarray:
    """(4,) bool: which corners sit at the taper/flat juncture (A, C)."""
    return np.array([True, False, True, False])


def corner_spacings(q: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Spacing at the flat corners for q = (z, pitch, roll): (4,) [m]."""
    return q[0] - corners[:, 0] * q[1] - corners[:, 1] * q[2]
