"""Datasets of scene kind "abs" (partial contact): steady flight and one run with its time series and spectra."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pipeline.classify import (
    ABS_OUTPUTS,
    ABS_RUN_ONLY_OUTPUTS,
    ABS_SPECTRA_KEPT,
    REGIME_FLAGS,
    STATUS_FLAGS,
    abs_regime,
)
from pipeline.data.netcdf import product_attrs, var
from solver.abs.face import region_loads
from solver.abs.integrate import AbsResult, settled_spectra, summarize
from solver.abs.params import SERIES, AbsScene
from solver.abs.steady import AbsSteady


def steady_variables(steady: AbsSteady, prefix: str = "") -> dict[str, xr.Variable]:
    p = prefix
    return {
        f"{p}z": var(steady.q[0], (), "m", "face height at the pivot above the disk mean plane"),
        f"{p}pitch": var(steady.q[1], (), "rad", "pitch (positive: leading edge up)"),
        f"{p}roll": var(steady.q[2], (), "rad", "roll (positive: y < 0 side up)"),
        f"{p}flying_height": var(steady.element_spacing, (), "m", "flying height at the read/write element"),
        f"{p}min_spacing": var(steady.min_spacing, (), "m", "smallest spacing over the face's pads"),
        f"{p}min_spacing_x": var(steady.min_spacing_x, (), "m", "x of the smallest spacing"),
        f"{p}min_spacing_y": var(steady.min_spacing_y, (), "m", "y of the smallest spacing"),
        f"{p}air_force": var(steady.air_force[0], (), "N", "air-bearing force"),
        f"{p}contact_force": var(steady.surface.contact, (), "N", "contact force (statistical roughness)"),
        f"{p}adhesion_force": var(steady.surface.adhesion, (), "N", "adhesion force"),
    }


def fly_dataset(steady: AbsSteady, scene: AbsScene) -> xr.Dataset:
    """Steady flight: attitude, spacings, forces, the pressure and the etch depth on the grid."""
    data = steady_variables(steady)
    data["pressure"] = var(steady.pressure, ("x", "y"), "Pa", "air-bearing pressure")
    data["depth"] = var(steady.depth, ("x", "y"), "m", "etch depth of the face")
    data["iterations"] = var(steady.iterations, (), "1", "attitude Newton iterations")
    data["reynolds_solves"] = var(steady.reynolds_solves, (), "1", "sparse Reynolds solves")
    data["factorizations"] = var(steady.factorizations, (), "1", "sparse LU factorizations of the steady film")
    data["force_residual"] = var(steady.force_residual, (), "1", "force balance residual / preload")
    data["touchdown_adhesion_force"] = var(steady.touchdown_adhesion, (), "N",
                                           "fold estimate: adhesion force with the face lowered at the steady pitch "
                                           "and roll until its lowest point is at eps")  # fmt: skip
    data["touchdown_lowering"] = var(steady.touchdown_lowering, (), "m", "lowering of the face for the fold estimate")
    data["wall_time"] = var(steady.wall_time, (), "s", "wall time of the steady solve")
    names, loads = region_loads(scene, steady.x, steady.y, steady.pressure)
    data["region_load"] = var(loads[:, 0], ("region",), "N", "air-bearing load carried by the region (node quadrature)")
    data["region_pitch_moment"] = var(loads[:, 1], ("region",), "N m",
                                      "pitch moment of the region's air-bearing load about the pivot")  # fmt: skip
    data["region_roll_moment"] = var(loads[:, 2], ("region",), "N m",
                                     "roll moment of the region's air-bearing load about the pivot")  # fmt: skip
    coords = {
        "x": ("x", steady.x, {"units": "m", "long_name": "position from the leading edge"}),
        "y": ("y", steady.y, {"units": "m", "long_name": "position from the centre line"}),
        "region": ("region", names, {"long_name": "face region (painted in order; the cavity is the rest)"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(product_attrs(f"Steady flight of scene {scene.name}", scene, "fly"))
    if steady.branch:
        ds.attrs["branch"] = f"contact: {steady.branch}"
    return ds


def run_dataset(result: AbsResult, scene: AbsScene) -> xr.Dataset:
    """One partial-contact run: attitude and force histories, spectra, summary, provenance."""
    summary = summarize(result, scene)
    data: dict[str, Any] = {
        "z": var(result.q[:, 0], ("time",), "m", "face height at the pivot"),
        "pitch": var(result.q[:, 1], ("time",), "rad", "pitch (positive: leading edge up)"),
        "roll": var(result.q[:, 2], ("time",), "rad", "roll (positive: y < 0 side up)"),
    }
    for name, (units, long_name) in SERIES.items():
        data[name] = var(result.series[name], ("time",), units, long_name)
    freq, spectra = settled_spectra(result, scene)
    for name, (units, long_name) in ABS_SPECTRA_KEPT.items():
        data[f"{name}_spectrum"] = var(spectra[name], ("frequency",), units, long_name)
    outputs = {**ABS_OUTPUTS, **ABS_RUN_ONLY_OUTPUTS}
    for key, value in summary.items():
        data[key] = var(value, (), outputs[key].units, outputs[key].long_name)
    data["status"] = var(np.int8(result.status), (), "1", "run status", **STATUS_FLAGS)
    regime = abs_regime(summary["contact_fraction"], not result.steady.note)
    data["regime"] = var(np.int8(regime), (), "1", ABS_OUTPUTS["regime"].long_name, **REGIME_FLAGS)
    for key, long_name in (("steps", "time steps"), ("newton_iterations", "Newton iterations of the contact solve"),
                           ("reynolds_solves", "Reynolds solves"), ("nodes", "grid nodes")):  # fmt: skip
        data[key] = var(result.work[key], (), "1", long_name)
    data["wall_time"] = var(result.work["wall_time"], (), "s", "wall time of the run")
    data.update(steady_variables(result.steady, prefix="steady_"))
    coords = {
        "time": ("time", result.t, {"units": "s", "long_name": "time since steady flight"}),
        "frequency": ("frequency", freq, {"units": "Hz", "long_name": "frequency"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(product_attrs(f"Partial-contact dynamics of scene {scene.name}", scene, "run"))
    ds.attrs["status_message"] = result.message
    ds.attrs["steady_note"] = result.steady.note
    ds.attrs["steady_branch"] = result.steady.branch
    ds.attrs["settle_time"] = scene.numerics.settle_time
    return ds


def modes(scene: AbsScene, steady: AbsSteady) -> tuple[list[str], dict[str, xr.Variable]]:
    """The slider's modes on its air bearing (:mod:`solver.abs.modes`): report lines and variables on ``mode``.

    Each mode with the damping ratio the scene's time step adds to it (the generalized-alpha step at
    omega dt, ``numerics.rho_infinity``): where that is not small against the mode's own, a run's
    response in that mode is set by the time step, not by the film.  And the frequency the step runs it
    at (its period error): where a run's spectral peak should sit.
    """
    import math

    from solver.abs.modes import air_bearing_modes, numerical_damping, step_frequency_ratio

    found = air_bearing_modes(scene, steady)
    num = scene.numerics
    added = np.array([numerical_damping(2.0 * math.pi * f * num.dt, num.rho_infinity) for f in found.frequency])
    stepped = found.frequency * np.array(
        [step_frequency_ratio(2.0 * math.pi * f * num.dt, num.rho_infinity) for f in found.frequency]
    )
    lines = [
        f"  modes on the air bearing (linearized about steady flight, {found.nodes} film unknowns; "
        f"the step adds zeta_num and runs the mode at f_step, dt = {num.dt * 1e6:g} us, "
        f"rho_infinity = {num.rho_infinity:g}):",
        "    frequency [kHz]  zeta      zeta_num   f_step [kHz]  shape |z| : |pitch| L : |roll| W   flying height",
    ]
    for f, zeta, z_num, f_step, shape, fh in zip(found.frequency, found.damping_ratio, added, stepped, found.shape,
                                                found.element, strict=True):  # fmt: skip
        lines.append(f"    {f * 1e-3:14.1f}  {zeta:.5f}  {z_num:.2e}  {f_step * 1e-3:12.1f}  {shape[0]:.3f} : "
                     f"{shape[1]:.3f} : {shape[2]:.3f}          {fh:.3f}")  # fmt: skip
    variables = {
        "dof": xr.Variable(("dof",), np.array(["z", "pitch", "roll"])),
        "mode_frequency": var(found.frequency, ("mode",), "Hz", "frequency of the slider's mode on its air bearing"),
        "mode_damping_ratio": var(found.damping_ratio, ("mode",), "1", "modal damping ratio (film and suspension)"),
        "mode_numerical_damping": var(added, ("mode",), "1",
                                      "damping ratio the scene's time step adds (generalized-alpha at omega dt)"),
        "mode_step_frequency": var(stepped, ("mode",), "Hz",
                                   "frequency the scene's time step runs the mode at (generalized-alpha at omega dt)"),
        "mode_shape": var(found.shape, ("mode", "dof"), "1",
                          "spacing amplitudes |z|, |pitch| L, |roll| W, largest 1"),
        "mode_flying_height": var(found.element, ("mode",), "1",
                                  "flying height amplitude at the element, on the scale of mode_shape"),
    }  # fmt: skip
    return lines, variables
