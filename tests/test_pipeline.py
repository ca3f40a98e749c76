"""Pipeline: configuration, classification, netCDF round trips, figures and the command line."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
import xarray as xr
from conftest import cf_errors, thornton_e

from pipeline.classify import classify_impulses
from pipeline.cli import main
from pipeline.config import DEFAULT_SCENE, ConfigError, load_scene, parse_override, scene_toml
from pipeline.data.netcdf import open_result, write_netcdf
from pipeline.data.rails import run_dataset
from solver.errors import ContactError
from solver.kinds import scene_from_dict
from solver.params import ParameterError
from solver.rails.integrate import simulate

SMALL = [
    "numerics.nx=41",
    "numerics.nx_taper=9",
    "numerics.ny=7",
    "numerics.t_end=30e-6",
    "numerics.output_interval=0.4e-6",
]


# ---------------------------------------------------------------- configuration
def test_override_values_are_toml_typed():
    assert parse_override("contact.mu=0.5") == ("contact.mu", 0.5)
    assert parse_override("contact.wedging=false") == ("contact.wedging", False)
    assert parse_override("models.slip=continuum") == ("models.slip", "continuum")
    assert parse_override("numerics.nx=101") == ("numerics.nx", 101)


def test_dotted_overrides_reach_the_scene():
    scene = load_scene(DEFAULT_SCENE, ["contact.mu=0.3", "contact.alpha=1", "initial.zdot=-0.02"])
    assert (scene.contact.mu, scene.contact.alpha, scene.initial.zdot) == (0.3, 1.0, -0.02)
    assert isinstance(scene.contact.alpha, float)


@pytest.mark.parametrize(
    ("override", "words"),
    [
        ("contact.muu=1", ["contact.muu", "[contact]"]),
        ("contact.alpha=1.5", ["contact.alpha", "1.5", "[0, 1]"]),
        ("contact.mu=-0.1", ["contact.mu", "-0.1", ">= 0"]),
        ("slider.mass=-1e-5", ["slider.mass", "-1e-05", "> 0"]),
        ("slider.pitch_inertia=-1e-9", ["slider.pitch_inertia", "> 0"]),
        ("numerics.nx_taper=4", ["numerics.nx_taper", "4", "taper"]),
        ("contact.mu='high'", ["contact.mu", "'high'", "wrong type"]),
        ("models.slip=magic", ["models.slip", "magic", "first_order"]),
        ("numerics.nx=50.5", ["numerics.nx", "integer"]),
    ],
)
def test_bad_input_names_key_value_and_what_is_allowed(override, words):
    with pytest.raises(ParameterError) as err:
        load_scene(DEFAULT_SCENE, [override])
    for word in words:
        assert word in str(err.value), (word, str(err.value))


def test_unknown_key_in_a_file_names_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(DEFAULT_SCENE.read_text() + "\n[extras]\nfoo = 1\n")
    with pytest.raises(ParameterError, match=r"unknown key 'extras' in .*bad\.toml"):
        load_scene(bad)
    typo = tmp_path / "typo.toml"
    typo.write_text(DEFAULT_SCENE.read_text().replace("alpha = 0.8", "alpah = 0.8"))
    with pytest.raises(ParameterError, match=r"contact\.alpah.*typo\.toml"):
        load_scene(typo)


def test_a_study_file_is_not_a_scene(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text('[study]\nscene = "x.toml"\n')
    with pytest.raises(ConfigError, match="study file"):
        load_scene(study)


def test_scene_toml_round_trips_every_parameter():
    scene = load_scene(DEFAULT_SCENE, ["contact.mu=0.25", "models.slip=continuum"])
    again = scene_from_dict(tomllib.loads(scene_toml(scene)), source="round trip")
    assert again == scene


# ---------------------------------------------------------------- classification
def test_impulse_growth_classification():
    g = classify_impulses(np.array([1.0, 0.5, 0.9, 0.2]), np.array([3, 1, 1, 3]))
    assert (g.stable, g.n_impacts, g.n_larger_than_first, g.n_front_corner_impacts) == (1, 4, 0, 0)
    assert g.max_impulse_ratio == pytest.approx(0.9)
    g = classify_impulses(np.array([1.0, 0.5, 1.2, 2.0]), np.array([3, 0, 2, 1]))
    assert (g.stable, g.n_larger_than_first, g.n_front_corner_impacts) == (0, 2, 2)
    assert g.max_impulse_ratio == pytest.approx(2.0)
    # a shared impact (two corners at one instant) is one event: its shares, 1 ulp apart, are not growth
    share = 2.550594979607706e-07
    split = classify_impulses([share, np.nextafter(share, 1.0), 0.1 * share], [1, 3, 1], [1e-5, 1e-5, 2e-5])
    assert split.stable == 1 and split.n_impacts == 3 and split.first_impulse == share + np.nextafter(share, 1.0)
    assert classify_impulses([share, np.nextafter(share, 1.0)], [1, 3]).stable == 0  # without times: two records
    none = classify_impulses(np.array([]), np.array([], dtype=int))
    assert none.stable == 1 and none.n_impacts == 0 and math.isnan(none.first_impulse)


# ---------------------------------------------------------------- datasets
@pytest.fixture(scope="module")
def small_run():
    scene = load_scene(DEFAULT_SCENE, [*SMALL, "contact.alpha=0.8"])
    return scene, simulate(scene)


def test_run_netcdf_round_trip_is_self_describing(small_run, tmp_path):
    scene, result = small_run
    assert result.status == 0 and len(result.impacts) >= 1
    path = write_netcdf(run_dataset(result, scene), tmp_path / "run.nc")
    assert not list(tmp_path.glob(".*tmp")), "temporary file left behind"
    ds = open_result(path)
    assert ds.attrs["Conventions"].startswith("CF-")
    for key in ("title", "source", "history", "git_commit", "package_version", "scene_toml"):
        assert ds.attrs[key], key
    for name, v in {**ds.data_vars, **ds.coords}.items():
        if name in ("corner", "impact", "rail"):
            continue
        assert "long_name" in v.attrs and "units" in v.attrs, name
    assert list(ds["impact_corner"].values) == [i.corner_letter for i in result.impacts]
    np.testing.assert_array_equal(ds["impact_impulse"].values, [i.impulse for i in result.impacts])
    np.testing.assert_array_equal(ds["z"].values, result.q[:, 0])
    assert list(ds["stable"].attrs["flag_meanings"].split()) == ["unstable", "stable"]
    assert int(ds["n_impacts"]) == len(result.impacts)
    assert scene_from_dict(tomllib.loads(ds.attrs["scene_toml"]), source="attrs") == scene
    # the classification stored agrees with the impulses stored
    q = ds["impact_impulse"].values
    assert int(ds["stable"]) == int(not np.any(q[1:] > q[0]))


def test_open_result_rejects_files_that_are_not_ours(tmp_path):
    other = tmp_path / "other.nc"
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(other)
    with pytest.raises(ValueError, match="not a netCDF file written by hdi"):
        open_result(other)
    text = tmp_path / "notes.nc"
    text.write_text("hello")
    with pytest.raises(ValueError, match="not a netCDF file"):
        open_result(text)


# ---------------------------------------------------------------- command line
def test_cli_fly_simulate_plot(tmp_path, capsys):
    fly_nc, run_nc, png = tmp_path / "fly.nc", tmp_path / "run.nc", tmp_path / "run.png"
    sets = [a for s in SMALL for a in ("--set", s)]
    assert main(["fly", str(DEFAULT_SCENE), *sets, "-o", str(fly_nc), "--plot", str(tmp_path / "fly.png")]) == 0
    out = capsys.readouterr().out
    assert "minimum spacing" in out and "bearing number" in out
    fly = open_result(fly_nc)
    assert cf_errors(fly_nc) == []
    assert float(fly["z"]) == pytest.approx(0.115e-6, rel=1e-12)
    assert fly["pressure"].attrs["units"] == "Pa" and fly["pressure"].shape == (2, 41, 7)
    # pressure is ambient on every rail edge and above it inside
    p = fly["pressure"].values
    assert np.allclose(p[:, 0, :], 101e3) and np.allclose(p[:, :, 0], 101e3)
    assert p.max() > 101e3
    assert main(["simulate", str(DEFAULT_SCENE), *sets, "--set", "contact.alpha=0.5", "-o", str(run_nc)]) == 0
    out = capsys.readouterr().out
    assert "impact   1" in out and ("STABLE" in out or "UNSTABLE" in out)
    assert cf_errors(run_nc) == []
    assert main(["plot", str(run_nc), "-o", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


@pytest.mark.parametrize("law", ["constant", "thornton"])
def test_cli_simulate_records_each_impact_s_speed_coefficient_and_yield_velocity(tmp_path, capsys, law):
    # the check: hdi simulate ... --set contact.restitution=thornton --set contact.corner_radius=10e-6
    # writes impact_velocity, impact_alpha and impact_yield_velocity, and every impact_alpha (of a corner not held
    # by the chattering rule) is contact.alpha times e_T of that impact to round-off
    run_nc = tmp_path / "run.nc"
    sets = [a for s in SMALL for a in ("--set", s)]
    sets += ["--set", f"contact.restitution={law}", "--set", "contact.corner_radius=10e-6"]
    sets += ["--set", "contact.alpha=0.9", "--set", "numerics.t_end=100e-6"]
    assert main(["simulate", str(DEFAULT_SCENE), *sets, "-o", str(run_nc)]) == 0
    out = capsys.readouterr().out
    assert ("V_y =" in out) == (law == "thornton")
    assert cf_errors(run_nc) == []
    ds = open_result(run_nc)
    speed, alpha = ds["impact_velocity"].values, ds["impact_alpha"].values
    v_yield, held = ds["impact_yield_velocity"].values, ds["impact_held"].values == 1
    assert speed.size >= 2 and not held.any()
    np.testing.assert_array_equal(speed, ds["impact_approach_before"].values)
    assert ds["impact_alpha"].attrs["units"] == "1" and ds["impact_yield_velocity"].attrs["units"] == "m s-1"
    if law == "constant":
        assert (alpha == 0.9).all() and np.isnan(v_yield).all()
        return
    assert np.all(np.abs(alpha - 0.9 * thornton_e(speed, v_yield)) <= 4 * np.finfo(float).eps)
    assert np.all(v_yield > 0.0) and np.any(speed > 2 * v_yield) and alpha.min() < 0.8


def test_cli_bad_input_exits_2_before_work(capsys):
    assert main(["simulate", str(DEFAULT_SCENE), "--set", "contact.alpha=2"]) == 2
    err = capsys.readouterr().err
    assert "contact.alpha = 2.0" in err and "[0, 1]" in err
    assert main(["fly", "no/such/scene.toml"]) == 2
    assert "no such file" in capsys.readouterr().err


SCENE2 = DEFAULT_SCENE.with_name("chen_bogy2007.toml")
SCENE2_SMALL = ["numerics.nx=81", "numerics.ny=67", "numerics.t_end=2e-5", "numerics.settle_time=5e-6",
                "contact.delta_gamma=0.0"]  # fmt: skip


def test_cli_scene2_fly_simulate_plot(tmp_path, capsys):
    """Scene 2 through the command line: fly, a short run, their netCDF files read back, the figures drawn."""
    sets = [a for s in SCENE2_SMALL for a in ("--set", s)]
    fly_nc, run_nc = tmp_path / "fly2.nc", tmp_path / "run2.nc"
    assert main(["fly", str(SCENE2), *sets, "-o", str(fly_nc), "--plot", str(tmp_path / "fly2.png")]) == 0
    assert "flying height" in capsys.readouterr().out
    fly = open_result(fly_nc)
    assert cf_errors(fly_nc) == []
    assert fly.attrs["scene_kind"] == "abs" and fly["pressure"].dims == ("x", "y")
    assert 0.5e-9 < float(fly["flying_height"]) < 10e-9 and fly["flying_height"].attrs["units"] == "m"
    assert main(["simulate", str(SCENE2), *sets, "-o", str(run_nc), "--plot", str(tmp_path / "run2.png")]) == 0
    out = capsys.readouterr().out
    assert "bouncing 3 sigma" in out and "mean contact force" in out
    run = open_result(run_nc)
    assert cf_errors(run_nc) == []
    assert int(run["status"]) == 0 and run["flying_height"].dims == ("time",)
    assert {"bouncing_3sigma", "mean_contact_force", "contact_fraction", "flying_height_spectrum"} <= set(run)
    assert float(run["bouncing_3sigma"]) >= 0.0
    png = tmp_path / "again.png"
    assert main(["plot", str(run_nc), "-o", str(png)]) == 0 and png.stat().st_size > 10_000
    assert (tmp_path / "fly2.png").stat().st_size > 10_000


def test_cli_scene2_bad_input_names_the_key(capsys):
    assert main(["fly", str(SCENE2), "--set", "contact.mu=-1"]) == 2
    assert "contact.mu" in capsys.readouterr().err
    assert main(["fly", str(SCENE2), "--set", "slider.trailing_pad_width=1e-6"]) == 2
    assert "trailing pad" in capsys.readouterr().err


def test_cli_failures_end_in_one_line_and_the_traceback_needs_debug(tmp_path, capsys, monkeypatch):
    sets = [a for s in SMALL for a in ("--set", s)]
    out = tmp_path / "a.nc"
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    assert main(["simulate", str(empty), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("hdi: error:") and err.count("\n") == 1 and "empty scene file" in err
    (tmp_path / "nameless.toml").write_text("[contact]\nmu = 0.3\n")
    assert main(["simulate", str(tmp_path / "nameless.toml"), "-o", str(out)]) == 2
    assert "needs a name" in capsys.readouterr().err
    # a scene without an answer (the calibration height puts the rear corners below the asperities): status 1,
    # the values, what to try, and no file
    bad = [*sets, "--set", "calibration.z=0.03e-6"]
    assert main(["simulate", str(DEFAULT_SCENE), *bad, "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("hdi: error: a corner starts below the asperity height") and err.count("\n") == 1
    assert "B 24.84 nm" in err and "; try " in err and not out.exists()
    with pytest.raises(ContactError):
        main(["--debug", "simulate", str(DEFAULT_SCENE), *bad, "-o", str(out)])
    # a file that cannot be written is refused before any work
    assert main(["fly", str(DEFAULT_SCENE), *sets, "-o", str(tmp_path)]) == 2
    err = capsys.readouterr()
    assert "is a folder" in err.err and "minimum spacing" not in err.out
    # a bug is reported as one, in one line
    monkeypatch.setattr("pipeline.cli.cmd_query", lambda args: {}["boom"])
    parser_main = main(["query", str(out)])
    err = capsys.readouterr().err
    assert parser_main == 1 and "unexpected KeyError" in err and "--debug" in err and err.count("\n") == 1


def test_scene2_regime_rule():
    from pipeline.classify import REGIMES, SUSTAINED_FRACTION, abs_regime

    assert [REGIMES[abs_regime(f, True)] for f in (0.0, 1e-6, SUSTAINED_FRACTION - 1e-9)] == [
        "flying", "intermittent_contact", "intermittent_contact"]  # fmt: skip
    assert REGIMES[abs_regime(SUSTAINED_FRACTION, True)] == "sustained_contact"
    assert REGIMES[abs_regime(1.0, True)] == "stuck"  # the pad never leaves the disk
    assert REGIMES[abs_regime(0.0, False)] == "stuck"  # no flying equilibrium, whatever the run did
    assert abs_regime(float("nan"), True) == -1
