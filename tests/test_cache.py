"""Stores of the reduced air-bearing models' tables: the solver's in-memory default and the pipeline's disk.

The solver builds a ``quasi_static`` table or ``linearized`` coefficients once per key and keeps them in the
store it is given (:mod:`solver.store`); it reads and writes no files itself.  :class:`pipeline.run.cache.DiskStore`
keeps them as ``.npz`` files in ``HDI_CACHE_DIR``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import small_scene

from pipeline.run.cache import DiskStore
from solver.rails import bearings
from solver.rails.bearings import make_air_bearing
from solver.rails.integrate import simulate
from solver.rails.params import Models, Numerics
from solver.rails.steady import fly
from solver.store import MemoryStore

#: A quasi_static table of 4 x 4 x 5 nodes on a coarse grid: a few dozen steady solves.
TINY_TABLE = {"nx": 41, "nx_taper": 9, "ny": 5, "table_nz": 4, "table_npitch": 4, "table_nroll": 5, "t_end": 20e-6}


class CountingStore(MemoryStore):
    def __init__(self) -> None:
        super().__init__()
        self.gets, self.puts = [], []

    def get(self, key):
        self.gets.append(key)
        return super().get(key)

    def put(self, key, arrays):
        self.puts.append(key)
        super().put(key, arrays)


@pytest.fixture(scope="module")
def table_scene():
    scene = small_scene(numerics=Numerics(**TINY_TABLE))
    scene = dataclasses.replace(scene, models=Models(air_bearing="quasi_static"))
    return scene, fly(scene)


def test_a_table_is_built_once_per_store_and_key(table_scene):
    scene, steady = table_scene
    store = CountingStore()
    first = make_air_bearing(scene, store=store)
    first.start(steady)
    assert len(store.gets) == 1 and store.puts == store.gets
    second = make_air_bearing(scene, store=store)
    second.start(steady)
    assert store.gets == 2 * store.puts  # found: not built again
    assert second.table is first.table
    assert second.film.work.reynolds_solves == 0  # nothing solved for the second bearing's table


def test_the_solver_writes_no_files_by_default(table_scene, tmp_path, monkeypatch):
    monkeypatch.setenv("HDI_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    scene, steady = table_scene
    monkeypatch.setattr(bearings, "DEFAULT_STORE", MemoryStore())
    simulate(scene, steady)
    assert list(tmp_path.iterdir()) == []


def test_runs_on_a_disk_store_are_the_runs_in_memory(table_scene, tmp_path):
    # np.savez / np.load round-trip the table exactly: a run reading it from disk is bit-identical
    scene, steady = table_scene
    in_memory = simulate(scene, steady, store=MemoryStore())
    disk = DiskStore(tmp_path)
    built = simulate(scene, steady, store=disk)
    assert [p.suffix for p in tmp_path.iterdir()] == [".npz"]  # one table, no temporary file left
    read = simulate(scene, steady, store=DiskStore(tmp_path))
    assert read.work["reynolds_solves"] < built.work["reynolds_solves"]  # loaded, not built
    for r in (built, read):
        np.testing.assert_array_equal(r.q, in_memory.q)
        np.testing.assert_array_equal(r.v, in_memory.v)
        assert [i.impulse for i in r.impacts] == [i.impulse for i in in_memory.impacts]


def test_disk_store_round_trip_and_failures(tmp_path, monkeypatch):
    arrays = {"table": np.random.default_rng(0).normal(size=(3, 4, 5)), "seconds": np.array(1.5)}
    monkeypatch.setenv("HDI_CACHE_DIR", str(tmp_path / "env"))
    store = DiskStore()  # the environment is read at each call, not at construction
    assert store.get("k") is None
    store.put("k", arrays)
    assert store.path("k") == tmp_path / "env" / "k.npz"
    got = store.get("k")
    assert got.keys() == arrays.keys()
    for name in arrays:
        np.testing.assert_array_equal(got[name], arrays[name])
    store.path("k").write_bytes(b"not a zip file")
    assert store.get("k") is None  # a damaged file is a miss, not an error
    blocked = tmp_path / "file"
    blocked.write_text("")
    DiskStore(blocked / "sub").put("k", arrays)  # cannot create the folder: logged, not raised
    assert DiskStore(blocked / "sub").get("k") is None
