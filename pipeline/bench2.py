"""Benchmark of one scene-2 run (kind "abs"): cost per step and per simulated millisecond against error.

``hdi bench --scene studies/scenes/chen_bogy2007.toml``.  Every case is the
same 1-ms run (default scene: 0.2 nm RMS track, adhesion, friction) on
another grid or time step.  Errors are taken against the finest case of the
same run: the steady flying height, the mean flying height and the 3-sigma
bouncing after the settling time.  Costs: the median over ``repeats`` timed
runs on one core (the steady flight is solved once per grid and left out),
per step and per simulated millisecond; the baseline is the default scene
measured in the same session, so ratios survive this machine's noise.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import xarray as xr

from solver.partial import fly_start, simulate_abs, summarize

from .config import load_scene
from .provenance import base_attrs
from .store import var, write_netcdf

#: (label, nx, ny, dt [s]) of the benchmark; the last one is the reference.
CASES = (
    ("coarse 61x51, dt 0.4 us", 61, 51, 0.4e-6),
    ("coarse 61x51, dt 0.2 us", 61, 51, 0.2e-6),
    ("default 121x101, dt 0.4 us", 121, 101, 0.4e-6),
    ("default 121x101, dt 0.2 us", 121, 101, 0.2e-6),
    ("default 121x101, dt 0.1 us", 121, 101, 0.1e-6),
    ("fine 181x151, dt 0.2 us", 181, 151, 0.2e-6),
    ("reference 241x201, dt 0.1 us", 241, 201, 0.1e-6),
)
QUICK = (("coarse 41x31, dt 0.4 us", 41, 31, 0.4e-6), ("reference 61x51, dt 0.2 us", 61, 51, 0.2e-6))


def run_bench_abs(args: argparse.Namespace) -> int:
    cases = QUICK if args.quick else CASES
    t_end = "2e-4" if args.quick else "1e-3"
    settle = "5e-5" if args.quick else "2e-4"
    rows = []
    print(f"{'case':30s} {'nodes':>6s} {'steps':>6s} {'ms/step':>8s} {'s/ms':>7s} {'FH0 [nm]':>9s} "
          f"{'meanFH':>8s} {'3sig [nm]':>9s} {'Fc [uN]':>8s}")  # fmt: skip
    for label, nx, ny, dt in cases:
        scene = load_scene(args.scene, [f"numerics.nx={nx}", f"numerics.ny={ny}", f"numerics.dt={dt}",
                                        f"numerics.output_interval={max(dt, 1e-6)}", f"numerics.t_end={t_end}",
                                        f"numerics.settle_time={settle}"])  # fmt: skip
        steady = fly_start(scene)
        walls = []
        for _ in range(max(1, args.repeats if not label.startswith("reference") else 1)):
            t0 = time.perf_counter()
            result = simulate_abs(scene, steady=steady)
            walls.append(time.perf_counter() - t0)
        s = summarize(result, scene)
        wall = statistics.median(walls)
        steps = result.work["steps"]
        row = {
            "case": label, "nx": nx, "ny": ny, "dt": dt, "nodes": nx * ny, "steps": steps,
            "wall_per_run": wall, "wall_per_step": wall / max(steps, 1),
            "wall_per_ms": wall / (scene.numerics.t_end / 1e-3), "status": result.status,
            "steady_flying_height": steady.element_spacing, "mean_flying_height": s["mean_flying_height"],
            "bouncing_3sigma": s["bouncing_3sigma"], "mean_contact_force": s["mean_contact_force"],
            "halvings": result.work["step_halvings"],
        }  # fmt: skip
        rows.append(row)
        print(f"{label:30s} {nx * ny:6d} {steps:6d} {row['wall_per_step'] * 1e3:8.3f} {row['wall_per_ms']:7.2f} "
              f"{row['steady_flying_height'] * 1e9:9.4f} {row['mean_flying_height'] * 1e9:8.4f} "
              f"{row['bouncing_3sigma'] * 1e9:9.5f} {row['mean_contact_force'] * 1e6:8.4f}", flush=True)  # fmt: skip
    ref = rows[-1]
    base = next((r for r in rows if r["case"].startswith("default") and abs(r["dt"] - 0.2e-6) < 1e-12), rows[0])
    print(f"\nerrors against {ref['case']}; cost relative to {base['case']} measured in this session")
    print(f"{'case':30s} {'FH0 err [nm]':>12s} {'meanFH err':>10s} {'3sig err [%]':>12s} {'cost x':>7s}")
    for r in rows:
        r["steady_fh_error"] = abs(r["steady_flying_height"] - ref["steady_flying_height"])
        r["mean_fh_error"] = abs(r["mean_flying_height"] - ref["mean_flying_height"])
        r["bouncing_error"] = abs(r["bouncing_3sigma"] / ref["bouncing_3sigma"] - 1.0)
        r["cost_ratio"] = r["wall_per_run"] / base["wall_per_run"]
        print(f"{r['case']:30s} {r['steady_fh_error'] * 1e9:12.5f} {r['mean_fh_error'] * 1e9:10.5f} "
              f"{100 * r['bouncing_error']:12.2f} {r['cost_ratio']:7.2f}")  # fmt: skip
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
            coords={"case": ("case", np.array([r["case"] for r in rows]))},
        )
        ds.attrs.update(base_attrs("Scene 2 benchmark: cost per step and per simulated ms against error"))
        ds.attrs["reference"] = ref["case"]
        ds.attrs["baseline"] = base["case"]
        print(f"wrote {write_netcdf(ds, args.output)}")
    return 0
