"""Display units of text tables and figures: SI values as the field reads them (nm, mN, kHz, urad, us)."""

from __future__ import annotations

import numpy as np


def display_scale(units: str, values: object = None) -> tuple[float, str]:
    """(factor, unit shown) for a quantity in SI ``units``; ``values`` picks the range where it matters.

    Lengths in nm (um from 1 um up), forces in mN, frequencies in kHz, angles in urad, times in us below
    1 ms (with ``values``; else seconds, as wall times are); anything else as it is ("1" for no unit).
    """
    span = 0.0
    if values is not None:
        array = np.abs(np.asarray(values, dtype=float))
        span = float(np.nanmax(array)) if array.size and np.isfinite(array).any() else 0.0
    if units == "m":
        return (1e6, "um") if span >= 1e-6 else (1e9, "nm")
    if units == "N":
        return 1e3, "mN"
    if units == "Hz":
        return 1e-3, "kHz"
    if units == "rad":
        return 1e6, "urad"
    if units == "s" and values is not None and 0.0 < span < 1e-3:
        return 1e6, "us"
    return 1.0, units or "1"
