"""Stored reference datasets: a fresh run of the same command must give the same numbers, variable by variable.

Each file in ``tests/data/`` is the output of one ``hdi`` command listed in ``make_reference.REFERENCES``;
the test runs that command again into a temporary folder and compares every variable and coordinate
of the stored file with the fresh one:

- the same set of variables (one added or dropped is a change of the output format to notice);
- the same dimensions and shape;
- floats within ``|fresh - stored| <= RTOL |stored| + RTOL S``, where ``S`` is the variable's own scale
  (its largest stored magnitude, or that of a sibling for a value that is round-off of zero, see
  ``SCALE_OF``), so that a series crossing zero does not fail on round-off; NaN where NaN was;
- integers, flags and strings exactly.

Not compared: measured wall times and the ledger's run ids (a hash of the code itself), which differ
between identical runs or after any edit, and global attributes (history, git commit, file paths).
When a variable differs and the scene or study text differs too, the message shows how.

A change of results that is meant is stored again with the command in ``make_reference``'s docstring.
"""

from __future__ import annotations

import difflib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from make_reference import DATA, REFERENCES, run_reference

from pipeline.data.netcdf import open_result, write_netcdf

RTOL = 1e-9

REGENERATE = (
    "if the change is meant, regenerate with `python tests/make_reference.py {name}` "
    "(from the repository root) and commit tests/data/{name} with the change that explains it"
)

#: Variables whose stored value is round-off of an exact zero (the symmetric slider's static roll
#: moment, ~1e-20 N m): their scale is that of the named sibling, not their own.
SCALE_OF = {
    "static_roll_moment": "static_pitch_moment",
    "steady_static_roll_moment": "steady_static_pitch_moment",
}

#: Global attributes shown when variables differ, to tell a change of inputs from a change of code.
INPUT_ATTRS = ("scene_toml", "study_toml")


def excluded(name: str) -> bool:
    """Variables that legitimately differ between identical runs: wall times, and run ids (they hash the code)."""
    return "wall" in name or name == "run_id"


def _scale(stored: xr.Dataset, name: str) -> float:
    sibling = SCALE_OF.get(name, name)
    values = np.abs(np.asarray(stored[sibling if sibling in stored.variables else name].values, dtype=float))
    values = values[np.isfinite(values)]
    return float(values.max()) if values.size else 0.0


def _where(var: xr.Variable, flat: int) -> str:
    index = np.unravel_index(flat, var.shape)
    return "(" + ", ".join(f"{d}={i}" for d, i in zip(var.dims, index, strict=True)) + ")" if var.ndim else "()"


def _compare_floats(name: str, s: xr.Variable, f: xr.Variable, scale: float) -> str | None:
    a, b = np.asarray(s.values, dtype=float).ravel(), np.asarray(f.values, dtype=float).ravel()
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    if not np.array_equal(nan_a, nan_b):
        k = int(np.argmax(nan_a != nan_b))
        return f"{name}: NaN at {_where(s, k)} in one file only (stored {a[k]!r}, fresh {b[k]!r})"
    with np.errstate(invalid="ignore"):
        diff = np.where(nan_a, 0.0, np.abs(b - a))
    floor = RTOL * scale
    bad = diff > RTOL * np.abs(a) + floor
    if not bad.any():
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(bad, diff / np.abs(a), 0.0)  # inf where a zero became non-zero
    k = int(np.argmax(relative))
    return (
        f"{name}: largest relative difference {relative[k]:.3g} at {_where(s, k)} "
        f"(stored {a[k]!r}, fresh {b[k]!r}); {int(bad.sum())} of {a.size} values outside "
        f"rtol {RTOL:g} + atol {floor:.3g} ({s.attrs.get('units', '?')})"
    )


def _compare_exact(name: str, s: xr.Variable, f: xr.Variable) -> str | None:
    a, b = np.asarray(s.values).ravel(), np.asarray(f.values).ravel()
    bad = a != b
    if not bad.any():
        return None
    k = int(np.argmax(bad))
    text = (
        f"{name}: {int(bad.sum())} of {a.size} values differ, first at {_where(s, k)} (stored {a[k]!r}, fresh {b[k]!r})"
    )
    if a.dtype.kind in "iub" and b.dtype.kind in "iub":
        relative = np.abs(b.astype(float) - a) / np.maximum(np.abs(a.astype(float)), 1.0)
        text += f"; largest relative difference {relative.max():.3g}"
    return text


def compare(stored: xr.Dataset, fresh: xr.Dataset) -> list[str]:
    """What differs between a stored reference and a fresh run: one line per variable, empty if nothing."""
    problems = []
    dropped = sorted(set(stored.variables) - set(fresh.variables), key=str)
    added = sorted(set(fresh.variables) - set(stored.variables), key=str)
    if dropped:
        problems.append(f"variables no longer written: {dropped}")
    if added:
        problems.append(f"new variables not in the reference: {added}")
    for name in sorted(set(stored.variables) & set(fresh.variables), key=str):
        if excluded(str(name)):
            continue
        s, f = stored.variables[name], fresh.variables[name]
        if s.dims != f.dims or s.shape != f.shape:
            was, now = dict(zip(s.dims, s.shape, strict=True)), dict(zip(f.dims, f.shape, strict=True))
            problems.append(f"{name}: dims {was} became {now}")
        elif (s.dtype.kind == "f") != (f.dtype.kind == "f") or (s.dtype.kind in "USO") != (f.dtype.kind in "USO"):
            problems.append(f"{name}: type {s.dtype} became {f.dtype}")
        else:
            exact = s.dtype.kind != "f"
            problem = _compare_exact(name, s, f) if exact else _compare_floats(name, s, f, _scale(stored, name))
            if problem:
                problems.append(problem)
    return problems


def input_changes(stored: xr.Dataset, fresh: xr.Dataset, context: int = 8) -> list[str]:
    """Lines of the scene and study texts that differ between the two files (at most ``context`` per text)."""
    lines = []
    for attr in INPUT_ATTRS:
        old, new = str(stored.attrs.get(attr, "")), str(fresh.attrs.get(attr, ""))
        if old != new:
            diff = difflib.unified_diff(old.splitlines(), new.splitlines(), lineterm="", n=0)
            changed = [d for d in diff if d[:1] in "+-" and d[:3] not in ("---", "+++")]
            lines.append(f"the inputs differ too, attribute {attr}: " + "; ".join(changed[:context]))
    return lines


def test_every_reference_is_stored_and_every_stored_file_is_a_reference():
    stored = {p.name for p in DATA.glob("*.nc")}
    missing, orphans = sorted(set(REFERENCES) - stored), sorted(stored - set(REFERENCES))
    assert not missing, f"tests/data has no {missing}; {REGENERATE.format(name=' '.join(missing))}"
    assert not orphans, f"tests/data/{orphans} match no command in make_reference.REFERENCES: delete or add them"


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_fresh_run_matches_the_stored_reference(name: str, tmp_path: Path):
    stored = open_result(DATA / name)
    fresh = run_reference(name, tmp_path / name, tmp_path)
    problems = compare(stored, fresh)
    if problems:
        problems += input_changes(stored, fresh)
    assert not problems, f"tests/data/{name} differs from a fresh run:\n  " + "\n  ".join(
        [*problems, REGENERATE.format(name=name)]
    )


# ----------------------------------------------------------------------------- the comparison itself


def _synthetic() -> xr.Dataset:
    t = np.linspace(0.0, 1.0, 11)
    return xr.Dataset(
        {
            "z": ("time", np.sin(2 * np.pi * t) * 1e-7, {"units": "m"}),  # crosses zero: values ~1e-23 at t = 0.5
            "roll_moment": ((), 1.2e-20, {"units": "N m"}),
            "pitch_moment": ((), 4.8e-5, {"units": "N m"}),
            "gap": ("time", np.where(t > 0.8, np.nan, t), {"units": "m"}),
            "n_impacts": ((), np.int32(7)),
            "corner": ("time", np.array(list("ABCDABCDABC"))),
            "wall_time": ((), 0.25),
            "run_id": ((), "4bc0019c1d300edde7a7"),
        },
        coords={"time": t},
    )


def test_compare_passes_identical_data_round_off_and_ignores_wall_times():
    stored = _synthetic()
    fresh = stored.copy(deep=True)
    fresh["z"] = fresh["z"] + 1e-17  # 1e-10 of the series' scale, yet infinitely many times its zeros
    fresh["pitch_moment"] = fresh["pitch_moment"] * (1 + 1e-12)
    fresh["wall_time"] = fresh["wall_time"] * 3
    fresh["run_id"] = fresh["run_id"].copy(data="another code version")
    assert compare(stored, fresh) == []


@pytest.mark.parametrize(
    ("name", "index", "value", "expected"),
    [
        ("z", 3, lambda v: v * (1 + 1e-6), "z: largest relative difference 1e-06 at (time=3)"),
        ("z", 0, lambda v: 1e-15, "z: largest relative difference inf at (time=0)"),
        ("gap", 2, lambda v: np.nan, "gap: NaN at (time=2) in one file only"),
        ("n_impacts", (), lambda v: 8, "n_impacts: 1 of 1 values differ"),
        ("corner", 4, lambda v: "D", "corner: 1 of 11 values differ, first at (time=4)"),
        ("time", 10, lambda v: v * (1 + 1e-3), "time: largest relative difference 0.001 at (time=10)"),
    ],
)
def test_compare_names_the_variable_and_the_relative_difference(name, index, value, expected):
    stored = _synthetic()
    values = stored[name].values.copy()
    values[index] = value(values[index])
    changed = (stored[name].dims, values, stored[name].attrs)
    fresh = stored.assign_coords({name: changed}) if name in stored.coords else stored.assign({name: changed})
    problems = compare(stored, fresh)
    assert len(problems) == 1 and problems[0].startswith(expected), problems


def test_compare_notices_round_off_variables_only_beyond_their_siblings_scale():
    stored = _synthetic().rename({"roll_moment": "static_roll_moment", "pitch_moment": "static_pitch_moment"})
    fresh = stored.copy(deep=True)
    fresh["static_roll_moment"] = -3e-20  # other round-off of zero: fine
    assert compare(stored, fresh) == []
    fresh["static_roll_moment"] = 1e-12  # a real roll moment
    assert [p.split(":")[0] for p in compare(stored, fresh)] == ["static_roll_moment"]


def test_compare_notices_added_dropped_and_reshaped_variables():
    stored = _synthetic()
    fresh = stored.drop_vars("gap").assign(extra=((), 1.0), n_impacts=("time", np.zeros(11, np.int32)))
    problems = compare(stored, fresh)
    assert problems[0] == "variables no longer written: ['gap']"
    assert problems[1] == "new variables not in the reference: ['extra']"
    assert problems[2].startswith("n_impacts: dims {} became {'time': 11}")


def test_compare_finds_one_perturbed_value_in_a_copy_of_a_stored_reference(tmp_path: Path):
    copy = open_result(DATA / "rails_run.nc")
    copy["z"].values[17] *= 1 + 1e-7
    write_netcdf(copy, tmp_path / "rails_run.nc")
    stored = open_result(DATA / "rails_run.nc")
    problems = compare(stored, open_result(tmp_path / "rails_run.nc"))
    assert [p.split(" (stored")[0] for p in problems] == ["z: largest relative difference 1e-07 at (time=17)"]
    changed_scene = stored.assign_attrs(scene_toml=stored.attrs["scene_toml"].replace("mu = 0.5", "mu = 0.6"))
    assert input_changes(stored, changed_scene) == ["the inputs differ too, attribute scene_toml: -mu = 0.5; +mu = 0.6"]
