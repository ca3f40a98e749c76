"""Parameters of scene kind "rails" (Benson, Chiang & Talke 1989): frozen dataclasses in SI units.

Sign conventions (scene 1, Benson, Chiang & Talke 1989)
--------------------------------------------------------
x1 runs along the slider in the direction of disk motion (leading edge at
negative x1), x2 across it, origin under the gimbal.  ``z`` is the gimbal's
height above the asperity base plane, ``pitch`` (th1) is positive when the
leading edge is up and ``roll`` (th2) is positive when the x2 < 0 side is up:

    h(x1, x2) = z - x1*th1 - x2*th2            (flat)
    h(x1, x2) = z - x1*th1 - x2*th2 - (x1 + c)*theta0   (taper, x1 < -c)

Suspension moments are generalized forces in these coordinates:
pitch moment = static_pitch_moment - pitch_stiffness*th1 (positive lifts the
leading edge), roll moment = static_roll_moment - roll_stiffness*th2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..params import Air, ParameterError, Section, quantity
from ..slip import POLYNOMIAL_SLIP_LAWS


@dataclass(frozen=True)
class Slider(Section):
    """Two-rail taper-flat slider (source Table 1)."""

    section = "slider"
    width: float = quantity(3.2e-3, "m", "slider width", symbol="w", lo=0.0, lo_open=True)
    rail_width: float = quantity(0.686e-3, "m", "rail width", symbol="b", lo=0.0, lo_open=True)
    flat_front: float = quantity(1.788e-3, "m", "gimbal to taper/flat juncture", symbol="c", lo=0.0, lo_open=True)
    flat_rear: float = quantity(1.0e-3 * 0.382, "m", "gimbal to trailing edge", symbol="d", lo=0.0, lo_open=True)
    taper_length: float = quantity(
        0.5e-3,
        "m",
        "taper length along the slider (not in the source)",
        symbol="c0",
        lo=0.0,
        lo_open=True,
    )
    taper_angle: float = quantity(0.0145, "rad", "taper angle", symbol="theta0", lo=0.0, hi=0.2, lo_open=True)
    mass: float = quantity(0.071e-3, "kg", "slider mass", symbol="m", lo=0.0, lo_open=True)
    pitch_inertia: float = quantity(
        0.143e-9, "kg m2", "pitch inertia about the gimbal", symbol="I1", lo=0.0, lo_open=True
    )
    roll_inertia: float = quantity(0.074e-9, "kg m2", "roll inertia", symbol="I2", lo=0.0, lo_open=True)
    cg_offset: float = quantity(0.028e-3, "m", "mass centre ahead of the gimbal (mass centre at x1 = -a)", symbol="a")
    friction_lever: float = quantity(
        1.0e-3, "m", "gimbal height above the disk surface (friction lever arm)", symbol="e", lo=0.0
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.rail_width > self.width / 2:
            raise ParameterError(
                f"slider.rail_width = {self.rail_width!r} is not allowed: must be <= slider.width/2 "
                f"= {self.width / 2:g} [m] (two rails at the outer edges)"
            )
        det = self.mass * self.pitch_inertia - (self.mass * self.cg_offset) ** 2
        if det <= 0:
            raise ParameterError(
                f"slider.pitch_inertia = {self.pitch_inertia!r} is not allowed: must exceed "
                f"mass*cg_offset^2 = {self.mass * self.cg_offset**2:g} [kg m2] "
                "(inertia about the gimbal includes the mass-centre offset)"
            )

    @property
    def length(self) -> float:
        """Rail length c0 + c + d [m]."""
        return self.taper_length + self.flat_front + self.flat_rear


@dataclass(frozen=True)
class Suspension(Section):
    """Preload and gimbal moments (the source gives no gimbal stiffness)."""

    section = "suspension"
    preload: float = quantity(0.0932, "N", "preload through the gimbal", symbol="F", lo=0.0)
    pitch_stiffness: float = quantity(0.0, "N m rad-1", "gimbal pitch stiffness", symbol="k1", lo=0.0)
    roll_stiffness: float = quantity(0.0, "N m rad-1", "gimbal roll stiffness", symbol="k2", lo=0.0)
    static_pitch_moment: float = quantity(
        0.0, "N m", "static suspension pitch moment (positive lifts the leading edge)", symbol="M1"
    )
    static_roll_moment: float = quantity(0.0, "N m", "static suspension roll moment", symbol="M2")


@dataclass(frozen=True)
class Disk(Section):
    section = "disk"
    speed: float = quantity(2.0, "m s-1", "disk speed under the slider", symbol="V", lo=0.0)
    asperity_height: float = quantity(0.050e-6, "m", "asperity height above the base plane", symbol="h0", lo=0.0)


#: Restitution laws (``contact.restitution``), implemented in :mod:`solver.rails.restitution`.
RESTITUTION_MODELS = ("constant", "thornton")


@dataclass(frozen=True)
class Contact(Section):
    """Impacts at the rail corners: friction, restitution and its law, the contact's size and materials.

    ``restitution = "thornton"`` applies alpha times Thornton's e_T(V / V_y) (:mod:`solver.rails.restitution`):
    alpha is then the coefficient of an elastic impact.  ``corner_radius``, ``contact_modulus`` and
    ``yield_pressure`` set V_y and are used by that law only.
    """

    section = "contact"
    mu: float = quantity(0.5, "1", "Coulomb friction coefficient", symbol="mu", lo=0.0)
    alpha: float = quantity(0.8, "1", "coefficient of restitution", symbol="alpha", lo=0.0, hi=1.0)
    wedging: bool = quantity(True, "1", "include the wedging term eps*V in the approach velocity")
    max_impacts: int = quantity(2000, "1", "stop a run after this many impacts", lo=1)
    rest_velocity: float = quantity(
        1.0e-4,
        "m s-1",
        "chattering rule: a corner pressed onto the asperities that rebounds slower than this stays in "
        "sustained contact (0 = never)",
        lo=0.0,
    )
    restitution: str = quantity(
        "constant",
        "",
        "restitution law: constant alpha, or alpha times Thornton's elastic-plastic e_T(V / V_y)",
        choices=RESTITUTION_MODELS,
    )
    corner_radius: float = quantity(
        10.0e-6,
        "m",
        "radius of the contact where a corner meets an asperity (thornton law)",
        symbol="R",
        lo=0.0,
        lo_open=True,
    )
    contact_modulus: float = quantity(
        94.0e9, "Pa", "composite modulus E* of slider and disk (thornton law)", symbol="E*", lo=0.0, lo_open=True
    )
    yield_pressure: float = quantity(
        3.2e9, "Pa", "limiting contact pressure p_y (thornton law)", symbol="p_y", lo=0.0, lo_open=True
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        # Hertz's contact radius at yield is a_y = pi p_y R / (2 E*): a pressure at or above 2 E* / pi would need a
        # contact wider than the corner (and a strain of order 1), outside the theory the law rests on.
        limit = 2.0 * self.contact_modulus / math.pi
        if self.restitution == "thornton" and self.yield_pressure >= limit:
            raise ParameterError(
                f"contact.yield_pressure = {self.yield_pressure!r} is not allowed with contact.contact_modulus = "
                f"{self.contact_modulus!r}: must be < 2 E*/pi = {limit:g} [Pa] (the contact radius at yield, "
                "pi p_y R / (2 E*), must stay below the corner radius R)"
            )


@dataclass(frozen=True)
class Initial(Section):
    """Disturbance from steady flight, as initial velocities."""

    section = "initial"
    zdot: float = quantity(-0.01, "m s-1", "initial vertical velocity of the gimbal", symbol="zdot0")
    pitch_rate: float = quantity(5.0, "rad s-1", "initial pitch rate", symbol="th1dot0")
    roll_rate: float = quantity(10.0, "rad s-1", "initial roll rate", symbol="th2dot0")


CALIBRATION_MODES = ("source_attitude", "none")


@dataclass(frozen=True)
class Calibration(Section):
    """How the steady state is set.

    ``none``: the printed preload and suspension moments; the attitude is
    whatever balances them.  ``source_attitude``: the slider flies at the
    given attitude and the suspension is set to match the film there: the
    preload becomes the film's load and the static pitch/roll moments
    cancel the film's moments about the gimbal (the source's steady state
    cannot be reached with its printed load; see the README).
    """

    section = "calibration"
    mode: str = quantity("source_attitude", "", "steady-state calibration", choices=CALIBRATION_MODES)
    z: float = quantity(0.115e-6, "m", "target gimbal height (source_attitude mode)", lo=0.0, lo_open=True)
    pitch: float = quantity(13.5e-6, "rad", "target pitch (source_attitude mode)")
    roll: float = quantity(0.0, "rad", "target roll (source_attitude mode)")


AIR_BEARING_MODELS = ("reynolds", "quasi_static", "linearized", "none")
CONTACT_MODELS = ("restitution",)


@dataclass(frozen=True)
class Models(Section):
    """Physical ingredients chosen by name from the registries."""

    section = "models"
    air_bearing: str = quantity("reynolds", "", "air-bearing model", choices=AIR_BEARING_MODELS)
    slip: str = quantity("first_order", "", "slip law", choices=POLYNOMIAL_SLIP_LAWS)
    contact: str = quantity("restitution", "", "contact law", choices=CONTACT_MODELS)


STEP_CONTROLS = ("fixed", "adaptive")


@dataclass(frozen=True)
class Numerics(Section):
    section = "numerics"
    nx: int = quantity(201, "1", "grid nodes along each rail (taper + flat)", lo=16)
    nx_taper: int = quantity(
        31,
        "1",
        "grid nodes on the taper, juncture included (0 = auto, 15 % of nx; fewer than 5 cannot resolve the taper)",
        lo=0,
    )
    ny: int = quantity(21, "1", "grid nodes across each rail", lo=5)
    cluster_x: float = quantity(
        2.0,
        "1",
        "clustering strength along the rail at the juncture and trailing edge (0 = uniform)",
        lo=0.0,
        hi=8.0,
    )
    cluster_y: float = quantity(
        0.0,
        "1",
        "clustering strength across the rail towards its edges (0 = uniform)",
        lo=0.0,
        hi=8.0,
    )
    dt: float = quantity(1.0e-7, "s", "time step (adaptive stepping: the first step)", lo=0.0, lo_open=True)
    time_step: str = quantity(
        "fixed", "", "time-step control: fixed dt, or adaptive from a local error estimate", choices=STEP_CONTROLS
    )
    step_tol: float = quantity(
        1.0e-13, "m", "adaptive stepping: local error per step in the corner spacings", lo=0.0, lo_open=True
    )
    dt_max: float = quantity(2.0e-6, "s", "adaptive stepping: largest step", lo=0.0, lo_open=True)
    t_end: float = quantity(300.0e-6, "s", "duration of a run", lo=0.0, lo_open=True)
    output_interval: float = quantity(0.2e-6, "s", "sampling interval of stored time series", lo=0.0)
    newton_max_iter: int = quantity(1, "1", "Newton iterations per time step (1 = linearly implicit)", lo=1)
    newton_tol: float = quantity(1.0e-10, "1", "Newton tolerance on the scaled film residual", lo=0.0, lo_open=True)
    steady_tol: float = quantity(
        1.0e-10,
        "1",
        "steady solve tolerance (scaled residual and force balance)",
        lo=0.0,
        lo_open=True,
    )
    table_nz: int = quantity(11, "1", "quasi_static table: nodes along z", lo=4)
    table_npitch: int = quantity(11, "1", "quasi_static table: nodes along pitch", lo=4)
    table_nroll: int = quantity(9, "1", "quasi_static table: nodes along roll (odd: roll = 0 is a node)", lo=5)
    table_z_below: float = quantity(
        0.06e-6, "m", "quasi_static table: z range below steady flight", lo=0.0, lo_open=True
    )
    table_z_above: float = quantity(
        2.0e-6, "m", "quasi_static table: z range above steady flight", lo=0.0, lo_open=True
    )
    table_pitch_span: float = quantity(
        800e-6, "rad", "quasi_static table: pitch range either side of steady flight", lo=0.0, lo_open=True
    )
    table_roll_span: float = quantity(
        500e-6, "rad", "quasi_static table: roll range either side of 0", lo=0.0, lo_open=True
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        ratio = self.output_interval / self.dt
        if (
            self.time_step == "fixed"
            and self.output_interval != 0.0
            and (ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio)
        ):
            raise ParameterError(
                f"numerics.output_interval = {self.output_interval!r} is not allowed with numerics.dt = {self.dt!r}: "
                "must be 0 (every step) or a whole multiple of dt [s]"
            )
        if self.table_nroll % 2 == 0:
            raise ParameterError(
                f"numerics.table_nroll = {self.table_nroll} is not allowed: must be odd (roll = 0 is a node)"
            )
        if 0 < self.nx_taper < 5:
            raise ParameterError(
                f"numerics.nx_taper = {self.nx_taper} is not allowed: must be 0 (auto) or >= 5 "
                "(fewer nodes cannot resolve the taper)"
            )
        if self.nx - self.taper_nodes + 1 < 11:
            raise ParameterError(
                f"numerics.nx_taper = {self.nx_taper} is not allowed with numerics.nx = {self.nx}: "
                "the flat needs at least 11 nodes (nx - nx_taper + 1 >= 11)"
            )

    @property
    def taper_nodes(self) -> int:
        """Nodes on the taper: nx_taper, or 15 % of the intervals (at least 5) when it is 0."""
        return self.nx_taper if self.nx_taper > 0 else max(5, round(0.15 * (self.nx - 1)) + 1)

    @property
    def output_every(self) -> int:
        """Steps between stored samples (1 when output_interval is 0)."""
        return max(1, round(self.output_interval / self.dt)) if self.output_interval > 0 else 1


SECTIONS: dict[str, type[Section]] = {
    "slider": Slider,
    "suspension": Suspension,
    "air": Air,
    "disk": Disk,
    "contact": Contact,
    "initial": Initial,
    "models": Models,
    "numerics": Numerics,
    "calibration": Calibration,
}


@dataclass(frozen=True)
class Scene:
    """A complete scene: every parameter of one simulation."""

    kind = "rails"
    name: str = "benson1989"
    description: str = ""
    slider: Slider = field(default_factory=Slider)
    suspension: Suspension = field(default_factory=Suspension)
    air: Air = field(default_factory=Air)
    disk: Disk = field(default_factory=Disk)
    contact: Contact = field(default_factory=Contact)
    initial: Initial = field(default_factory=Initial)
    models: Models = field(default_factory=Models)
    numerics: Numerics = field(default_factory=Numerics)
    calibration: Calibration = field(default_factory=Calibration)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "description": self.description}
        for name in SECTIONS:
            out[name] = getattr(self, name).to_dict()
        return out

    def flat(self) -> dict[str, Any]:
        """Dotted-key view: {'contact.mu': 0.5, ...}."""
        out: dict[str, Any] = {}
        for name in SECTIONS:
            for key, value in getattr(self, name).to_dict().items():
                out[f"{name}.{key}"] = value
        return out


#: Time series of a run: name -> (units, long_name); corner_spacing has a second dimension, the corner.
SERIES = {
    "z": ("m", "gimbal height above the asperity base plane"),
    "pitch": ("rad", "pitch (positive: leading edge up)"),
    "roll": ("rad", "roll (positive: x2 < 0 side up)"),
    "zdot": ("m s-1", "vertical velocity of the gimbal"),
    "pitch_rate": ("rad s-1", "pitch rate"),
    "roll_rate": ("rad s-1", "roll rate"),
    "min_spacing": ("m", "minimum spacing (lowest flat corner)"),
    "corner_spacing": ("m", "spacing at the flat corners"),
    "air_load": ("N", "air-bearing load Q"),
}
