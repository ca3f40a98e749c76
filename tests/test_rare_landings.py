"""bench/rare_landings.py: its proportion interval and its report on runs written to a file."""

from __future__ import annotations

import json

import pytest
from conftest import bench_script


@pytest.fixture(scope="module")
def landings():
    return bench_script("rare_landings")


def test_wilson_interval_against_its_closed_forms(landings):
    """No event in n: [0, z^2 / (n + z^2)]; k and n - k events mirror each other; the interval holds k / n."""
    z = 1.959964
    for n in (10, 184):
        lo, hi = landings.wilson(0, n)
        assert lo == 0.0 and hi == pytest.approx(z * z / (n + z * z), rel=1e-12)
    for k, n in ((3, 184), (7, 184), (1, 16)):
        lo, hi = landings.wilson(k, n)
        mirror = landings.wilson(n - k, n)
        assert (lo, hi) == pytest.approx((1.0 - mirror[1], 1.0 - mirror[0]), abs=1e-12)
        assert lo < k / n < hi


def test_report_counts_landings_and_pairs_the_tracks(landings, tmp_path, capsys):
    """Two settings on three tracks, one landing each on different tracks, the reference on both: the report pairs
    the tracks, counts one landing per setting and shows the reference where either landed."""
    rows = []
    for name, forces in (("default", (0.1e-6, 20e-6, 0.2e-6)), ("2 dt, secant", (9e-6, 0.1e-6, 0.3e-6))):
        for seed, force in zip((1, 2, 3), forces, strict=True):
            rows.append({"setting": name, "seed": seed, "status": 0, "cpu": 1.0, "bouncing_3sigma": 0.5e-9,
                         "mean_contact_force": force, "mean_flying_height": 2.1e-9})  # fmt: skip
    for seed in (1, 2):
        rows.append({"setting": "default dt/4", "seed": seed, "status": 0, "cpu": 4.0, "bouncing_3sigma": 0.45e-9,
                     "mean_contact_force": 0.1e-6, "mean_flying_height": 2.11e-9})  # fmt: skip
    path = tmp_path / "runs.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert landings.landed_seeds(landings.by_setting(path), "default dt/4") == [1, 2]
    landings.report(path, "default dt/4")
    out = capsys.readouterr().out
    assert "3 tracks run by every setting" in out
    assert out.count("landed 1 ") == 2
    assert "seed 1:" in out and "seed 2:" in out and "seed 3:" not in out and "not run" not in out


def test_an_unknown_setting_is_refused_with_the_allowed_ones(landings, tmp_path):
    with pytest.raises(SystemExit, match="--setting 'fast' is not allowed: one of 'default'"):
        landings.main(["--setting", "fast", "-o", str(tmp_path / "x.jsonl")])


def test_report_pairs_every_setting_with_a_reference_run_on_every_track(landings, tmp_path, capsys):
    """With the reference on every track its landings are a rate like the settings': it gets a row, and each setting
    is paired with it (3-sigma 0.5 against 0.45 nm on every track: +0.05 nm)."""
    runs = (("default", 0.5e-9, 0.1e-6), ("2 dt, secant", 0.5e-9, 9e-6), ("default dt/4", 0.45e-9, 0.1e-6))
    rows = [{"setting": name, "seed": seed, "status": 0, "cpu": 1.0, "bouncing_3sigma": b, "mean_contact_force": f,
             "mean_flying_height": 2.1e-9} for name, b, f in runs for seed in (1, 2, 3)]  # fmt: skip
    rows.append({**rows[-1], "seed": 4, "mean_contact_force": 40e-6})  # the reference lands where the default flies
    rows += [{**rows[0], "seed": 4}, {**rows[3], "seed": 4}]  # the default flies, the secant lands as everywhere
    path = tmp_path / "runs.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    landings.report(path, "default dt/4")
    out = capsys.readouterr().out
    assert "the reference (default dt/4) on all of them" in out
    assert out.count("paired with default dt/4: +0.05 ") == 2
    assert "  default dt/4 " in out and "landed 1 " in out and "landed 4 " in out  # the secant on every track
    assert "4 tracks run by every setting" in out and "seed 4: default 0.10  2 dt, secant 9.00 uN; reference" in out
