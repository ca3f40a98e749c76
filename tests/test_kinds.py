"""The scene-kind registries: every solver kind has a pipeline adapter and the other way round, and every kind
goes through the same path (fly, simulate, its datasets, CF-1.8 files, its figures, a study record) on its tiny
scene.  A new kind is tested here by being registered."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import cf_errors

from pipeline.config import scene_toml
from pipeline.data.netcdf import open_result, write_netcdf
from pipeline.figures.common import save_figure
from pipeline.kinds import adapter_of, adapters, plot_dataset
from pipeline.run.runner import run_case
from solver.kinds import get_kind, kinds, scene_from_dict
from solver.params import ParameterError

KINDS = sorted(kinds())


def test_every_solver_kind_has_an_adapter_and_back():
    assert set(kinds()) == set(adapters()) and KINDS


def test_an_unknown_kind_is_an_error_listing_the_kinds():
    with pytest.raises(ParameterError, match="kind = 'disk' in x.toml is not allowed: must be one of"):
        scene_from_dict({"kind": "disk"}, source="x.toml")


@pytest.mark.parametrize("name", KINDS)
def test_the_kind_declares_its_parameters_and_outputs_once(name):
    kind, adapter = get_kind(name), adapter_of(name)
    scene = kind.tiny()
    assert isinstance(scene, kind.scene_type) and scene.kind == name
    assert set(kind.sections) == {f.name for f in dataclasses.fields(scene) if f.name not in ("name", "description")}
    for section, free in kind.steady_free.items():
        assert section in kind.sections, section
        names = {f.name for f in dataclasses.fields(kind.sections[section])}
        assert free is None or set(free) <= names, (section, set(free) - names)
    for out_name, out in adapter.outputs.items():
        assert out.long_name, out_name
        assert out.units or np.dtype(out.dtype).kind == "O", out_name
    assert set(adapter.required_outputs) <= set(adapter.study_outputs) <= set(adapter.outputs)
    assert adapter.class_flag is None or adapter.class_flag in adapter.required_outputs


@pytest.mark.parametrize("name", KINDS)
def test_the_tiny_scene_round_trips_through_its_toml(name):
    import tomllib

    scene = get_kind(name).tiny()
    assert scene_from_dict({"kind": name, **tomllib.loads(scene_toml(scene))}, source="toml") == scene


@pytest.mark.parametrize("name", KINDS)
def test_fly_and_run_give_cf_files_and_figures_of_the_kind(name, tmp_path):
    kind, adapter = get_kind(name), adapter_of(name)
    scene = kind.tiny()
    steady = kind.fly(scene)
    result = kind.simulate(scene, **adapter.run_inputs(scene))
    assert result.status == 0, result.message
    for product, ds in (("fly", adapter.fly_dataset(steady, scene, 0.1)), ("run", adapter.run_dataset(result, scene))):
        path = write_netcdf(ds, tmp_path / f"{product}.nc")
        assert cf_errors(path) == []
        back = open_result(path)
        assert back.attrs["scene_kind"] == name and back.attrs["product"] == product
        assert adapter_of(back) is not None
        png = save_figure(plot_dataset(back), tmp_path / f"{product}.png")
        assert png.stat().st_size > 10_000
    assert adapter.fly_report(steady, scene, 0.1) and adapter.run_report(result, ds, scene)


@pytest.mark.parametrize("name", KINDS)
def test_a_study_record_holds_every_output_of_the_kind(name):
    kind, adapter = get_kind(name), adapter_of(name)
    record = run_case({"kind": name, **kind.tiny().to_dict()}, "test-run", adapter.impacts_kept)
    assert record["status"] == 0, record.get("message")
    missing = set(adapter.outputs) - set(record)
    assert not missing, missing
    assert isinstance(adapter.progress(record), str)


@pytest.mark.parametrize("name", KINDS)
def test_warm_up_loads_the_kind_on_one_thread(name, monkeypatch):
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    get_kind(name).warm_up()
    import os

    assert os.environ["NUMBA_NUM_THREADS"] == "1"


def test_multifidelity_is_refused_for_a_kind_without_a_two_valued_class():
    from pathlib import Path

    from pipeline.config import ConfigError
    from pipeline.study.spec import load_study

    scene2_study = Path(__file__).resolve().parents[1] / "studies" / "pad_width.toml"
    assert adapter_of(load_study(scene2_study).base).class_flag is None
    with pytest.raises(ConfigError, match="scene kind 'abs' has none for this mode: use mode = 'grid' or 'boundary'"):
        load_study(scene2_study, mode="multifidelity")
    with pytest.raises(ConfigError, match=r"mode = 'boundary'.*needs a \[boundary\] table"):
        load_study(scene2_study, mode="boundary")
