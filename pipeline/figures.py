"""Figures are functions of datasets: no computation, matplotlib imported lazily.

``plot_run``: the source's Figures 9-16 style: vertical displacement, pitch
and roll against time, and the impact history as spikes labelled with the
corner struck.  ``plot_fly``: the steady pressure over both rails.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

if TYPE_CHECKING:
    from matplotlib.figure import Figure

CORNER_COLOURS = {"A": "tab:red", "B": "tab:blue", "C": "tab:orange", "D": "tab:green"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_run(ds: xr.Dataset, title: str | None = None) -> Figure:
    """Time histories and impact spikes of one run dataset."""
    plt = _pyplot()
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
        cfg = _scene_values(ds)
        title = (
            f"{ds.attrs.get('scene', '')}: mu = {cfg.get('mu', '?')}, alpha = {cfg.get('alpha', '?')}, "
            f"zdot0 = {cfg.get('zdot', '?')} m/s -- {int(ds['n_impacts'])} impacts, {verdict}"
        )
    fig.suptitle(title, fontsize=11)
    return fig


def _scene_values(ds: xr.Dataset) -> dict[str, object]:
    import tomllib

    try:
        scene = tomllib.loads(ds.attrs.get("scene_toml", ""))
    except tomllib.TOMLDecodeError:
        return {}
    return {**scene.get("contact", {}), **scene.get("initial", {})}


def plot_fly(ds: xr.Dataset) -> Figure:
    """Steady pressure over the two rails (map) and along each rail's centre line."""
    plt = _pyplot()
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


def save_figure(fig: Figure, path: str | Path, dpi: int = 120) -> Path:
    """Save and close a figure."""
    plt = _pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def plot_dataset(ds: xr.Dataset) -> Figure:
    """The figure that fits a dataset written by this project."""
    if "impact_time" in ds and "time" in ds.dims:
        return plot_run(ds)
    if "pressure" in ds:
        return plot_fly(ds)
    raise ValueError("no figure fits this dataset (expected a run or a fly file)")
