"""Parameter validation: bad values, types and keys raise ParameterError naming the dotted key.

A message must let a user fix a TOML file without reading the code: the
dotted key, the offending value, what is allowed, and (for config input)
the file it came from.
"""

from __future__ import annotations

import dataclasses

import pytest

from solver.kinds import field_metadata, scene_from_dict
from solver.params import ParameterError
from solver.rails.params import SECTIONS, Contact, Models, Numerics, Scene, Slider


@pytest.mark.parametrize(
    ("build", "key", "value", "allowed"),
    [
        (lambda: Slider(mass=-1e-5), "slider.mass", "-1e-05", "> 0"),
        (lambda: Slider(pitch_inertia=-1e-10), "slider.pitch_inertia", "-1e-10", "> 0"),
        (lambda: Slider(roll_inertia=0.0), "slider.roll_inertia", "0.0", "> 0"),
        (lambda: Contact(alpha=1.2), "contact.alpha", "1.2", "in [0, 1]"),
        (lambda: Contact(alpha=-0.1), "contact.alpha", "-0.1", "in [0, 1]"),
        (lambda: Contact(mu=-0.5), "contact.mu", "-0.5", ">= 0"),
        (lambda: Numerics(dt=0.0), "numerics.dt", "0.0", "> 0"),
        (lambda: Numerics(nx_taper=4), "numerics.nx_taper", "4", ">= 5"),
        (lambda: Contact(corner_radius=-1e-6), "contact.corner_radius", "-1e-06", "> 0 [m]"),
        (lambda: Contact(contact_modulus=-94e9), "contact.contact_modulus", "-94000000000.0", "> 0 [Pa]"),
        (lambda: Contact(yield_pressure=0.0), "contact.yield_pressure", "0.0", "> 0 [Pa]"),
        (lambda: Contact(restitution="plastic"), "contact.restitution", "'plastic'", "'constant', 'thornton'"),
    ],
)
def test_out_of_range_value_names_key_value_and_range(build, key, value, allowed):
    with pytest.raises(ParameterError) as info:
        build()
    message = str(info.value)
    assert key in message and value in message and allowed in message


def test_thornton_refuses_a_yield_pressure_whose_contact_outgrows_the_corner():
    # Hertz's contact radius at yield, pi p_y R / (2 E*), reaches R at p_y = 2 E* / pi = 59.8 GPa for E* = 94 GPa
    with pytest.raises(ParameterError) as info:
        Contact(restitution="thornton", contact_modulus=94e9, yield_pressure=60e9)
    message = str(info.value)
    assert "contact.yield_pressure = 60000000000.0" in message and "contact.contact_modulus" in message
    assert "2 E*/pi = 5.98423e+10" in message
    Contact(restitution="thornton", contact_modulus=94e9, yield_pressure=59e9)
    Contact(restitution="constant", contact_modulus=94e9, yield_pressure=60e9)  # unused by the constant law


def test_too_few_taper_nodes_mentions_the_taper():
    with pytest.raises(ParameterError, match="taper"):
        Scene(numerics=Numerics(nx_taper=4))


def test_too_few_flat_nodes():
    with pytest.raises(ParameterError, match=r"numerics\.nx_taper.*flat"):
        Numerics(nx=20, nx_taper=11)


@pytest.mark.parametrize(
    ("build", "key"),
    [
        (lambda: Slider(mass="heavy"), "slider.mass"),
        (lambda: Contact(alpha=True), "contact.alpha"),
        (lambda: Contact(wedging=1), "contact.wedging"),
        (lambda: Numerics(nx=61.0), "numerics.nx"),
        (lambda: Models(slip=6), "models.slip"),
    ],
)
def test_wrong_type_is_rejected(build, key):
    with pytest.raises(ParameterError, match="wrong type") as info:
        build()
    assert key in str(info.value)


def test_unknown_choice_lists_the_registry():
    with pytest.raises(ParameterError) as info:
        Models(air_bearing="magic")
    message = str(info.value)
    assert "models.air_bearing" in message and "'magic'" in message
    assert "'reynolds'" in message and "'none'" in message


def test_inertia_must_exceed_the_mass_centre_offset():
    # I1 is about the gimbal: it must exceed m a^2, or the mass matrix is singular
    with pytest.raises(ParameterError, match="slider.pitch_inertia"):
        Slider(mass=1e-3, cg_offset=1e-3, pitch_inertia=0.5e-9)


def test_rails_must_fit_on_the_slider():
    with pytest.raises(ParameterError, match="slider.rail_width"):
        Slider(width=1e-3, rail_width=0.6e-3)


def test_unknown_key_names_the_key_and_the_file():
    with pytest.raises(ParameterError) as info:
        scene_from_dict({"contact": {"muu": 1}}, source="x.toml")
    message = str(info.value)
    assert "contact.muu" in message and "x.toml" in message
    # the message lists the valid keys so the typo is obvious
    assert "mu" in message.split("has", 1)[1]


def test_unknown_section_names_the_file():
    with pytest.raises(ParameterError, match=r"'contakt'.*x\.toml"):
        scene_from_dict({"contakt": {"mu": 1}}, source="x.toml")


def test_bad_value_from_a_file_names_key_and_file():
    with pytest.raises(ParameterError) as info:
        scene_from_dict({"slider": {"mass": -1.0}}, source="studies/scene1.toml")
    message = str(info.value)
    assert "slider.mass" in message and "studies/scene1.toml" in message


def test_round_trip_through_plain_dicts():
    scene = Scene(contact=Contact(mu=0.3, alpha=0.85), numerics=Numerics(nx=61, nx_taper=11, ny=9))
    assert scene_from_dict(scene.to_dict(), source="round-trip") == scene
    flat = scene.flat()
    assert flat["contact.mu"] == 0.3 and flat["numerics.nx"] == 61


def test_integers_are_accepted_for_floats():
    # TOML writes 1 for 1.0; the stored value is a float
    contact = Contact(alpha=1)
    assert contact.alpha == 1.0 and isinstance(contact.alpha, float)


def test_every_field_has_units_and_a_long_name():
    # the same metadata feeds the output attributes: nothing may be missing
    for section, cls in SECTIONS.items():
        for f in dataclasses.fields(cls):
            meta = field_metadata(f"{section}.{f.name}")
            assert meta["long_name"], f"{section}.{f.name}"
            assert meta["units"] is not None, f"{section}.{f.name}"
    assert field_metadata("slider.mass")["units"] == "kg"
    assert field_metadata("contact.mu")["units"] == "1"
    with pytest.raises(ParameterError, match="contact.muu"):
        field_metadata("contact.muu")


def test_parameters_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        Contact().mu = 0.1  # type: ignore[misc]
