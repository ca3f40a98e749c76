"""Shared scenes and helpers for the physics tests.

The scene-1 checks run on a small grid (61 x 9 nodes per rail) so that the
whole suite stays fast; the published comparisons use the 1-D inclined
slider, whose grids are cheap enough to run several resolutions and fit the
observed order.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from solver.abs.face import abs_grid
from solver.abs.forces import SurfaceForces
from solver.abs.params import AbsScene
from solver.abs.steady import AbsSteady
from solver.grid import control_volume_widths
from solver.kinds import scene_from_dict
from solver.rails.params import Calibration, Contact, Disk, Initial, Models, Numerics, Scene, Slider

EPS = np.finfo(float).eps

#: Scene-1 steady attitude of the source (z [m], pitch [rad], roll [rad]).
SCENE1_ATTITUDE = np.array([0.115e-6, 13.5e-6, 0.0])

#: Taper length that reproduces the source's steady state (not in the source).
TAPER_LENGTH = 0.4e-3

SMALL_GRID = {"nx": 61, "nx_taper": 11, "ny": 9}


def thornton_e(speed, yield_velocity):
    """Thornton's e_T (J. Appl. Mech. 64:383, 1997) as written in ../shared/SCENE2-NOTES.md section 6, with
    r = V_y / V capped at 1 (elastic below V_y): the tests' own copy of the closed form."""
    r = np.minimum(np.asarray(yield_velocity, dtype=float) / np.asarray(speed, dtype=float), 1.0)
    return (6 * np.sqrt(3) / 5) ** 0.5 * (1 - r**2 / 6) ** 0.5 * (r / (r + 2 * (6 / 5 - r**2 / 5) ** 0.5)) ** 0.25


def small_scene(**sections) -> Scene:
    """Scene 1 with the documented taper length on the small grid; ``sections`` replace whole sections."""
    numerics = sections.pop("numerics", Numerics(**SMALL_GRID))
    slider = sections.pop("slider", Slider(taper_length=TAPER_LENGTH))
    return Scene(slider=slider, numerics=numerics, **sections)


@pytest.fixture(scope="session")
def scene1() -> Scene:
    return small_scene()


def rigid_scene(
    *, t_end: float, alpha: float = 0.5, max_impacts: int = 2000, rest_velocity: float = 1e-4, **numerics
) -> Scene:
    """No film, no disk motion, no pitch/roll coupling: the slider is a point mass on four corners.

    Pitch and roll inertias of 1e12 kg m^2 make the spin an impact gives
    (x * impulse / I ~ 1e-21 rad/s) far below round-off, so the vertical
    motion is the bouncing point mass of the textbook.
    """
    return Scene(
        models=Models(air_bearing="none"),
        initial=Initial(zdot=0.0, pitch_rate=0.0, roll_rate=0.0),
        slider=Slider(taper_length=TAPER_LENGTH, cg_offset=0.0, pitch_inertia=1e12, roll_inertia=1e12),
        disk=Disk(speed=0.0),
        calibration=Calibration(pitch=0.0),
        contact=Contact(alpha=alpha, mu=0.0, max_impacts=max_impacts, rest_velocity=rest_velocity),
        numerics=Numerics(t_end=t_end, nx=41, nx_taper=11, ny=5, **numerics),
    )


def with_preload(steady, preload: float):
    """A steady state whose suspension pushes with ``preload`` [N] (the film-free scenes have none)."""
    return dataclasses.replace(steady, suspension=dataclasses.replace(steady.suspension, preload=preload))


def inclined_slider_arrays(x: np.ndarray, K: float):
    """Scaled spacing H = K - (K - 1) X of an inclined slider on nodes x, one rail, three columns.

    Returns H, Hx, Hy, dx, dy, dxc, dyc for ``y = [0, 0.5, 1]`` (only the
    middle column is unknown; use ``y_flux=False`` for an infinitely wide
    bearing).
    """
    y = np.array([0.0, 0.5, 1.0])
    xf = 0.5 * (x[1:] + x[:-1])
    nodes = K - (K - 1.0) * x
    faces = K - (K - 1.0) * xf
    H = np.repeat(nodes[None, :, None], 3, axis=2)
    Hx = np.repeat(faces[None, :, None], 3, axis=2)
    Hy = np.repeat(nodes[None, :, None], 2, axis=2)
    return H, Hx, Hy, np.diff(x), np.diff(y), control_volume_widths(x), control_volume_widths(y)


def cf_errors(path) -> list[str]:
    """The errors the IOOS compliance checker (CF-1.8) finds in a netCDF file, as 'section: message' lines.

    Errors are the failed high-priority checks, what ``compliance-checker --test cf:1.8`` lists under
    "Errors"; an exception inside the checker (as a string-valued coordinate variable causes) counts too.
    """
    import contextlib
    import io
    import json
    import tempfile

    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    with tempfile.TemporaryDirectory() as tmp:
        report = f"{tmp}/report.json"
        said = io.StringIO()
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            ComplianceChecker.run_checker(
                str(path), ["cf:1.8"], 0, "normal", output_filename=report, output_format="json"
            )
        with open(report) as f:
            result = json.load(f)["cf:1.8"]
    failed = [c for c in result["high_priorities"] if c["value"][0] < c["value"][1]]
    errors = [f"{c['name']}: {m}" for c in failed for m in c["msgs"]]
    if "exceptions occurred" in said.getvalue():
        errors.append(said.getvalue().strip())
    return errors


#: The default scene-2 file.
SCENE2_FILE = Path(__file__).resolve().parents[1] / "studies" / "scenes" / "chen_bogy2007.toml"


def chen_bogy(overrides: dict | None = None):
    """chen_bogy2007 with dotted-key overrides ("numerics.nx": 41) applied to its TOML tables."""
    import tomllib

    data = tomllib.loads(SCENE2_FILE.read_text())
    for key, value in (overrides or {}).items():
        section, _, name = key.partition(".")
        data.setdefault(section, {})[name] = value
    return scene_from_dict(data, source=str(SCENE2_FILE))


# scene 2 (kind "abs"): a run started from a chosen attitude, and the free drop of a flat face --------------------

#: chen_bogy2007's face [m].
LENGTH, WIDTH = 0.85e-3, 0.70e-3


def start_at(scene: AbsScene, q) -> AbsSteady:
    """A run start at attitude q (z, pitch, roll) [m, rad, rad]; only ``q`` is used by simulate_abs."""
    grid = abs_grid(scene)
    zero = np.zeros(3)
    return AbsSteady(
        q=np.asarray(q, dtype=float),
        element_spacing=math.nan,
        min_spacing=math.nan,
        min_spacing_x=math.nan,
        min_spacing_y=math.nan,
        air_force=zero,
        surface=SurfaceForces(zero, np.zeros((3, 3)), 0.0, 0.0, 0.0, 0),
        pressure=np.full(grid.shape, scene.air.ambient_pressure),
        x=grid.x,
        y=grid.y,
        depth=grid.depth,
        iterations=0,
        reynolds_solves=0,
        force_residual=0.0,
        wall_time=0.0,
    )


def drop_scene(dt: float, *, mu: float = 0.0, rho: float | None = None, t_end: float = 10e-6) -> AbsScene:
    """A flat slider with no air bearing, no suspension, no adhesion falling at 1 mm/s onto a smooth disk.

    The summit density 3.07e8 m^-2 makes the wall soft enough (k = 2.3e10
    N/m^1.5 over the face) that the impact penetrates 1 nm and lasts 2.9 us:
    15 steps of 0.2 us.  ``rho``: numerics.rho_infinity (None: the default).  Fixed steps (no contact substeps):
    every step is a sample, so the discrete balances hold sample by sample.
    """
    numerics = {"nx": 21, "ny": 21, "dt": dt, "t_end": t_end, "settle_time": 0.0, "output_interval": dt,
                "contact_omega_dt": 0.0}  # fmt: skip
    if rho is not None:
        numerics["rho_infinity"] = rho
    data = {
        "kind": "abs",
        "slider": {"crown": 0.0, "camber": 0.0},
        "abs": {
            "base_depth": 0.0,
            "refine_region": "",
            "regions": [{"name": "face", "depth": 0.0, "rect": [0.0, LENGTH, -0.5 * WIDTH, 0.5 * WIDTH]}],
        },
        "suspension": {
            "preload": 0.0,
            "vertical_stiffness": 0.0,
            "pitch_stiffness": 0.0,
            "roll_stiffness": 0.0,
            "vertical_damping": 0.0,
            "pitch_damping": 0.0,
            "roll_damping": 0.0,
        },
        "disk": {"rms": 0.0},
        "contact": {"mu": mu, "delta_gamma": 0.0, "summit_density": 3.07e8},
        "models": {"air_bearing": "none"},
        "initial": {"zdot": -1e-3},
        "numerics": numerics,
    }
    return scene_from_dict(data)


def bench_script(name: str):
    """A script of bench/ (not a package) loaded as a module by its path: ``bench_script("statistics_grid")``."""
    path = Path(__file__).resolve().parents[1] / "bench" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
