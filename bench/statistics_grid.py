"""Are scene 2's run statistics converged on the grid?  The default run on several grids, track by track.

Each (grid, seed) is one 1-ms run of ``studies/scenes/chen_bogy2007.toml`` from its own steady flight; a seed is
the same track on every grid (box-filtered over each grid's cells), so the runs pair.  Records go to a JSON-lines
file, one per run, and a rerun skips the runs already there (kill it and start again: it resumes).  The report
gives, per grid, the mean and 95 % half-width of the 3-sigma bouncing, mean flying height, mean contact force and
contact fraction, and the paired difference of every grid to the finest.

    python bench/statistics_grid.py --grids 121x101,161x135,181x151,241x201 --seeds 1-4 -o grid.jsonl
    python bench/statistics_grid.py --grids 121x101,241x201 --seeds 5-8 -o grid.jsonl   # more tracks, two grids
    python bench/statistics_grid.py --report -o grid.jsonl                             # the table only
    python bench/statistics_grid.py --report -o grid.jsonl --netcdf results/statistics_grid.nc \
        --figure results/statistics_grid.png                                           # and the file, the figure

A default run costs about 45 s at 121 x 101 and 170 s at 241 x 201 on one core.  Each record keeps the commit
it was computed at; the netCDF file lists them (``run_commits``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import xarray as xr
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"
MEASURES = (
    ("bouncing_3sigma", 1e9, "nm"),
    ("mean_flying_height", 1e9, "nm"),
    ("mean_contact_force", 1e6, "uN"),
    ("contact_fraction", 100.0, "%"),
)
#: Measures that cannot be negative: their panels stop at zero.
NON_NEGATIVE = ("mean_contact_force", "contact_fraction")


def parse_range(text: str) -> list[int]:
    """'1-4' or '1,3,5' -> the seeds; anything else is an error naming the option."""
    try:
        if "-" in text:
            lo, hi = (int(v) for v in text.split("-"))
            seeds = list(range(lo, hi + 1))
        else:
            seeds = [int(v) for v in text.split(",")]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0:
        raise SystemExit(f"--seeds {text!r} is not allowed: a range 'LO-HI' or a list '1,3,5' of seeds >= 0")
    return seeds


def parse_grids(text: str) -> list[tuple[int, int]]:
    """'121x101,241x201' -> [(121, 101), (241, 201)]; anything else is an error naming the option."""
    try:
        grids = [tuple(int(v) for v in g.split("x")) for g in text.split(",")]
    except ValueError:
        grids = []
    if not grids or any(len(g) != 2 or min(g) < 11 for g in grids):
        raise SystemExit(f"--grids {text!r} is not allowed: NXxNY,... with at least 11 nodes each (e.g. 121x101)")
    return grids


def run(grids: list[tuple[int, int]], seeds: list[int], out: Path) -> None:
    from pipeline.provenance import git_commit
    from solver.abs.integrate import simulate_abs, summarize
    from solver.kinds import scene_from_dict

    done = {(r["nx"], r["ny"], r["seed"]) for r in read(out)}
    for seed in seeds:
        for nx, ny in grids:
            if (nx, ny, seed) in done:
                continue
            data = tomllib.loads(SCENE.read_text())
            data["numerics"].update(nx=nx, ny=ny)
            data["disk"]["seed"] = seed
            scene = scene_from_dict(data, source=str(SCENE))
            wall = time.perf_counter()
            result = simulate_abs(scene)
            record = {"nx": nx, "ny": ny, "seed": seed, "status": result.status, "message": result.message,
                      "wall": time.perf_counter() - wall, "git_commit": git_commit(),
                      **summarize(result, scene)}  # fmt: skip
            with out.open("a") as f:
                f.write(json.dumps(record) + "\n")
            print(f"{nx} x {ny} seed {seed}: 3-sigma {record['bouncing_3sigma'] * 1e9:.3f} nm, "
                  f"{record['wall']:.0f} s", flush=True)  # fmt: skip


def read(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def mean_ci(values: list[float]) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    half = stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size) if v.size > 1 else float("nan")
    return float(v.mean()), float(half)


def report(path: Path) -> None:
    by_grid = grouped(path)
    if not by_grid:
        raise SystemExit(f"{path}: no finished runs (is it a file this script wrote with -o?)")
    finest = max(by_grid)
    for name, scale, unit in MEASURES:
        print(name)
        for grid in sorted(by_grid):
            runs = by_grid[grid]
            m, h = mean_ci([runs[s][name] * scale for s in sorted(runs)])
            line = f"  {grid[0]:3d} x {grid[1]:<3d} n = {len(runs)}: {m:.4g} +- {h:.2g} {unit}"
            common = sorted(set(runs) & set(by_grid[finest]))
            if grid != finest and len(common) > 1:
                dm, dh = mean_ci([(runs[s][name] - by_grid[finest][s][name]) * scale for s in common])
                line += f"   paired with {finest[0]} x {finest[1]} (n = {len(common)}): {dm:+.3g} +- {dh:.2g}"
            print(line)


def grouped(path: Path) -> dict[tuple[int, int], dict[int, dict]]:
    """The finished runs of ``path`` by grid and seed."""
    by_grid: dict[tuple[int, int], dict[int, dict]] = {}
    for r in read(path):
        if r["status"] == 0:
            by_grid.setdefault((r["nx"], r["ny"]), {})[r["seed"]] = r
    return by_grid


def dataset(path: Path):
    """The runs as an xarray Dataset: each measure on (grid, seed), NaN where a run is missing, and per grid
    the mean, the 95 % half-width and the paired difference to the finest grid with its half-width."""

    from pipeline.data.netcdf import var
    from pipeline.provenance import base_attrs

    by_grid = grouped(path)
    grids = sorted(by_grid)
    seeds = sorted({s for runs in by_grid.values() for s in runs})
    finest = grids[-1]
    data = {}
    for name, _scale, unit in MEASURES:
        units = {"nm": "m", "uN": "N", "%": "1"}[unit]  # stored in SI (a fraction for the contact time)
        table = np.full((len(grids), len(seeds)), np.nan)
        for g, grid in enumerate(grids):
            for k, seed in enumerate(seeds):
                if seed in by_grid[grid]:
                    table[g, k] = by_grid[grid][seed][name]
        data[name] = var(table, ("grid", "realization"), units, f"{name.replace('_', ' ')} of each run")
        mean, half, diff, diff_half = (np.full(len(grids), np.nan) for _ in range(4))
        for g, grid in enumerate(grids):
            row = table[g][np.isfinite(table[g])]
            mean[g], half[g] = mean_ci(list(row)) if row.size else (np.nan, np.nan)
            both = np.isfinite(table[g]) & np.isfinite(table[-1])
            if grid != finest and np.count_nonzero(both) > 1:
                diff[g], diff_half[g] = mean_ci(list(table[g][both] - table[-1][both]))
        data[f"{name}_mean"] = var(mean, ("grid",), units, f"mean of {name.replace('_', ' ')} over the tracks")
        data[f"{name}_ci95"] = var(half, ("grid",), units, "half-width of its 95 % confidence interval (t)")
        data[f"{name}_paired"] = var(diff, ("grid",), units, f"paired difference to {finest[0]} x {finest[1]}")
        data[f"{name}_paired_ci95"] = var(diff_half, ("grid",), units, "half-width of the paired difference's 95 % CI")
    commits = sorted({r.get("git_commit", "unrecorded") for runs in by_grid.values() for r in runs.values()})
    attrs = base_attrs("Scene 2: the default run's statistics against the grid, track by track")
    attrs.update(
        product="statistics_grid",
        scene_file=str(SCENE.relative_to(ROOT)),
        run_commits=", ".join(commits),
        command="python bench/statistics_grid.py --report -o RUNS.jsonl --netcdf FILE.nc",
    )
    coords = {
        "nx": ("grid", np.array([g[0] for g in grids]), {"long_name": "nodes along the slider", "units": "1"}),
        "ny": ("grid", np.array([g[1] for g in grids]), {"long_name": "nodes across the slider", "units": "1"}),
        "realization": ("realization", np.array(seeds), {"long_name": "track seed (disk.seed)", "units": "1"}),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def figure(ds, path: Path):
    """Each measure against the grid: the tracks (grey, joined by seed) and the mean with its 95 % interval; the
    figure (closed) is returned."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(MEASURES), figsize=(4.2 * len(MEASURES), 3.8), constrained_layout=True)
    x = ds["nx"].values
    for ax, (name, scale, unit), letter in zip(axes, MEASURES, "abcd", strict=True):
        table = ds[name].values * scale
        for k in range(table.shape[1]):
            ok = np.isfinite(table[:, k])
            ax.plot(x[ok], table[ok, k], color="0.75", lw=0.8, marker=".", ms=3)
        ax.errorbar(x, ds[f"{name}_mean"].values * scale, yerr=ds[f"{name}_ci95"].values * scale, fmt="o",
                    color="C1", capsize=4, label="mean, 95 % CI")  # fmt: skip
        ax.set_xlabel("nodes along the slider (nx)")
        ax.set_ylabel(f"{name.replace('_', ' ')} [{unit}]")
        ax.set_xticks(x)
        ax.set_title(f"({letter})", loc="left")
        if name == "mean_contact_force":
            ax.set_yscale("symlog", linthresh=0.1)
        if name in NON_NEGATIVE:  # a t-interval of a skewed sample can reach below zero: the axis stops at 0
            ax.set_ylim(bottom=0.0)
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle("Scene 2: the default run against the grid (grey: one track, the same seed on every grid)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return fig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--grids", default="121x101,241x201", help="NXxNY,... (default: 121x101,241x201)")
    parser.add_argument("--seeds", default="1-8", help="track seeds, '1-8' or '1,2,5'")
    parser.add_argument("-o", "--out", type=Path, default=Path("statistics_grid.jsonl"))
    parser.add_argument("--report", action="store_true", help="only print the table of the runs in --out")
    parser.add_argument("--netcdf", type=Path, help="write the runs and their statistics to this netCDF file")
    parser.add_argument("--figure", type=Path, help="draw them into this PNG")
    parser.add_argument("--redraw", type=Path, help="only draw --figure from this netCDF file (written by --netcdf)")
    args = parser.parse_args()
    if args.redraw:
        if not args.figure:
            parser.error("--redraw needs --figure")
        with xr.open_dataset(args.redraw) as ds:
            figure(ds.load(), args.figure)
        print(f"wrote {args.figure}")
        return
    if not args.report:
        run(parse_grids(args.grids), parse_range(args.seeds), args.out)
    report(args.out)
    if args.netcdf or args.figure:
        ds = dataset(args.out)
        if args.netcdf:
            from pipeline.data.netcdf import write_netcdf

            print(f"wrote {write_netcdf(ds, args.netcdf)}")
        if args.figure:
            figure(ds, args.figure)
            print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
