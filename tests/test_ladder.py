"""The grid ladder of a steady flight (``hdi fly SCENE --ladder``, :mod:`pipeline.ladder`).

The fits against power laws whose limit and order are known, Richardson's estimate exactly on them and its
refusals, the grid lists it accepts and refuses, and the command end to end on the kind's tiny scene: every
grid flown, a CF file read back, a figure rendered.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import cf_errors

from pipeline.cli import main
from pipeline.config import scene_toml
from pipeline.data.netcdf import open_result
from pipeline.ladder import default_grids, fit_power, halving_triple, parse_grids, richardson
from solver.abs.kind import tiny

H = 1.0 / (np.array([81, 121, 161, 241, 321]) - 1.0)


@pytest.mark.parametrize(("f0", "b", "p"), [(2.0e-9, 3.0e-8, 1.7), (134e-6, -5e-5, 2.0), (1.0, 4.0, 0.9)])
def test_the_fit_finds_the_limit_and_order_of_a_power_law(f0, b, p):
    """f0 + b h^p sampled on the default ladder's h: the order to the search's step (0.0025), the limit to 1e-4
    of the ladder's spread."""
    got_f0, got_b, got_p = fit_power(H, f0 + b * H**p)
    assert abs(got_p - p) <= 0.0025
    spread = abs(b) * H.max() ** p
    assert abs(got_f0 - f0) <= 1e-4 * spread


def test_the_fit_refuses_what_is_no_power_law():
    """Too few points, a non-monotone ladder whose best order sits at the end of the range, an order below 0.5."""
    assert math.isnan(fit_power(H[:2], np.array([1.0, 2.0]))[2])
    assert math.isnan(fit_power(H, np.array([2.0, 1.0, 2.0, 1.0, 2.0]))[2])
    assert math.isnan(fit_power(H, 1.0 + H**0.3)[2])


def test_richardson_is_exact_on_a_power_law_and_refuses_the_rest():
    h = np.array([1 / 80, 1 / 160, 1 / 320])
    p, f0, why = richardson(*(2.0 + 5.0 * h**1.5))
    assert why == "" and p == pytest.approx(1.5, rel=1e-9) and f0 == pytest.approx(2.0, rel=1e-12)
    assert "not monotone" in richardson(1.0, 2.0, 1.5)[2]
    assert "does not shrink" in richardson(2.1448, 2.0914, 2.0301, scale=1.0, unit="nm")[2]
    assert "below 0.5" in richardson(*(1.0 + h**0.3))[2]
    assert "no flight" in richardson(1.0, math.nan, 2.0)[2]


def test_the_grid_lists():
    assert default_grids(121, 101) == [(81, 68), (121, 101), (161, 134), (241, 201), (321, 268)]
    assert parse_grids(" 121x101, 81x67,161 x 135") == [(81, 67), (121, 101), (161, 135)]
    assert halving_triple([81, 121, 161, 241, 321]) == (0, 2, 4)
    assert halving_triple([81, 121, 161]) is None
    for text, said in (("81,121x101,161x135", "'81' is not NXxNY"), ("5x5,81x67,161x135", "fewer than 11"),
                       ("81x67,81x69,161x135", "repeat an nx"), ("81x67,161x135", "at least 3")):  # fmt: skip
        with pytest.raises(ValueError, match=said):
            parse_grids(text)


def test_the_ladder_command_on_the_tiny_face(tmp_path, capsys):
    """``hdi fly --ladder`` on the tiny stepped face: every grid flies, the pitch converges at an observed order
    near 2 (the fit and Richardson agree), the file is CF and reads back, the figure is drawn; a grid that does
    not resolve the face is an error before any flight, naming the region."""
    scene_file = tmp_path / "tiny.toml"
    scene_file.write_text(scene_toml(tiny()))
    out, png = tmp_path / "ladder.nc", tmp_path / "ladder.png"
    assert main(["fly", str(scene_file), "--ladder", "21x17,41x33,81x65", "-o", str(out), "--plot", str(png)]) == 0
    said = capsys.readouterr().out
    assert "pitch [urad]" in said and "Richardson (21, 41, 81)" in said
    assert cf_errors(out) == []
    ds = open_result(out)
    assert ds.attrs["product"] == "ladder" and list(ds["nx"].values) == [21, 41, 81]
    assert np.all(ds["status"].values == 0)
    p_fit, p_rich = float(ds["pitch_fit_order"]), float(ds["pitch_richardson_order"])
    assert 1.5 <= p_rich <= 3.0 and abs(p_fit - p_rich) < 0.05
    assert float(ds["pitch_fit_limit"]) == pytest.approx(float(ds["pitch_richardson_limit"]), rel=1e-4)
    assert png.stat().st_size > 10_000
    assert main(["fly", str(scene_file), "--ladder", "11x11,41x33,81x65"]) == 2
    assert "too coarse for abs.regions" in capsys.readouterr().err
