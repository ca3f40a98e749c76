"""Modes of the slider on its air bearing (solver.abs.modes) against the time stepper and the scheme's algebra."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.abs.film import AbsFilm
from solver.abs.integrate import simulate_abs
from solver.abs.modes import air_bearing_modes, numerical_damping, step_frequency_ratio
from solver.abs.steady import fly_start
from tests.conftest import chen_bogy

COARSE = {"numerics.nx": 41, "numerics.ny": 31, "numerics.refine_nodes": 2}


def modal_fit(t: np.ndarray, x: np.ndarray, eigenvalues: np.ndarray, width: int) -> float:
    """Least-squares fit of x(t) by a constant and Re/Im of exp(lambda t) per eigenvalue: residual RMS / signal RMS.

    Signal and basis both pass the same moving average of ``width`` samples (a linear filter keeps a sum of
    exponentials one), which removes the modes above the fitted ones.
    """
    columns = [np.ones_like(t)]
    for lam in eigenvalues:
        e = np.exp(lam * (t - t[0]))
        columns += [e.real, e.imag]
    kernel = np.ones(width) / width
    basis = np.array([np.convolve(c, kernel, mode="valid") for c in columns]).T
    y = np.convolve(x, kernel, mode="valid")
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return float(np.std(y - basis @ coef) / np.std(y))


@pytest.fixture(scope="module")
def free_response():
    """COARSE chen_bogy2007 on a smooth disk: its modes, and a free response from steady flight (zdot = -0.2 mm/s).

    The trapezoidal rule (rho_infinity = 1: no numerical damping) at dt = 0.0125 us, 40 us.
    """
    dt = 0.0125e-6
    scene = chen_bogy(
        COARSE
        | {
            "disk.rms": 0.0,
            "initial.zdot": -2e-5,
            "numerics.rho_infinity": 1.0,
            "numerics.dt": dt,
            "numerics.output_interval": dt,
            "numerics.t_end": 40e-6,
            "numerics.settle_time": 0.0,
        }
    )
    film = AbsFilm(scene)
    steady = fly_start(scene, film)
    modes = air_bearing_modes(scene, steady, band=(20e3, 5e6), max_damping=1.0)
    result = simulate_abs(scene, steady)
    assert result.status == 0, result.message
    return scene, modes, result


def test_free_response_is_the_sum_of_the_modes(free_response):
    """After the film's fast transients (t > 10 us) the time stepper's z and pitch are sums of the light modes.

    The modes with damping ratio below 0.1 under 1 MHz (roll 113.1 kHz, zeta 0.021; first pitch 170.3 kHz,
    zeta 0.012 on this grid) and a constant fit z and pitch to 1.0 % of the signal, after a moving average
    over the period of the second pitch mode (4.2 MHz on this coarse grid: the trapezoidal step runs it
    slow, so it would not fit).  The rest: the film's heavily damped modes.  The modes use the stepper's own
    film forces (the links' segment profiles included); with the node quadrature alone, as before, the fit
    left 4.8 %.  Control: the same fit with the light modes' damping doubled leaves 10.7 %, their frequency
    3 % off 24.7 %; both at least 2.5 times the true modes' residual.
    """
    _, modes, result = free_response
    keep = result.t >= 10e-6
    t = result.t[keep]
    light = (modes.damping_ratio < 0.1) & (modes.frequency < 1e6)
    assert np.sum(light) == 2
    lam = modes.eigenvalues[light]
    top = modes.frequency[np.argmax(modes.element)]  # the second pitch mode moves the element most
    assert 3e6 < top < 5e6
    width = int(round(1.0 / (top * (t[1] - t[0]))))
    for k in (0, 1):
        x = result.q[keep, k]
        fit = modal_fit(t, x, lam, width)
        assert fit < 0.03, (k, fit)
        for wrong in (2.0 * lam.real + 1j * lam.imag, lam.real + 1.03j * lam.imag):
            assert modal_fit(t, x, wrong, width) > 2.5 * fit, k


def test_modes_are_damped_and_in_the_band(free_response):
    """Every mode decays (the film and suspension only dissipate) and lies in the band it was searched in."""
    _, modes, _ = free_response
    assert modes.frequency.size > 0
    assert np.all(modes.damping_ratio > 0.0)
    assert np.all((modes.frequency >= 20e3) & (modes.frequency <= 5e6))
    assert np.all(np.diff(modes.frequency) > 0.0)
    assert np.allclose(np.max(modes.shape, axis=1), 1.0)


def test_the_step_runs_the_second_pitch_mode_at_its_step_frequency(free_response):
    """The free response's spectral peak is the second pitch mode at the step's frequency, not at the mode's own.

    On this coarse grid the mode is at 4.78 MHz, omega dt = 0.38 at 0.0125 us, and the trapezoidal rule runs it
    1.15 % slow (step_frequency_ratio 0.9885: 4.727 MHz).  The peak of z's spectrum above 1 MHz (Hann window,
    zero-padded) must lie within a tenth of that shift of the step's frequency (it lies 1.2 kHz from it, against
    the shift's 55 kHz).
    """
    scene, modes, result = free_response
    keep = result.t >= 10e-6
    t, z = result.t[keep], result.q[keep, 0]
    top = int(np.argmax(modes.element))
    f_mode = modes.frequency[top]
    dt = scene.numerics.dt
    f_step = f_mode * step_frequency_ratio(2.0 * math.pi * f_mode * dt, scene.numerics.rho_infinity)
    assert 0.985 < f_step / f_mode < 0.995
    n = 1 << 20
    amplitude = np.abs(np.fft.rfft((z - z.mean()) * np.hanning(z.size), n))
    f = np.fft.rfftfreq(n, t[1] - t[0])
    high = f > 1e6
    peak = f[high][np.argmax(amplitude[high])]
    assert abs(peak - f_step) < 0.1 * (f_mode - f_step), (peak, f_step, f_mode)


@pytest.mark.jitless
def test_numerical_damping_of_the_generalized_alpha_step():
    """zeta_num from the amplification matrix: 0 for the trapezoidal rule, the step's own decay otherwise.

    Checked against the scheme run on x'' + omega^2 x = 0 (its relations written again here, dt = 1): once
    the spurious root has died out, x_n obeys x_n+1 = 2 r cos(theta) x_n - r^2 x_n-1 exactly, and the
    least-squares fit of that recurrence gives the principal root r e^(i theta), hence -ln r / theta, to
    round-off.  And zeta_num grows as (omega dt)^3 at small omega dt for rho_infinity < 1 (second order,
    dissipative): slope between omega dt = 0.05 and 0.1 within 0.2 of 3.
    """
    assert numerical_damping(0.7, 1.0) == pytest.approx(0.0, abs=1e-12)
    for rho in (0.0, 0.5, 0.9):
        for omega_dt in (0.2, 0.7):
            am, af = (2 * rho - 1) / (rho + 1), rho / (rho + 1)
            gamma, beta = 0.5 - am + af, 0.25 * (1 - am + af) ** 2
            w2 = omega_dt**2
            q, v, a = 1.0, 0.0, -w2
            xs = []
            for _ in range(200):
                balance = am * a + w2 * ((1 - af) * (q + v + (0.5 - beta) * a) + af * q)
                a1 = -balance / ((1 - am) + w2 * (1 - af) * beta)
                q1 = q + v + (0.5 - beta) * a + beta * a1
                v, a, q = v + (1 - gamma) * a + gamma * a1, a1, q1
                xs.append(q)
            x = np.array(xs[60:])
            (c1, c2), *_ = np.linalg.lstsq(np.stack([x[1:-1], x[:-2]], axis=1), x[2:], rcond=None)
            r = math.sqrt(-c2)
            theta = math.acos(c1 / (2.0 * r))
            assert -math.log(r) / theta == pytest.approx(numerical_damping(omega_dt, rho), rel=1e-6, abs=1e-12)
            assert theta / omega_dt == pytest.approx(step_frequency_ratio(omega_dt, rho), rel=1e-9)
    small = [numerical_damping(w, 0.0) for w in (0.05, 0.1)]
    assert math.log(small[1] / small[0]) / math.log(2.0) == pytest.approx(3.0, abs=0.2)


@pytest.mark.jitless
def test_step_frequency_ratio_is_the_trapezoidal_rules_and_second_order():
    """rho_infinity = 1 is the trapezoidal rule: the ratio is 2 atan(omega dt / 2) / (omega dt) to round-off.

    For every rho_infinity the step runs slow (ratio below 1) and the error 1 - ratio falls as (omega dt)^2:
    slope between omega dt = 0.05 and 0.1 within 0.05 of 2.
    """
    for omega_dt in (0.05, 0.458, 1.3):
        exact = 2.0 * math.atan(omega_dt / 2.0) / omega_dt
        assert step_frequency_ratio(omega_dt, 1.0) == pytest.approx(exact, rel=1e-12)
    for rho in (0.0, 0.5, 0.9, 1.0):
        errors = [1.0 - step_frequency_ratio(w, rho) for w in (0.05, 0.1)]
        assert all(e > 0.0 for e in errors)
        assert math.log(errors[1] / errors[0]) / math.log(2.0) == pytest.approx(2.0, abs=0.05)


def test_fly_modes_command_writes_the_modes(tmp_path, capsys):
    """``hdi fly --modes``: the table on the console, the modes in the netCDF (read back), refused for kind rails."""
    from pipeline.cli import main
    from pipeline.config import DEFAULT_SCENE
    from pipeline.data.netcdf import open_result
    from tests.conftest import SCENE2_FILE

    out = tmp_path / "fly.nc"
    sets = [arg for key, value in COARSE.items() for arg in ("--set", f"{key}={value}")]
    assert main(["fly", str(SCENE2_FILE), *sets, "--modes", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "modes on the air bearing" in text and "f_step, dt = 0.2 us, rho_infinity = 0.9" in text
    ds = open_result(out)
    assert list(ds["dof"].values) == ["z", "pitch", "roll"]
    assert ds["mode_shape"].dims == ("mode", "dof")
    assert np.all(ds["mode_damping_ratio"].values < 0.5) and np.all(ds["mode_frequency"].values > 0.0)
    assert np.all(ds["mode_numerical_damping"].values >= 0.0)
    f, f_step = ds["mode_frequency"].values, ds["mode_step_frequency"].values
    assert np.all((f_step < f) & (f_step > 0.9 * f))
    assert main(["fly", str(DEFAULT_SCENE), "--modes"]) == 2
    assert "--modes" in capsys.readouterr().err


@pytest.mark.jitless
def test_the_free_response_fit_recovers_a_damped_oscillation():
    """bench/free_response.py's fit: a 716-kHz oscillation with damping ratio 0.0015 under a faster-decaying
    106-kHz one (the roll mode's place) and a constant, sampled at 0.1 us for 1 ms: its frequency to 1e-6 and its
    damping ratio to 0.1 % (measured: 2e-8 and 2e-5).  Control: a tenth more damping is found as such."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "bench" / "free_response.py"
    spec = importlib.util.spec_from_file_location("free_response", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    t = np.arange(0.0, 1e-3, 1e-7)
    f, roll = 716.0e3, 106.0e3

    def signal(zeta: float) -> np.ndarray:
        w = 2.0 * math.pi * f
        main = 1e-11 * np.exp(-zeta * w * t) * np.cos(w * math.sqrt(1.0 - zeta**2) * t + 0.3)
        return 2.1e-9 + main + 5e-12 * np.exp(-0.03 * 2.0 * math.pi * roll * t) * np.cos(2.0 * math.pi * roll * t)

    f_fit, zeta_fit = bench.ringing(t, signal(0.0015))
    assert f_fit == pytest.approx(f * math.sqrt(1.0 - 0.0015**2), rel=1e-6)
    assert zeta_fit == pytest.approx(0.0015, rel=1e-3)
    assert bench.ringing(t, signal(0.00165))[1] == pytest.approx(0.00165, rel=1e-3)
