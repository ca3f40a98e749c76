"""Parameters of scene kind ``"abs"``: a slider with an arbitrary air-bearing surface in partial contact.

Scene 2 of PHYSICS.md (a femto slider with a micro trailing pad).  The same
frozen-dataclass machinery as scene 1 (:mod:`solver.params`): SI units,
ranges and long names written once, validation before any work.

Frame and sign conventions
--------------------------
x runs along the slider from the leading edge (x = 0) to the trailing edge
(x = L), in the direction of the disk's motion at zero skew; y runs across
it from the centre line (-W/2 <= y <= W/2).  The pivot (gimbal dimple) sits
at (pivot_x, pivot_y) on the slider's back, ``thickness`` above the face.
The state is q = (z, pitch, roll): z is the face's height above the disk's
mean plane at the pivot, pitch > 0 lifts the leading edge, roll > 0 lifts
the y < 0 side, so the spacing of a face point is

    h(x, y) = z - (x - pivot_x) pitch - (y - pivot_y) roll + s(x, y) - z_d(x, y, t),

with s the static surface (etch depth, crown, camber, twist) and z_d the
disk's height under the point.  Crown and camber are positive when the
face bulges towards the disk; twist is the height difference of the
corners: s = crown (1 - (2 x'/L)^2)... written relative to the bulge, see
:mod:`solver.abs.face`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from solver.params import Air, ParameterError, Section, check_field, quantity
from solver.slip import SLIP_LAWS

GRAM_FORCE = 9.80665e-3  # N
#: Second entropy word of initial.zdot_spread's generator: a stream apart from the track's default_rng(seed).
KICK_STREAM = 0x6B69636B


@dataclass(frozen=True)
class Region:
    """One etched region of the air-bearing surface: a rectangle or a polygon at an etch depth.

    Coordinates from the leading edge (x) and the centre line (y) [m].
    ``width_from`` names a [slider] key (e.g. "trailing_pad_width") that
    replaces the rectangle's y extent by that width about its centre line.
    """

    name: str
    depth: float
    rect: tuple[float, float, float, float] | None = None
    polygon: tuple[tuple[float, float], ...] | None = None
    width_from: str = ""

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "depth": self.depth}
        if self.rect is not None:
            out["rect"] = list(self.rect)
        if self.polygon is not None:
            out["polygon"] = [list(p) for p in self.polygon]
        if self.width_from:
            out["width_from"] = self.width_from
        return out


REGION_KEYS = {"name", "depth", "rect", "polygon", "width_from"}


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ParameterError(f"{where} = {value!r} has the wrong type: expected a finite number [m]")
    return float(value)


def region_from_dict(data: dict[str, Any], index: int) -> Region:
    where = f"abs.regions[{index}]"
    if not isinstance(data, dict):
        raise ParameterError(f"{where} = {data!r} must be a table with keys {', '.join(sorted(REGION_KEYS))}")
    for key in data:
        if key not in REGION_KEYS:
            raise ParameterError(f"unknown key '{where}.{key}': a region has {', '.join(sorted(REGION_KEYS))}")
    name = data.get("name", f"region {index}")
    if not isinstance(name, str):
        raise ParameterError(f"{where}.name = {name!r} has the wrong type: expected a string")
    if "depth" not in data:
        raise ParameterError(f"{where} ({name!r}) has no depth: give depth [m] below the pad top (0 = pad)")
    depth = _number(data["depth"], f"{where}.depth")
    if depth < 0:
        raise ParameterError(f"{where}.depth = {depth!r} is not allowed: must be >= 0 [m] (etch depth)")
    rect = data.get("rect")
    polygon = data.get("polygon")
    if (rect is None) == (polygon is None):
        raise ParameterError(f"{where} ({name!r}) must have exactly one of rect = [x0, x1, y0, y1] or polygon")
    width_from = data.get("width_from", "")
    if rect is not None:
        if not isinstance(rect, list | tuple) or len(rect) != 4:
            raise ParameterError(f"{where}.rect = {rect!r} is not allowed: must be [x0, x1, y0, y1] [m]")
        x0, x1, y0, y1 = (_number(v, f"{where}.rect") for v in rect)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"{where}.rect = {rect!r} is not allowed: needs x1 > x0 and y1 > y0 [m]")
        return Region(name, depth, rect=(x0, x1, y0, y1), width_from=width_from)
    if width_from:
        raise ParameterError(f"{where}.width_from = {width_from!r} is only allowed with a rect")
    if not isinstance(polygon, list | tuple) or len(polygon) < 3:
        raise ParameterError(f"{where}.polygon = {polygon!r} is not allowed: needs at least 3 [x, y] vertices [m]")
    pts = []
    for k, p in enumerate(polygon):
        if not isinstance(p, list | tuple) or len(p) != 2:
            raise ParameterError(f"{where}.polygon[{k}] = {p!r} is not allowed: must be [x, y] [m]")
        pts.append((_number(p[0], f"{where}.polygon[{k}]"), _number(p[1], f"{where}.polygon[{k}]")))
    return Region(name, depth, polygon=tuple(pts))


@dataclass(frozen=True)
class AbsSlider(Section):
    """A slider body with an arbitrary air-bearing surface (femto form factor by default)."""

    section = "slider"
    length: float = quantity(0.85e-3, "m", "slider length (leading to trailing edge)", symbol="L", lo=0.0, lo_open=True)
    width: float = quantity(0.70e-3, "m", "slider width", symbol="W", lo=0.0, lo_open=True)
    thickness: float = quantity(
        0.23e-3, "m", "slider thickness: pivot height above the face (friction lever)", symbol="t", lo=0.0
    )
    mass: float = quantity(0.58e-6, "kg", "slider mass", symbol="m", lo=0.0, lo_open=True)
    pitch_inertia: float = quantity(
        3.75e-14, "kg m2", "pitch inertia about the pivot", symbol="I_p", lo=0.0, lo_open=True
    )
    roll_inertia: float = quantity(2.6e-14, "kg m2", "roll inertia about the pivot", symbol="I_r", lo=0.0, lo_open=True)
    pivot_x: float = quantity(0.425e-3, "m", "pivot position from the leading edge", symbol="x_p", lo=0.0)
    pivot_y: float = quantity(0.0, "m", "pivot position from the centre line", symbol="y_p")
    crown: float = quantity(18.0e-9, "m", "crown height (bulge along the length)", symbol="c_r")
    camber: float = quantity(2.5e-9, "m", "camber height (bulge across the width)", symbol="c_a")
    twist: float = quantity(0.0, "m", "twist (corner height difference)", symbol="t_w")
    trailing_pad_width: float = quantity(
        100.0e-6,
        "m",
        "width of the trailing pad (regions with width_from = 'trailing_pad_width')",
        lo=0.0,
        lo_open=True,
    )
    element_x: float = quantity(
        0.840e-3, "m", "read/write element (flying-height point) from the leading edge", symbol="x_e", lo=0.0
    )
    element_y: float = quantity(0.0, "m", "read/write element from the centre line", symbol="y_e")

    def __post_init__(self) -> None:
        super().__post_init__()
        for key, value, top in (("pivot_x", self.pivot_x, self.length), ("element_x", self.element_x, self.length)):
            if value > top:
                raise ParameterError(
                    f"slider.{key} = {value!r} is not allowed: must lie on the slider, in [0, {top:g}] [m]"
                )
        for key, value in (("pivot_y", self.pivot_y), ("element_y", self.element_y)):
            if abs(value) > 0.5 * self.width:
                raise ParameterError(
                    f"slider.{key} = {value!r} is not allowed: must be within +-{0.5 * self.width:g} [m]"
                )


@dataclass(frozen=True)
class Abs(Section):
    """The air-bearing surface: etched regions painted in order over a base depth."""

    section = "abs"
    base_depth: float = quantity(1.5e-6, "m", "depth of the face outside every region (the deep cavity)", lo=0.0)
    regions: tuple = field(
        default=(),
        metadata={
            "units": "",
            "long_name": "etched regions",
            "lo": None,
            "hi": None,
            "lo_open": False,
            "hi_open": False,
            "choices": None,
            "symbol": "",
        },
    )
    refine_region: str = quantity("", "", "name of the region around which the grid is refined (empty: none)")

    def __post_init__(self) -> None:
        regions = tuple(r if isinstance(r, Region) else region_from_dict(r, k) for k, r in enumerate(self.regions))
        object.__setattr__(self, "regions", regions)
        for f in dataclasses.fields(self):
            if f.name != "regions":
                check_field(self.section, f, getattr(self, f.name))
        names = [r.name for r in regions]
        if self.refine_region and self.refine_region not in names:
            raise ParameterError(
                f"abs.refine_region = {self.refine_region!r} is not allowed: must name a region "
                f"({', '.join(repr(n) for n in names) or 'there are none'}) or be empty"
            )

    def to_dict(self) -> dict[str, Any]:
        return {
            "base_depth": self.base_depth,
            "regions": [r.to_dict() for r in self.regions],
            "refine_region": self.refine_region,
        }


@dataclass(frozen=True)
class AbsSuspension(Section):
    """Suspension: preload, springs and dampers in vertical, pitch and roll, static moments."""

    section = "suspension"
    preload: float = quantity(0.8 * GRAM_FORCE, "N", "preload (0.8 gram-force)", symbol="F", lo=0.0)
    vertical_stiffness: float = quantity(21.5, "N m-1", "vertical stiffness", symbol="k_z", lo=0.0)
    pitch_stiffness: float = quantity(3.7e-5, "N m rad-1", "pitch stiffness", symbol="k_p", lo=0.0)
    roll_stiffness: float = quantity(4.6e-5, "N m rad-1", "roll stiffness", symbol="k_r", lo=0.0)
    vertical_damping: float = quantity(1.0e-4, "N s m-1", "vertical damping", symbol="c_z", lo=0.0)
    pitch_damping: float = quantity(1.0e-11, "N m s rad-1", "pitch damping", symbol="c_p", lo=0.0)
    roll_damping: float = quantity(1.0e-11, "N m s rad-1", "roll damping", symbol="c_r", lo=0.0)
    static_pitch_moment: float = quantity(0.0, "N m", "static pitch moment (positive lifts the leading edge)")
    static_roll_moment: float = quantity(0.0, "N m", "static roll moment (positive lifts the y < 0 side)")


ACF_SHAPES = ("exponential", "gaussian")


@dataclass(frozen=True)
class AbsDisk(Section):
    """The disk: speed from rpm and radius, skew, and the track profile that moves under the slider."""

    section = "disk"
    rpm: float = quantity(10000.0, "min-1", "disk rotation speed", lo=0.0)
    radius: float = quantity(20.0e-3, "m", "radius of the track", lo=0.0, lo_open=True)
    skew: float = quantity(6.65, "degree", "skew angle of the slider to the track", lo=-30.0, hi=30.0)
    rms: float = quantity(0.2e-9, "m", "RMS roughness of the track profile", symbol="sigma", lo=0.0)
    correlation_length: float = quantity(
        2.0e-6, "m", "correlation length of the synthetic track profile (1/e lag)", symbol="l", lo=0.0, lo_open=True
    )
    acf: str = quantity("exponential", "", "autocorrelation shape of the synthetic profile", choices=ACF_SHAPES)
    seed: int = quantity(1, "1", "random seed of the synthetic profile (and of initial.zdot_spread's draw)", lo=0)
    profile_file: str = quantity("", "", "measured track profile (CSV or netCDF); empty: synthetic")
    profile_spacing: float = quantity(0.25e-6, "m", "sample spacing of the synthetic profile", lo=0.0, lo_open=True)

    @property
    def speed(self) -> float:
        """Disk speed at the track [m/s]: 2 pi r rpm / 60."""
        return 2.0 * math.pi * self.radius * self.rpm / 60.0

    @property
    def velocity(self) -> tuple[float, float]:
        """Disk velocity in the slider frame (along x, along y) [m/s]."""
        psi = math.radians(self.skew)
        return self.speed * math.cos(psi), self.speed * math.sin(psi)


SURFACE_CONTACT_LAWS = ("greenwood_williamson", "elastic", "none")
#: Adhesion laws (:data:`solver.surface.ADHESION_LAWS`, whose names a test checks against these; named here so
#: that reading parameters does not load the kernels): "flat", the Lennard-Jones flat-flat law on the nominal
#: area; "asperity_dmt", a DMT pull on every Greenwood-Williamson summit (2 pi R dgamma at contact).
ADHESION_LAWS = ("flat", "asperity_dmt")


@dataclass(frozen=True)
class SurfaceContact(Section):
    """Asperity or elastic contact, adhesion and friction, acting on every cell of the face."""

    section = "contact"
    mu: float = quantity(0.3, "1", "Coulomb friction coefficient", symbol="mu", lo=0.0)
    delta_gamma: float = quantity(0.008, "J m-2", "surface-energy change (adhesion strength)", symbol="dgamma", lo=0.0)
    equilibrium_spacing: float = quantity(
        0.3e-9,
        "m",
        "intermolecular equilibrium spacing (zero-force spacing of the adhesion law)",
        symbol="eps",
        lo=0.0,
        lo_open=True,
    )
    summit_density: float = quantity(1.0e14, "m-2", "asperity summit density", symbol="eta_s", lo=0.0)
    summit_radius: float = quantity(1.0e-6, "m", "asperity summit radius", symbol="R", lo=0.0, lo_open=True)
    slider_modulus: float = quantity(400.0e9, "Pa", "Young's modulus of the slider (AlTiC)", lo=0.0, lo_open=True)
    slider_poisson: float = quantity(0.23, "1", "Poisson ratio of the slider", lo=0.0, hi=0.5)
    disk_modulus: float = quantity(110.0e9, "Pa", "Young's modulus of the disk", lo=0.0, lo_open=True)
    disk_poisson: float = quantity(0.3, "1", "Poisson ratio of the disk", lo=0.0, hi=0.5)
    damping_ratio: float = quantity(
        0.0,
        "1",
        "contact damping ratio (of a contact on one patch: every contact cell is a Kelvin-Voigt element with a "
        "coefficient proportional to its stiffness, Greenwood-Williamson or elastic; 0: none; measured head-disk "
        "contacts: a few percent)",
        symbol="zeta_c",
        lo=0.0,
        hi=1.0,
    )
    candidate_gap: float = quantity(
        20.0e-9,
        "m",
        "cells closer than this (plus eps and 6 RMS) to the disk feel contact and adhesion (beyond 20 nm the flat "
        "law's adhesion is below 3e-6 of its peak, the asperity_dmt law's, falling like d^-2, below 3e-4)",
        lo=0.0,
        lo_open=True,
    )


@dataclass(frozen=True)
class AbsInitial(Section):
    section = "initial"
    zdot: float = quantity(0.0, "m s-1", "initial vertical velocity from steady flight", symbol="zdot0")
    pitch_rate: float = quantity(0.0, "rad s-1", "initial pitch rate", symbol="th1dot0")
    roll_rate: float = quantity(0.0, "rad s-1", "initial roll rate", symbol="th2dot0")
    zdot_spread: float = quantity(
        0.0,
        "m s-1",
        "spread of the initial vertical velocity (standard deviation of a normal kick added to zdot, drawn from "
        "disk.seed in a stream of its own, the track staying the same): on a smooth disk it makes the seed sample "
        "the initial state, so that a study's realisations of a chaotic response (a pad held down by adhesion) "
        "give it an interval",
        symbol="sigma_zdot0",
        lo=0.0,
    )

    def velocities(self, seed: int) -> np.ndarray:
        """The initial velocities (zdot, pitch rate, roll rate): zdot plus the seed's draw of the spread."""
        kick = 0.0
        if self.zdot_spread > 0.0:
            kick = self.zdot_spread * np.random.default_rng([seed, KICK_STREAM]).standard_normal()
        return np.array([self.zdot + kick, self.pitch_rate, self.roll_rate])


ABS_AIR_BEARINGS = ("reynolds", "none")


@dataclass(frozen=True)
class AbsModels(Section):
    section = "models"
    air_bearing: str = quantity("reynolds", "", "air-bearing model", choices=ABS_AIR_BEARINGS)
    slip: str = quantity("fukui_kaneko", "", "slip law", choices=tuple(SLIP_LAWS))
    contact: str = quantity("greenwood_williamson", "", "contact law", choices=SURFACE_CONTACT_LAWS)
    adhesion: str = quantity(
        "flat",
        "",
        "adhesion law: 'flat' (Lennard-Jones flat-flat law on the nominal area) or 'asperity_dmt' (a DMT pull on "
        "each summit of the contact law, bounded at 2 pi R dgamma per summit at contact)",
        choices=ADHESION_LAWS,
    )
    slip_switch: float = quantity(
        0.3e-9, "m", "films thinner than this use the bounded second-order slip law (fukui_kaneko)", lo=0.0
    )


FILM_COUPLINGS = ("two_pass", "linearized")
#: How a linearized step predicts the attitude path of its film step (numerics.film_predictor).
FILM_PREDICTORS = ("extrapolated", "linear_model", "tangent")
FILM_UPDATES = ("none", "secant")
#: numerics.film_scheme, in the order of solver.kernels.film.SCHEME_*.
FILM_SCHEMES = ("midpoint", "bdf2", "trapezoid")
#: numerics.film_start_flux: where the trapezoid's flux at a step's start comes from.
FILM_START_FLUXES = ("carried", "evaluated")


@dataclass(frozen=True)
class AbsNumerics(Section):
    section = "numerics"
    nx: int = quantity(121, "1", "grid nodes along the slider", lo=11)
    ny: int = quantity(101, "1", "grid nodes across the slider", lo=11)
    refine: float = quantity(
        4.0, "1", "grid spacing ratio outside / inside the refined window around abs.refine_region", lo=1.0, hi=20.0
    )
    refine_nodes: int = quantity(
        3, "1", "fewest nodes across the narrowest dimension of any region (grid-resolution check)", lo=2
    )
    faces: str = quantity(
        "fitted",
        "",
        "how the regions meet the grid: fitted (nodes placed so that region edges along grid lines are "
        "control-volume faces, the rest cut), cut (the plain grid, every edge as cut links in series/parallel "
        "and contact patches) or sampled (depth at node and face centres: steps up to half a cell off, the "
        "scheme before cut cells)",
        choices=("fitted", "cut", "sampled"),
    )
    dt: float = quantity(
        0.1e-6,
        "s",
        "time step (resolves the second pitch mode: 729 kHz, omega dt = 0.46 on chen_bogy2007; hdi fly --modes; "
        "with rho_infinity 0.9, contact_omega_dt 0.5 and film_jacobian_every 50: README, 'Scene 2 benchmark')",
        lo=0.0,
        lo_open=True,
    )
    t_end: float = quantity(1.0e-3, "s", "duration of a run", lo=0.0, lo_open=True)
    settle_time: float = quantity(0.2e-3, "s", "time before the bouncing statistics start", lo=0.0)
    output_interval: float = quantity(
        0.5e-6, "s", "sampling interval of the stored time series (its Nyquist frequency, 1 MHz, is above the modes)",
        lo=0.0,
    )  # fmt: skip
    rho_infinity: float = quantity(
        0.9,
        "1",
        "generalized-alpha spectral radius at infinite frequency (1: trapezoidal Newmark, no numerical damping; "
        "< 1 damps the unresolved contact modes, and adds damping to the resolved ones: hdi fly --modes)",
        lo=0.0,
        hi=1.0,
    )
    contact_omega_dt: float = quantity(
        0.5,
        "1",
        "largest omega_c h of a step, omega_c the frequency of the surface forces' stiffness on the slider "
        "(its largest eigenvalue of M^-1 K): a step of dt is split into 2^j equal substeps (j <= contact_splits) "
        "where the contact needs it, at its start or at a substep's end (then redone finer); 0: fixed steps of dt",
        lo=0.0,
    )
    film_omega_dt: float = quantity(
        0.0,
        "1",
        "largest omega_f h of a step, omega_f^2 the largest |eigenvalue| of M^-1 K_f, K_f the film step's force "
        "derivatives at their last refresh (film_coupling 'linearized'): a step of dt is split into 2^j equal "
        "substeps (j <= contact_splits) where the film is stiffer (a pad near contact); 0: the film does not split "
        "steps",
        lo=0.0,
    )
    film_dt: float = quantity(
        0.0,
        "s",
        "longest film step: a step (or substep) h longer than this advances the film in m = ceil(h / film_dt) equal "
        "steps along the attitude path, linear from q_n to the path's end, over the track sampled at each film "
        "step's ends; the slider's balance is still solved once per step (README, 'The film's own step'); 0: one "
        "film step per step",
        lo=0.0,
    )
    film_scheme: str = quantity(
        "midpoint",
        "",
        "the film's time step: 'midpoint' (linearly implicit midpoint rule, second order), 'bdf2' (linearly "
        "implicit BDF2 over the film's last two steps, second order and L-stable, backward Euler where a step is "
        "longer than the last: its mean film force on a rough track is far closer to the converged one, but its "
        "slider is less damped and lands far more often) or 'trapezoid' (linearly implicit trapezoidal rule: each "
        "flux at the start's or the end's pressure and spacing; the start's as numerics.film_start_flux says) "
        "(README, 'The film's time scheme')",
        choices=FILM_SCHEMES,
    )
    film_start_flux: str = quantity(
        "carried",
        "",
        "the trapezoid's flux residual at a step's start (film_scheme 'trapezoid'): 'carried' (the last accepted "
        "step's end residual, carried to first order to the pressure the step left: no flux evaluation of its own) "
        "or 'evaluated' (evaluated again over the start's pressure and spacing: a second flux evaluation a step) "
        "(README, 'The film's time scheme')",
        choices=FILM_START_FLUXES,
    )
    contact_splits: int = quantity(
        3, "1", "most halvings of dt that contact_omega_dt may ask for (substeps of dt / 2^contact_splits)", lo=0, hi=8
    )
    rho_infinity_contact: float = quantity(
        0.0,
        "1",
        "spectral radius of the substeps whose contact is stiffer than the finest substep resolves (omega_c h > "
        "contact_omega_dt at contact_splits halvings): damps the contact modes the step cannot resolve, which a "
        "near-trapezoidal step feeds (a pad held down by adhesion bounced by tens of nm)",
        lo=0.0,
        hi=1.0,
    )
    newton_tol: float = quantity(
        1.0e-10, "1", "Newton tolerance of the implicit contact solve (force / preload)", lo=0.0, lo_open=True
    )
    film_coupling: str = quantity(
        "linearized",
        "",
        "film-structure coupling of a step: 'two_pass' advances the film along the predicted attitude path, then "
        "again along the corrected one; 'linearized' advances it once and corrects it to the corrected path with "
        "its derivatives (forward differences, refreshed every film_jacobian_every steps)",
        choices=FILM_COUPLINGS,
    )
    film_predictor: str = quantity(
        "tangent",
        "",
        "film_coupling 'linearized': the attitude path the film is advanced along; 'tangent' solves the step's "
        "Newton problem with the film force on its tangent about the present state, f_n + K_f (q - q_n); "
        "'extrapolated' takes the acceleration a_n + h (a_n - a_n-1) / h_n-1 (lets stale derivatives grow the "
        "film's mode on a rough track); 'linear_model' adds the last step's change that K_f does not explain to the "
        "tangent and linearizes the surface forces (a rough track's bouncing about 10 % low at dt 0.1 us): README, "
        "'The film's predictor'",
        choices=FILM_PREDICTORS,
    )
    film_jacobian_every: int = quantity(
        50, "1", "steps between refreshes of the film step's derivatives (film_coupling 'linearized')", lo=1
    )
    film_refresh_gap: float = quantity(
        0.0,
        "m",
        "film_coupling 'linearized': the film step's derivatives are refreshed also when the attitude has moved a "
        "corner of the trailing edge farther than this from where they were last refreshed (the film's stiffness "
        "grows steeply as the trailing pad comes down; README, 'Derivatives refreshed where the pad moves'); 0: "
        "only every film_jacobian_every steps",
        lo=0.0,
    )
    film_update: str = quantity(
        "none",
        "",
        "film_coupling 'linearized': between refreshes, 'secant' corrects the film step's derivatives (S, K_f) by "
        "a rank-one (Broyden) update along the path change of each re-pass (numerics.film_repass), from the two "
        "passes' pressures and forces, and keeps them per step size (refreshed after film_jacobian_every substeps "
        "of a size or film_jacobian_every dt); 'none' keeps them as refreshed, for the current size only",
        choices=FILM_UPDATES,
    )
    film_repass: float = quantity(
        1.0e-10,
        "m",
        "film_coupling 'linearized': the film is advanced again along the corrected path when it moves some corner "
        "of the face farther than this from the predicted one (a hard contact)",
        lo=0.0,
    )
    newton_max_iter: int = quantity(30, "1", "Newton iterations of the implicit contact solve", lo=1)
    film_floor: float = quantity(
        0.3e-9, "m", "smallest film thickness the Reynolds equation sees (cells in contact)", lo=0.0, lo_open=True
    )
    contact_threshold: float = quantity(
        1.0e-6, "N", "contact force above which a sample counts as in contact (contact_fraction)", lo=0.0
    )
    steady_tol: float = quantity(
        1.0e-5,
        "1",
        "steady force balance tolerance (residual / preload; 1e-5 of 0.8 gf moves z by ~1e-14 m)",
        lo=0.0,
        lo_open=True,
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.settle_time >= self.t_end:
            raise ParameterError(
                f"numerics.settle_time = {self.settle_time!r} is not allowed with numerics.t_end = {self.t_end!r}: "
                "must be shorter than the run [s]"
            )
        if self.film_omega_dt > 0.0 and self.contact_omega_dt == 0.0:
            raise ParameterError(
                f"numerics.film_omega_dt = {self.film_omega_dt!r} is not allowed with numerics.contact_omega_dt = 0: "
                "the film splits steps with the contact's substeps (set contact_omega_dt > 0, or film_omega_dt = 0)"
            )
        ratio = self.output_interval / self.dt
        if self.output_interval != 0.0 and (ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio):
            raise ParameterError(
                f"numerics.output_interval = {self.output_interval!r} is not allowed with numerics.dt = {self.dt!r}: "
                "must be 0 (every step) or a whole multiple of dt [s]"
            )

    @property
    def output_every(self) -> int:
        return max(1, round(self.output_interval / self.dt)) if self.output_interval > 0 else 1


ABS_SECTIONS: dict[str, type[Section]] = {
    "slider": AbsSlider,
    "abs": Abs,
    "suspension": AbsSuspension,
    "air": Air,
    "disk": AbsDisk,
    "contact": SurfaceContact,
    "initial": AbsInitial,
    "models": AbsModels,
    "numerics": AbsNumerics,
}


@dataclass(frozen=True)
class AbsScene:
    """A complete scene of kind "abs"."""

    name: str = "abs"
    description: str = ""
    slider: AbsSlider = field(default_factory=AbsSlider)
    abs: Abs = field(default_factory=Abs)
    suspension: AbsSuspension = field(default_factory=AbsSuspension)
    air: Air = field(default_factory=lambda: Air(mean_free_path=65.0e-9))
    disk: AbsDisk = field(default_factory=AbsDisk)
    contact: SurfaceContact = field(default_factory=SurfaceContact)
    initial: AbsInitial = field(default_factory=AbsInitial)
    models: AbsModels = field(default_factory=AbsModels)
    numerics: AbsNumerics = field(default_factory=AbsNumerics)

    kind = "abs"

    def __post_init__(self) -> None:
        if self.contact.damping_ratio > 0.0 and self.models.contact == "none":
            raise ParameterError(
                f"contact.damping_ratio = {self.contact.damping_ratio!r} is not allowed with models.contact = "
                "'none': there is no contact to damp (set it to 0, or choose greenwood_williamson or elastic)"
            )
        lengths = [f.name for f in dataclasses.fields(AbsSlider) if f.metadata.get("units") == "m"]
        for k, region in enumerate(self.abs.regions):
            if region.width_from and region.width_from not in lengths:
                raise ParameterError(
                    f"abs.regions[{k}].width_from = {region.width_from!r} is not allowed: must name a [slider] length "
                    f"({', '.join(lengths)})"
                )

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": "abs", "name": self.name, "description": self.description}
        for name in ABS_SECTIONS:
            out[name] = getattr(self, name).to_dict()
        return out

    def flat(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name in ABS_SECTIONS:
            for key, value in getattr(self, name).to_dict().items():
                if key != "regions":
                    out[f"{name}.{key}"] = value
        return out


SERIES = {
    "flying_height": ("m", "flying height at the read/write element above the disk mean plane"),
    "clearance": ("m", "smallest spacing of the face to the resolved disk surface"),
    "contact_force": ("N", "normal contact force"),
    "adhesion_force": ("N", "adhesion force (negative: towards the disk)"),
    "friction_force": ("N", "friction force along the disk motion"),
    "air_force": ("N", "air-bearing force"),
    "contact_cells": ("1", "cells within reach of the surface forces"),
}
