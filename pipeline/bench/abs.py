"""Benchmark of one scene-2 run (kind "abs"): cost per step and per simulated millisecond against error.

``hdi bench --scene studies/scenes/chen_bogy2007.toml``.  Every case runs the
default 1-ms run (0.2 nm RMS track, adhesion, friction) on another grid or
time step, timed: the median over ``repeats`` runs on one core (the steady
flight is solved once per grid and left out), per step and per simulated
millisecond, and the cost relative to the default setting measured in the
same session, so ratios survive this machine's noise.

Errors need a deterministic run: the rough track is split differently on
every grid (each cell's resolved mean and unresolved RMS), so its 3-sigma
is not a numerical quantity that converges.  The error run is a smooth
disk and a 5 mm/s drop from steady flight, 200 us, compared with the
reference case sample by sample (max |FH(t) - FH_ref(t)|), plus the steady
flying height.  The rough run's 3-sigma is shown for information.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import xarray as xr

from pipeline.config import load_scene
from pipeline.data.netcdf import var, write_netcdf
from pipeline.provenance import base_attrs
from solver.abs.integrate import simulate_abs, summarize
from solver.abs.steady import fly_start

#: (label, nx, ny, dt [s]) of the benchmark; the last one is the reference.
CASES = (
    ("coarse 81x67, dt 0.4 us", 81, 67, 0.4e-6),
    ("coarse 81x67, dt 0.2 us", 81, 67, 0.2e-6),
    ("default 121x101, dt 0.4 us", 121, 101, 0.4e-6),
    ("default 121x101, dt 0.2 us", 121, 101, 0.2e-6),
    ("default 121x101, dt 0.1 us", 121, 101, 0.1e-6),
    ("fine 181x151, dt 0.2 us", 181, 151, 0.2e-6),
    ("reference 241x201, dt 0.1 us", 241, 201, 0.1e-6),
)
QUICK = (("coarse 81x67, dt 0.4 us", 81, 67, 0.4e-6), ("reference 81x67, dt 0.2 us", 81, 67, 0.2e-6))

#: The error run: a smooth disk (deterministic, no profile) and a 5 mm/s drop from steady flight.
DISTURBANCE = ["disk.rms=0.0", "initial.zdot=-0.005", "numerics.t_end=2e-4", "numerics.settle_time=0.0"]


def run_bench(args: argparse.Namespace) -> int:
    cases = QUICK if args.quick else CASES
    t_end = "2e-4" if args.quick else "1e-3"
    settle = "5e-5" if args.quick else "2e-4"
    rows = []
    print(f"{'case':30s} {'nodes':>6s} {'steps':>6s} {'ms/step':>8s} {'s/ms':>7s} {'FH0 [nm]':>9s} "
          f"{'meanFH':>8s} {'3sig [nm]':>9s} {'Fc [uN]':>8s}")  # fmt: skip
    for label, nx, ny, dt in cases:
        grid = [
            f"numerics.nx={nx}",
            f"numerics.ny={ny}",
            f"numerics.dt={dt}",
            f"numerics.output_interval={max(1, round(1e-6 / dt)) * dt}",
        ]
        scene = load_scene(args.scene, grid + [f"numerics.t_end={t_end}", f"numerics.settle_time={settle}"])
        steady = fly_start(scene)
        is_reference = label.startswith("reference")
        walls = []
        for _ in range(1 if is_reference else max(1, args.repeats)):
            t0 = time.perf_counter()
            result = simulate_abs(scene, steady=steady)
            walls.append(time.perf_counter() - t0)
        s = summarize(result, scene)
        wall = statistics.median(walls)
        steps = result.work["steps"]
        probe = load_scene(args.scene, grid + DISTURBANCE)
        drop = simulate_abs(probe, steady=fly_start(probe))
        row = {
            "case": label, "nx": nx, "ny": ny, "dt": dt, "nodes": nx * ny, "steps": steps,
            "wall_per_run": wall, "wall_per_step": wall / max(steps, 1),
            "wall_per_ms": wall / (scene.numerics.t_end / 1e-3), "status": result.status,
            "steady_flying_height": steady.element_spacing, "mean_flying_height": s["mean_flying_height"],
            "bouncing_3sigma": s["bouncing_3sigma"], "mean_contact_force": s["mean_contact_force"],
            "halvings": result.work["step_halvings"], "drop_t": drop.t, "drop_fh": drop.series["flying_height"],
        }  # fmt: skip
        rows.append(row)
        print(f"{label:30s} {nx * ny:6d} {steps:6d} {row['wall_per_step'] * 1e3:8.3f} {row['wall_per_ms']:7.2f} "
              f"{row['steady_flying_height'] * 1e9:9.4f} {row['mean_flying_height'] * 1e9:8.4f} "
              f"{row['bouncing_3sigma'] * 1e9:9.5f} {row['mean_contact_force'] * 1e6:8.4f}", flush=True)  # fmt: skip
    ref = rows[-1]
    base = next((r for r in rows if r["case"].startswith("default") and abs(r["dt"] - 0.2e-6) < 1e-12), rows[0])
    print(f"\nerrors against {ref['case']}; cost relative to {base['case']} measured in this session")
    print(
        "  drop: smooth disk, zdot0 = -5 mm/s, 200 us; max |FH(t) - FH_ref(t)| over the run and its largest excursion"
    )
    print(
        f"{'case':30s} {'FH0 err [nm]':>12s} {'drop err [nm]':>13s} {'excursion':>9s} {'3sig [%]':>9s} {'cost x':>7s}"
    )
    for r in rows:
        r["steady_fh_error"] = abs(r["steady_flying_height"] - ref["steady_flying_height"])
        ref_fh = np.interp(r["drop_t"], ref["drop_t"], ref["drop_fh"])
        r["drop_error"] = float(np.max(np.abs(r["drop_fh"] - ref_fh)))
        r["drop_excursion"] = float(np.max(np.abs(ref["drop_fh"] - ref["drop_fh"][0])))
        r["mean_fh_error"] = abs(r["mean_flying_height"] - ref["mean_flying_height"])
        r["bouncing_error"] = abs(r["bouncing_3sigma"] / ref["bouncing_3sigma"] - 1.0)
        r["cost_ratio"] = r["wall_per_run"] / base["wall_per_run"]
        print(f"{r['case']:30s} {r['steady_fh_error'] * 1e9:12.5f} {r['drop_error'] * 1e9:13.5f} "
              f"{r['drop_excursion'] * 1e9:9.4f} {100 * r['bouncing_error']:9.2f} {r['cost_ratio']:7.2f}")  # fmt: skip
    if args.output:
        ds = xr.Dataset(
            {
                key: var([r[key] for r in rows], ("case",), units, key.replace("_", " "))
                for key, units in (
                    ("nodes", "1"),
                    ("steps", "1"),
                    ("dt", "s"),
                    ("wall_per_run", "s"),
                    ("wall_per_step", "s"),
                    ("wall_per_ms", "s"),
                    ("steady_flying_height", "m"),
                    ("mean_flying_height", "m"),
                    ("bouncing_3sigma", "m"),
                    ("mean_contact_force", "N"),
                    ("steady_fh_error", "m"),
                    ("mean_fh_error", "m"),
                    ("bouncing_error", "1"),
                    ("cost_ratio", "1"),
                    ("halvings", "1"),
                )  # fmt: skip
            },
            coords={"case": ("case", np.array([r["case"] for r in rows]), {"long_name": "benchmark case"})},
        )
        ds.attrs.update(base_attrs("Scene 2 benchmark: cost per step and per simulated ms against error"),
                        scene_kind="abs", product="bench")  # fmt: skip
        ds.attrs["reference"] = ref["case"]
        ds.attrs["baseline"] = base["case"]
        print(f"wrote {write_netcdf(ds, args.output)}")
    return 0
