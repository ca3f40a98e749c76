"""Kernels compiled in a child process first (:func:`solver.jit.compile_apart`).

numba's machine code for a kernel compiled in the process that runs it and for the same kernel loaded from its
cache differ in the last bits of some results (the film's cut-link fluxes, numba 0.68): a run in a process that
compiled its kernels parted from the same run in a process that loaded them (2e-19 m after 30 us of the default
scene-2 run, 2e-17 m on a stuck pad).  The pipeline therefore compiles them in a child first, and every process
loads them.  These tests run real child interpreters.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from solver import jit

pytestmark = pytest.mark.skipif(jit.JIT_DISABLED, reason="nothing is compiled with the JIT off")

ROOT = Path(__file__).resolve().parents[1]


def test_the_child_runs_once_per_kernel_version(tmp_path, monkeypatch):
    """The statement runs in a child that knows it is one (and would not spawn another), once: the marker in the
    version's cache folder stops a second run, and ``notify`` is called only then; a failing child is a warning and
    no marker."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv(jit.COMPILING_APART, raising=False)
    log = tmp_path / "runs.txt"
    statement = (
        f"import os; open({str(log)!r}, 'a').write(os.environ[{jit.COMPILING_APART!r}] + "
        "os.environ['NUMBA_NUM_THREADS'] + '\\n')"
    )
    told = []
    assert jit.compile_apart("probe", statement, notify=lambda: told.append(1))
    assert jit.compile_apart("probe", statement, notify=lambda: told.append(1))
    assert log.read_text().splitlines() == ["11"], "one run, in a child that is marked and has one thread"
    assert told == [1], "the caller is told once, when the child starts"
    assert (jit.cache_folder() / "probe.apart").exists()
    assert jit.cache_folder().parent == tmp_path / "cache"
    with pytest.warns(RuntimeWarning, match="compiling the kernels apart \\(broken\\) failed.*ZeroDivisionError"):
        assert not jit.compile_apart("broken", "1 / 0")
    assert not (jit.cache_folder() / "broken.apart").exists()
    monkeypatch.setenv(jit.COMPILING_APART, "1")
    assert not jit.compile_apart("inside", statement), "a child does not spawn another"
    assert log.read_text().splitlines() == ["11"]


SCRIPT = """
import json, sys, tomllib
from pipeline.run.runner import warm_up
from solver.abs.integrate import simulate_abs
from solver.abs.steady import fly_start
from solver.kinds import scene_from_dict

warm_up(("abs",))
data = tomllib.loads(open("studies/scenes/chen_bogy2007.toml").read())
data["slider"]["trailing_pad_width"] = 80e-6
data["numerics"].update(t_end=2e-5, settle_time=0.0)
scene = scene_from_dict(data)
print(json.dumps(simulate_abs(scene, fly_start(scene)).q.tolist()))
"""


@pytest.mark.slow
def test_a_process_that_compiled_the_kernels_runs_what_later_ones_load(tmp_path):
    """Two processes on an empty cache: the first has its kernels compiled apart (a minute), the second loads them;
    a 20-us run of the 80-um pad (the case where compiling in place parted most, 5e-16 rad after 30 us) is the same
    to the last bit in both."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env.pop(jit.COMPILING_APART, None)
    runs = [
        subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True, check=True)
        for _ in range(2)
    ]
    first, second = (json.loads(r.stdout.strip().splitlines()[-1]) for r in runs)
    assert len(first) > 2
    assert first == second
    assert list((tmp_path / "cache").glob("*/warm-up-abs.apart"))
