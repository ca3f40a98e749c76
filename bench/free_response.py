"""Scene 2's time step against its modes: the free response of steady flight on a smooth disk, fitted.

The default scene on a smooth disk (``disk.rms`` 0), started from steady flight with a vertical velocity
(``initial.zdot``, 0.1 mm/s by default: a few picometres of motion, the linear regime), is run for ``--t-end``
at each ``--dt``.  The flying height at the element rings in the second pitch mode; band-passed around it
(650-800 kHz, zero phase), its analytic signal gives the ringing's frequency (slope of the phase) and decay
rate (slope of the log envelope) over 100-900 us, hence its damping ratio.  Printed against:

* the mode of the linearized system (:func:`solver.abs.modes.air_bearing_modes`), what a run tends to as
  dt -> 0;
* the generalized-alpha step's own root at omega dt: the frequency it runs the mode at
  (:func:`~solver.abs.modes.step_frequency_ratio`) and the damping it adds
  (:func:`~solver.abs.modes.numerical_damping`).  The coupled step (the film's linearly implicit midpoint
  and the linearized coupling) is not that single oscillator, so the damping's difference is the measure
  of what the coupling adds or removes.

    python bench/free_response.py                      # dt 0.1, 0.05, 0.025 us; about 6 minutes on one core
    python bench/free_response.py --dt 0.1 0.15 --set numerics.film_jacobian_every=33
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.signal import butter, hilbert, sosfiltfilt

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
ABS_SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"

#: Band around the second pitch mode [Hz] and the fitted window [s].
BAND = (650.0e3, 800.0e3)
WINDOW = (100.0e-6, 900.0e-6)


def ringing(t: np.ndarray, x: np.ndarray, window: tuple[float, float] = WINDOW) -> tuple[float, float]:
    """(frequency [Hz], damping ratio) of the band-passed ringing of x(t) over ``window``."""
    dt = float(t[1] - t[0])
    y = sosfiltfilt(butter(4, BAND, btype="band", fs=1.0 / dt, output="sos"), x - x.mean())
    a = hilbert(y)
    keep = (t > window[0]) & (t < window[1])
    decay = np.polyfit(t[keep], np.log(np.abs(a[keep])), 1)[0]
    omega = np.polyfit(t[keep], np.unwrap(np.angle(a))[keep], 1)[0]
    return omega / (2.0 * math.pi), -decay / omega


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dt", type=float, nargs="+", default=[0.1, 0.05, 0.025], help="time steps [us]")
    parser.add_argument("--zdot", type=float, default=1.0e-4, help="initial vertical velocity [m/s]")
    parser.add_argument("--t-end", type=float, default=1.0e-3, help="run length [s] (the fit uses 100-900 us)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scene override")
    args = parser.parse_args()
    if args.t_end < WINDOW[1]:
        parser.error(f"--t-end = {args.t_end} s: the fit needs runs of at least {WINDOW[1]} s")

    from pipeline.config import load_scene
    from solver.abs.integrate import simulate_abs
    from solver.abs.modes import air_bearing_modes, numerical_damping, step_frequency_ratio
    from solver.abs.steady import fly_start

    base = ["disk.rms=0", f"initial.zdot={args.zdot!r}", f"numerics.t_end={args.t_end!r}", *args.set]
    scene = load_scene(ABS_SCENE, base)
    steady = fly_start(scene)
    modes = air_bearing_modes(scene, steady)
    light = (modes.damping_ratio < 0.01) & (modes.frequency > BAND[0]) & (modes.frequency < BAND[1])
    if not np.any(light):
        raise SystemExit(f"no light mode in {BAND} Hz: the band is for the default face")
    f, zeta = float(modes.frequency[light][0]), float(modes.damping_ratio[light][0])
    rho = scene.numerics.rho_infinity
    print(f"second pitch mode: {f * 1e-3:.2f} kHz, damping ratio {zeta:.6f} (smooth disk, {modes.nodes} unknowns)")
    print("  dt [us]  run: f [kHz]  zeta      step's root: f [kHz]  zeta + zeta_num   run - root: df [kHz]  dzeta")
    for dt_us in args.dt:
        dt = dt_us * 1e-6
        run = load_scene(ABS_SCENE, [*base, f"numerics.dt={dt!r}", "numerics.output_interval=0"])
        result = simulate_abs(run, steady)
        if result.status != 0:
            print(f"  {dt_us:7.4g}  failed: {result.message}")
            continue
        f_run, zeta_run = ringing(result.t, result.series["flying_height"])
        omega_dt = 2.0 * math.pi * f * dt
        f_step = f * step_frequency_ratio(omega_dt, rho)
        zeta_step = zeta + numerical_damping(omega_dt, rho)
        print(f"  {dt_us:7.4g}  {f_run * 1e-3:12.2f}  {zeta_run:.6f}  {f_step * 1e-3:20.2f}  {zeta_step:.6f}"
              f"        {(f_run - f_step) * 1e-3:+10.2f}  {zeta_run - zeta_step:+.6f}")  # fmt: skip
        sys.stdout.flush()


if __name__ == "__main__":
    main()
