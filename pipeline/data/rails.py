"""Datasets of scene kind "rails": the steady flight and one contact run with its impacts."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pipeline.classify import RAILS_OUTPUTS, STABLE_FLAGS, STATUS_FLAGS, classify_impulses
from pipeline.data.netcdf import product_attrs, var
from solver.rails.geometry import CORNERS
from solver.rails.integrate import Result
from solver.rails.params import SERIES, Scene
from solver.rails.steady import SteadyFlight


def steady_variables(steady: SteadyFlight, prefix: str = "") -> dict[str, xr.Variable]:
    """Scalars of a steady flight (prefix '' for fly files, 'steady_' inside run files)."""
    p = prefix
    sus = steady.suspension
    return {
        f"{p}z": var(steady.z, (), "m", "gimbal height above the asperity base plane"),
        f"{p}pitch": var(steady.pitch, (), "rad", "pitch (positive: leading edge up)"),
        f"{p}roll": var(steady.roll, (), "rad", "roll (positive: x2 < 0 side up)"),
        f"{p}min_spacing": var(steady.min_spacing, (), "m", "minimum spacing over the rails"),
        f"{p}min_spacing_x1": var(steady.min_spacing_x1, (), "m", "x1 of the minimum spacing"),
        f"{p}min_spacing_x2": var(steady.min_spacing_x2, (), "m", "x2 of the minimum spacing"),
        f"{p}load": var(steady.load, (), "N", "air-bearing load Q"),
        f"{p}centre_of_pressure_x1": var(steady.centre_of_pressure[0], (), "m", "centre of pressure x1 (S1)"),
        f"{p}bearing_number": var(
            steady.bearing_number, (), "1", "bearing number 6 eta V L / (p0 h_min^2), L = rail length"
        ),
        f"{p}preload": var(sus.preload, (), "N", "preload in force (after calibration)"),
        f"{p}static_pitch_moment": var(
            sus.static_pitch_moment, (), "N m", "static suspension pitch moment in force (after calibration)"
        ),
        f"{p}static_roll_moment": var(sus.static_roll_moment, (), "N m", "static suspension roll moment in force"),
    }


def fly_dataset(steady: SteadyFlight, scene: Scene, wall_time: float = float("nan")) -> xr.Dataset:
    """Steady flight: attitude, minimum spacing, loads and the pressure field."""
    data = steady_variables(steady)
    data["corner_spacing"] = var(steady.corner_spacings, ("corner",), "m", "spacing at the flat corners")
    nr = steady.pressure.shape[0]
    data["pressure"] = var(steady.pressure, ("rail", "x1", "x2_local"), "Pa", "air-bearing pressure")
    coords = {
        "corner": ("corner", np.array(CORNERS), {"long_name": "flat corner (A front-left .. D rear-right)"}),
        "rail": ("rail", np.arange(nr), {"long_name": "rail (0: x2 < 0, 1: x2 > 0)"}),
        "x1": ("x1", steady.x1, {"units": "m", "long_name": "position along the slider (disk motion direction)"}),
        "x2_local": (
            "x2_local",
            steady.x2[0] - steady.x2[0].mean() if nr else np.zeros(0),
            {"units": "m", "long_name": "position across a rail from its centre line"},
        ),
        "x2": (("rail", "x2_local"), steady.x2, {"units": "m", "long_name": "position across the slider"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds["newton_iterations"] = var(steady.newton_iterations, (), "1", "Newton iterations (steady Reynolds)")
    ds["reynolds_solves"] = var(steady.reynolds_solves, (), "1", "steady Reynolds solves")
    if wall_time == wall_time:
        ds["wall_time"] = var(wall_time, (), "s", "wall time of the steady solve")
    ds.attrs.update(product_attrs(f"Steady flight of scene {scene.name}", scene, "fly"))
    return ds


#: Flags of ``impact_held``.
HELD_FLAGS = {"flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "free held"}


def run_summary(result: Result) -> dict[str, Any]:
    """Plain scalars of one run: classification, status and work (picklable, for studies)."""
    impulses = np.array([i.impulse for i in result.impacts])
    corners = np.array([i.corner for i in result.impacts], dtype=int)
    growth = classify_impulses(impulses, corners, [i.time for i in result.impacts])
    return {**growth.as_dict(), "status": result.status, "message": result.message, **result.work}


def run_dataset(result: Result, scene: Scene) -> xr.Dataset:
    """One run: time series, impacts on their own dimension, classification, provenance."""
    summary = run_summary(result)
    imp = result.impacts
    data: dict[str, xr.Variable] = {
        name: var(values, ("time", "corner")[: values.ndim], *SERIES[name]) for name, values in result.series.items()
    }
    data |= {
        "impact_time": var([i.time for i in imp], ("impact",), "s", "time of impact"),
        "impact_corner": var(
            np.array([i.corner_letter for i in imp], dtype="U1"), ("impact",), "", "corner struck (A, B, C, D)"
        ),
        "impact_impulse": var([i.impulse for i in imp], ("impact",), "N s", "normal impulse q"),
        "impact_approach_before": var(
            [i.approach_before for i in imp], ("impact",), "m s-1", "relative normal approach velocity U + eps V before"
        ),
        "impact_approach_after": var(
            [i.approach_after for i in imp], ("impact",), "m s-1", "relative normal approach velocity U + eps V after"
        ),
        "impact_velocity": var(
            [i.approach_before for i in imp],
            ("impact",),
            "m s-1",
            "normal approach speed U + eps V that enters the impulse and the restitution law (wedging included)",
        ),
        "impact_alpha": var(
            [i.alpha for i in imp],
            ("impact",),
            "1",
            "coefficient of restitution applied (contact.restitution; 0 for a plastic impact of a held corner)",
        ),
        "impact_yield_velocity": var(
            [i.yield_velocity for i in imp],
            ("impact",),
            "m s-1",
            "Thornton's yield velocity of the corner's effective mass (NaN under the constant law)",
        ),
        "impact_held": var(
            np.array([i.held for i in imp], dtype=np.int8),
            ("impact",),
            "1",
            "corner held on the asperities after the impact (chattering rule)",
            **HELD_FLAGS,
        ),
        **{
            name: var(summary[name], (), RAILS_OUTPUTS[name].units, RAILS_OUTPUTS[name].long_name)
            for name in (
                "n_impacts",
                "n_larger_than_first",
                "n_front_corner_impacts",
                "first_impulse",
                "max_impulse_ratio",
            )
        },
        "stable": var(np.int8(summary["stable"]), (), "1", RAILS_OUTPUTS["stable"].long_name, **STABLE_FLAGS),
        "status": var(np.int8(result.status), (), "1", "run status", **STATUS_FLAGS),
        "steps": var(result.work["steps"], (), "1", "time steps taken"),
        "reynolds_solves": var(result.work["reynolds_solves"], (), "1", "time-dependent Reynolds solves"),
        "newton_iterations": var(result.work["newton_iterations"], (), "1", "Newton iterations"),
        "wall_time": var(result.work["wall_time"], (), "s", "wall time of the run"),
    }
    data.update(steady_variables(result.steady, prefix="steady_"))
    coords = {
        "time": ("time", result.t, {"units": "s", "long_name": "time since the disturbance"}),
        "corner": ("corner", np.array(CORNERS), {"long_name": "flat corner (A front-left .. D rear-right)"}),
        "impact": ("impact", np.arange(len(imp)), {"long_name": "impact number"}),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(product_attrs(f"Contact dynamics of scene {scene.name}", scene, "run"))
    ds.attrs["status_message"] = result.message
    return ds
