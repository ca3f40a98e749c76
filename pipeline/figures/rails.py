"""Figures are functions of datasets: no computation, matplotlib imported lazily.

``plot_run``: the source's Figures 9-16 style: vertical displacement, pitch
and roll against time, and the impact history as spikes labelled with the
corner struck.  ``plot_fly``: the steady pressure over both rails.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from pipeline.figures.common import pyplot, scene_values

if TYPE_CHECKING:
    from matplotlib.figure import Figure

CORNER_COLOURS = {"A": "tab:red", "B": "tab:blue", "C": "tab:orange", "D": "tab:green"}


def plot_run(ds: xr.Dataset, title: str | None = None) -> Figure:
    """Time histories and impact spikes of one run dataset."""
    plt = pyplot()
    fig, axes = plt.subplots(4, 1, figsize=(8.0, 9.0), sharex=True, constrained_layout=True)
    t_us = ds["time"].values * 1e6
    panels = [
        ("z", 1e6, "z [um]", "steady_z"),
        ("pitch", 1e6, "pitch [urad]", "steady_pitch"),
        ("roll", 1e6, "roll [urad]", "steady_roll"),
    ]
    for ax, (name, scale, label, steady) in zip(axes, panels, strict=False):
        ax.plot(t_us, ds[name].values * scale, color="k", lw=1.0)
        if steady in ds:
            ax.axhline(float(ds[steady]) * scale, color="0.6", lw=0.8, ls="--", label="steady flight")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    if "steady_z" in ds:
        axes[0].legend(loc="upper right", fontsize=8, frameon=False)
    ax = axes[3]
    times = ds["impact_time"].values * 1e6
    impulses = ds["impact_impulse"].values * 1e6
    letters = [str(c) for c in ds["impact_corner"].values]
    for t, q, c in zip(times, impulses, letters, strict=True):
        colour = CORNER_COLOURS.get(c, "k")
        ax.vlines(t, 0.0, q, color=colour, lw=1.6)
        ax.text(t, q, c, ha="center", va="bottom", fontsize=9, color=colour, fontweight="bold")
    if impulses.size:
        ax.axhline(impulses[0], color="0.5", lw=0.8, ls=":", label="first impulse")
        ax.legend(loc="upper right", fontsize=8, frameon=False)
        ax.set_ylim(0.0, 1.18 * impulses.max())
    ax.set_ylabel("impulse [uN s]")
    ax.set_xlabel("time [us]")
    ax.set_xlim(t_us[0], t_us[-1])
    ax.grid(alpha=0.3)
    if title is None:
        verdict = {1: "stable", 0: "unstable"}.get(int(ds["stable"]), "?")
        cfg = scene_values(ds)
        title = (
            f"{ds.attrs.get('scene', '')}: mu = {cfg.get('mu', '?')}, alpha = {cfg.get('alpha', '?')}, "
            f"zdot0 = {cfg.get('zdot', '?')} m/s -- {int(ds['n_impacts'])} impacts, {verdict}"
        )
    fig.suptitle(title, fontsize=11)
    return fig


def plot_fly(ds: xr.Dataset) -> Figure:
    """Steady pressure over the two rails (map) and along each rail's centre line."""
    plt = pyplot()
    fig, (ax_map, ax_line) = plt.subplots(
        2, 1, figsize=(8.0, 7.0), constrained_layout=True, gridspec_kw={"height_ratios": [1.3, 1]}
    )
    p = ds["pressure"].values / 1e3
    x1 = ds["x1"].values * 1e3
    x2 = ds["x2"].values * 1e3
    vmin, vmax = np.nanmin(p), np.nanmax(p)
    for r in range(p.shape[0]):
        mesh = ax_map.pcolormesh(x1, x2[r], p[r].T, shading="gouraud", vmin=vmin, vmax=vmax, cmap="viridis")
        mid = p.shape[2] // 2
        ax_line.plot(x1, p[r, :, mid], label=f"rail {r} centre line")
    fig.colorbar(mesh, ax=ax_map, label="p [kPa]")
    ax_map.set_xlabel("x1 [mm] (disk motion ->)")
    ax_map.set_ylabel("x2 [mm]")
    ax_map.set_title(
        f"steady flight: z = {float(ds['z']) * 1e6:.4f} um, pitch = {float(ds['pitch']) * 1e6:.2f} urad, "
        f"h_min = {float(ds['min_spacing']) * 1e6:.4f} um, load = {float(ds['load']):.4f} N",
        fontsize=10,
    )
    ax_map.axvline(0.0, color="w", lw=0.8, ls="--")
    ax_line.axvline(0.0, color="0.5", lw=0.8, ls="--", label="gimbal")
    ax_line.set_xlabel("x1 [mm]")
    ax_line.set_ylabel("p [kPa]")
    ax_line.grid(alpha=0.3)
    ax_line.legend(fontsize=8, frameon=False)
    return fig


CELL_COLOURS = {"stable": "#9ecae1", "unstable": "#fdae6b", "failed": "0.55", "not run": "white"}


#: Relative spread of the ratios of consecutive values below which an axis is log-spaced (a study file writes
#: log-spaced values to a few digits, e.g. 1.259e-6, 1.585e-6, ...).
LOG_SPACING_TOLERANCE = 0.01


def log_spaced(values: np.ndarray) -> bool:
    """True for three or more increasing positive values with a constant ratio and no constant step (a log axis)."""
    v = np.asarray(values, dtype=float)
    if v.size < 3 or np.any(v <= 0.0):
        return False
    ratios, steps = v[1:] / v[:-1], np.diff(v)
    geometric = np.all(ratios > 1.0) and np.ptp(ratios) <= LOG_SPACING_TOLERANCE * (ratios.mean() - 1.0)
    arithmetic = np.ptp(steps) <= LOG_SPACING_TOLERANCE * np.abs(steps).mean()
    return bool(geometric and not arithmetic)


def _middle(lower: np.ndarray, upper: np.ndarray, log: bool) -> np.ndarray:
    """The middle of a bracket: arithmetic, or geometric on a log axis."""
    return np.sqrt(lower * upper) if log else 0.5 * (lower + upper)


def _edges(values: np.ndarray) -> np.ndarray:
    """Cell edges around (possibly non-uniform) centres; geometric midpoints for log-spaced centres."""
    v = np.asarray(values, dtype=float)
    if log_spaced(v):
        return np.exp(_edges(np.log(v)))
    if v.size == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def _label(ds: xr.Dataset, dim: str) -> str:
    units = ds[dim].attrs.get("units", "")
    return f"{dim} [{units}]" if units and units != "1" else f"{dim} [-]"


def plot_stability_map(ds: xr.Dataset, overlay: xr.Dataset | None = None) -> Figure:
    """Figure 17 style: stable and unstable cells over two axes, the boundary, one panel per other value.

    Horizontal: the first axis that is not the boundary axis (mu); vertical:
    the boundary axis (alpha).  The boundary is drawn through the middle of
    its bracket with the bracket shaded; ``overlay`` (a boundary-mode study of
    the same axes) adds its bisection brackets as error bars.  A log-spaced
    axis (a corner radius) is drawn on a log scale, with geometric middles.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    if overlay is not None and overlay.attrs.get("boundary_method") != "bisection":
        raise ValueError("the overlay must be a boundary-mode study (hdi run STUDY --mode boundary)")
    plt = pyplot()
    dims = [str(d) for d in ds["stable"].dims]
    ydim = ds.attrs.get("boundary_axis", dims[1] if len(dims) > 1 else dims[0])
    xdim = next(d for d in dims if d != ydim)
    pdims = [d for d in dims if d not in (xdim, ydim)]
    panels = [dict(zip(pdims, combo, strict=True)) for combo in _product(ds, pdims)]
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.8), squeeze=False, constrained_layout=True)
    # cell class: 0 stable, 1 unstable, 2 failed, 3 not run
    cmap = ListedColormap([CELL_COLOURS[k] for k in ("stable", "unstable", "failed", "not run")])
    for ax, sel in zip(axes[0], panels, strict=True):
        cell = ds.sel(sel) if sel else ds
        stable = cell["stable"].transpose(ydim, xdim).values
        status = cell["status"].transpose(ydim, xdim).values
        klass = np.where(stable == 1, 0, 1)
        klass = np.where(status == -1, 2, klass)
        klass = np.where(status == -2, 3, klass)
        x, y = ds[xdim].values, ds[ydim].values
        ylog = log_spaced(y)
        ax.pcolormesh(_edges(x), _edges(y), klass, cmap=cmap, vmin=-0.5, vmax=3.5, edgecolors="0.85", linewidth=0.3)
        if "boundary_lower" in cell:
            _draw_boundary(ax, x, cell, "k", "boundary (grid)" if cell.attrs.get("boundary_method") == "grid"
                           else "boundary (bisection)", ylog)  # fmt: skip
        if overlay is not None and "boundary_lower" in overlay:
            osel = overlay.sel(sel) if sel else overlay
            lower, upper = osel["boundary_lower"].values, osel["boundary_upper"].values
            mid = _middle(lower, upper, ylog)
            runs = int(osel["boundary_runs"].sum())
            ax.errorbar(overlay[xdim].values, mid, yerr=np.array([mid - lower, upper - mid]), fmt="o", ms=3.5,
                        color="tab:purple", capsize=3, lw=1.2, label=f"bisection bracket ({runs} runs)")  # fmt: skip
        if "refined" in cell:
            refined = cell["refined"].transpose(ydim, xdim).values == 1
            changed = refined & (cell["stable_cheap"].transpose(ydim, xdim).values != stable)
            xx, yy = np.meshgrid(x, y)
            ax.plot(xx[refined & ~changed], yy[refined & ~changed], "o", mfc="none", mec="k", ms=4, mew=0.7,
                    label="re-run with the full scene")  # fmt: skip
            ax.plot(xx[changed], yy[changed], "x", color="k", ms=5, mew=1.0, label="re-run, class changed")
        ran = int(np.count_nonzero(status != -2))
        title = ", ".join(f"{d} = {v:g} {ds[d].attrs.get('units', '')}" for d, v in sel.items())
        ax.set_title(f"{title}  ({ran} runs)" if title else f"{ran} runs", fontsize=10)
        ax.set_xlabel(_label(ds, xdim))
        ax.set_ylabel(_label(ds, ydim))
        if ylog:
            ax.set_yscale("log")
        ax.set_xlim(_edges(x)[0], _edges(x)[-1])
        ax.set_ylim(_edges(y)[0], _edges(y)[-1])
    handles = [Patch(facecolor=CELL_COLOURS[k], edgecolor="0.6", label=k) for k in ("stable", "unstable")]
    if np.any(ds["status"].values == -1):
        handles.append(Patch(facecolor=CELL_COLOURS["failed"], edgecolor="0.6", label="failed"))
    line_handles, _ = axes[0][0].get_legend_handles_labels()
    axes[0][0].legend(handles=handles + line_handles, loc="lower left", fontsize=8, framealpha=0.9)
    fig.suptitle(ds.attrs.get("title", ds.attrs.get("study", "")), fontsize=10)
    return fig


def _product(ds: xr.Dataset, dims: list[str]) -> list[tuple]:
    import itertools

    return list(itertools.product(*(ds[d].values.tolist() for d in dims)))


def _draw_boundary(ax, x: np.ndarray, cell: xr.Dataset, colour: str, label: str, log: bool = False) -> None:
    lower = cell["boundary_lower"].values
    upper = cell["boundary_upper"].values
    ax.fill_between(x, lower, upper, color=colour, alpha=0.18, step=None, lw=0)
    ax.plot(x, _middle(lower, upper, log), color=colour, lw=1.6, marker=".", label=label)
