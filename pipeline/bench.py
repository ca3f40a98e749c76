"""``hdi bench``: cost per step and per run against error, over grids and time steps.

For scene 1 it runs the source's disturbance (mu = 0.5, alpha = 0.8) on a
family of grids (nodes along x across a rail) at dt = 0.1 us and a family
of time steps at the source's grid, times each case (median of repeats;
the machine is shared and noisy), and reports the error of the first
impulses and impact times against the finest case.  A baseline measured in
the same run, a Newton step with the exact Jacobian and a scipy sparse
direct solve on the same grid, gives the speed-up of the approximate
factorisation at equal step.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import xarray as xr

from solver.airbearing import make_film
from solver.integrate import simulate
from solver.kernels import reynolds as kr
from solver.params import Numerics, Scene
from solver.steady import fly

from .config import load_scene
from .provenance import base_attrs
from .store import var, write_netcdf

GRIDS = [(51, 9, 7), (101, 16, 11), (201, 31, 21), (401, 61, 41)]
QUICK_GRIDS = [(51, 9, 7), (101, 16, 11), (201, 31, 21)]
STEPS = [0.4e-6, 0.2e-6, 0.1e-6, 0.05e-6]
N_COMPARED = 3  # impulses compared between cases (later impacts of a chaotic sequence drift apart)


def _scene(base: Scene, nx: int, nt: int, ny: int, dt: float, t_end: float) -> Scene:
    interval = dt * max(1, round(base.numerics.output_interval / dt))
    num = dataclasses.replace(base.numerics, nx=nx, nx_taper=nt, ny=ny, dt=dt, t_end=t_end, output_interval=interval)
    return dataclasses.replace(base, numerics=num)


def sparse_direct_step_cost(scene: Scene, n_steps: int = 10) -> float:
    """Median seconds per step of the baseline: exact-Jacobian midpoint step, scipy sparse direct solve."""
    film = make_film(scene)
    steady = fly(scene, film=film)
    q_old = steady.q
    q_new = steady.q + np.array([-1e-9, 5e-7, 1e-6])
    shape = film.P.shape
    ny = shape[2]
    R = np.zeros(shape)
    J = [np.zeros(shape) for _ in range(6)]
    interior = np.zeros(shape, dtype=bool)
    interior[:, 1:-1, 1:-1] = True
    H_new, H_old = np.empty(shape), np.empty(shape)
    film.fill_spacing(q_new, H_new, np.empty_like(film.Hx), np.empty_like(film.Hy))
    film.fill_spacing(q_old, H_old, np.empty_like(film.Hx), np.empty_like(film.Hy))
    film.fill_spacing(0.5 * (q_old + q_new), film.H_mid, film.Hx_mid, film.Hy_mid)
    ct = film.sigma / scene.numerics.dt
    P = film.P.copy()
    times = []
    for _ in range(n_steps):
        t0 = time.perf_counter()
        kr.assemble(P, film.H_mid, film.Hx_mid, film.Hy_mid, film.dx, film.dy, film.dxc, film.dyc,
                    film.lam, film.kn, film.c1, film.c2, R, *J, True)  # fmt: skip
        Jcx, Jxm, Jxp, Jcy, Jym, Jyp = J
        diag_t = ct * film.area[None] * H_new
        main = np.ones(P.size)
        main[interior.ravel()] = (diag_t + 0.5 * (Jcx + Jcy))[interior]
        mat = sp.diags(
            [main, 0.5 * Jym.ravel()[1:], 0.5 * Jyp.ravel()[:-1], 0.5 * Jxm.ravel()[ny:], 0.5 * Jxp.ravel()[:-ny]],
            [0, -1, 1, -ny, ny],
            format="csc",
        )
        rhs = np.where(interior, -(ct * film.area[None] * (P * H_new - film.P * H_old) + R), 0.0).ravel()
        spla.spsolve(mat, rhs)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _measure(scene: Scene, repeats: int) -> dict[str, float]:
    steady = fly(scene)
    simulate(scene, steady)  # warm-up (JIT, caches)
    walls, result = [], None
    for _ in range(repeats):
        result = simulate(scene, steady)
        walls.append(result.work["wall_time"])
    assert result is not None
    imp = result.impacts[:N_COMPARED]
    row = {
        "wall_per_run": float(np.median(walls)),
        "wall_per_step": float(np.median(walls)) / result.work["steps"],
        "steps": result.work["steps"],
        "newton_iterations": result.work["newton_iterations"],
        "n_impacts": len(result.impacts),
        "preload": steady.suspension.preload,
    }
    for k in range(N_COMPARED):
        row[f"impulse_{k + 1}"] = imp[k].impulse if k < len(imp) else np.nan
        row[f"impact_time_{k + 1}"] = imp[k].time if k < len(imp) else np.nan
        row[f"corner_{k + 1}"] = imp[k].corner if k < len(imp) else -1
    return row


def run_bench(args: argparse.Namespace) -> int:
    base = load_scene(args.scene, ["contact.mu=0.5", "contact.alpha=0.8"])
    t_end = 60e-6 if args.quick else 300e-6
    grids = QUICK_GRIDS if args.quick else GRIDS
    steps = [0.2e-6, 0.1e-6] if args.quick else STEPS
    cases: list[tuple[str, Scene]] = []
    for nx, nt, ny in grids:
        cases.append((f"grid {nx}x{ny} dt 0.1us", _scene(base, nx, nt, ny, 1e-7, t_end)))
    src = Numerics()
    for dt in steps:
        if dt != 1e-7:
            cases.append(
                (f"grid {src.nx}x{src.ny} dt {dt * 1e6:g}us", _scene(base, src.nx, src.nx_taper, src.ny, dt, t_end))
            )
    rows = []
    for label, scene in cases:
        row = _measure(scene, args.repeats)
        rows.append((label, scene, row))
        print(
            f"{label:28s} {row['wall_per_step'] * 1e3:8.4f} ms/step {row['wall_per_run']:8.3f} s/run "
            f"impacts {row['n_impacts']:3d}  q1 {row['impulse_1'] * 1e6:.5f} uN s  "
            f"t1 {row['impact_time_1'] * 1e6:.4f} us",
            flush=True,
        )
    finest = max(range(len(grids)), key=lambda i: rows[i][1].numerics.nx)
    on_src = [i for i, (_, sc, _) in enumerate(rows) if (sc.numerics.nx, sc.numerics.ny) == (src.nx, src.ny)]
    on_src.sort(key=lambda i: -rows[i][1].numerics.dt)
    smallest = on_src[-1]
    heads = " ".join(f"{'err q' + str(k + 1):>9s}" for k in range(N_COMPARED))
    table = []
    for title, members, ref_index in (
        (f"grids at dt 0.1 us, errors against {rows[finest][0]}", range(len(grids)), finest),
        (f"time steps at {src.nx}x{src.ny}, errors against {rows[smallest][0]}", on_src, smallest),
    ):
        print(f"\n{title}\n{'case':28s} {'ms/step':>8s} {'s/run':>8s} {heads} {'err t1 [ns]':>11s}")
        ref = rows[ref_index][2]
        for i in members:
            label, scene, row = rows[i]
            errs = [abs(row[f"impulse_{k + 1}"] / ref[f"impulse_{k + 1}"] - 1.0) for k in range(N_COMPARED)]
            err_t = abs(row["impact_time_1"] - ref["impact_time_1"]) * 1e9
            table.append((f"{label} (vs {rows[ref_index][0]})", scene, row, errs, err_t))
            print(f"{label:28s} {row['wall_per_step'] * 1e3:8.4f} {row['wall_per_run']:8.3f} "
                  + " ".join(f"{e:9.2e}" for e in errs) + f" {err_t:11.4f}")  # fmt: skip
    src_scene = _scene(base, src.nx, src.nx_taper, src.ny, 1e-7, t_end)
    baseline = sparse_direct_step_cost(src_scene)
    ours = next(r for lbl, s, r in rows if lbl.startswith(f"grid {src.nx}x{src.ny} dt 0.1us"))
    print(
        f"\nbaseline at {src.nx}x{src.ny}, dt 0.1 us: exact-Jacobian Newton step with scipy sparse direct solve "
        f"{baseline * 1e3:.2f} ms/step (~{baseline * round(t_end / 1e-7):.1f} s per {t_end * 1e6:.0f}-us run); "
        f"this solver {ours['wall_per_step'] * 1e3:.3f} ms/step: {baseline / ours['wall_per_step']:.1f}x faster"
    )
    if args.output:
        n = len(table)
        ds = xr.Dataset(
            {
                "wall_per_step": var(
                    [r["wall_per_step"] for _, _, r, _, _ in table], ("case",), "s", "median wall time per step"
                ),
                "wall_per_run": var(
                    [r["wall_per_run"] for _, _, r, _, _ in table], ("case",), "s", "median wall time per run"
                ),
                "nx": var([s.numerics.nx for _, s, _, _, _ in table], ("case",), "1", "nodes along a rail"),
                "ny": var([s.numerics.ny for _, s, _, _, _ in table], ("case",), "1", "nodes across a rail"),
                "dt": var([s.numerics.dt for _, s, _, _, _ in table], ("case",), "s", "time step"),
                "n_impacts": var([r["n_impacts"] for _, _, r, _, _ in table], ("case",), "1", "impacts in the run"),
                "first_impulse": var([r["impulse_1"] for _, _, r, _, _ in table], ("case",), "N s", "first impulse"),
                "impulse_error": var(
                    [e for _, _, _, e, _ in table],
                    ("case", "k"),
                    "1",
                    "relative error of impulse k against the finest case",
                ),  # fmt: skip
                "impact_time_error": var([t * 1e-9 for *_, t in table], ("case",), "s", "first impact time error"),
                "baseline_wall_per_step": var(baseline, (), "s", "scipy sparse direct Newton step (same grid)"),
            },
            coords={"case": ("case", [lbl for lbl, *_ in table]), "k": ("k", np.arange(1, N_COMPARED + 1))},
        )
        ds.attrs.update(base_attrs("hdi bench: cost against error, scene 1"))
        ds.attrs["t_end"] = t_end
        ds.attrs["cases"] = n
        print(f"wrote {write_netcdf(ds, args.output)}")
    return 0
