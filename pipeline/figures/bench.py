"""The work-precision figure of a scene-1 bench file."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from pipeline.figures.common import pyplot

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def plot_work_precision(ds: xr.Dataset) -> Figure:
    """Work-precision figure of ``hdi bench``: error against wall time per run, one line per family.

    Left: the largest relative error of the first impulses of the contact
    sequence against the reference; middle: the time-stepping error alone
    (fixed and adaptive, against the smallest fixed step on the same grid);
    right: the gimbal-height error of the flying run (no contact).
    Air-bearing levels are single markers; the dashed line is the 1 % target,
    the star the recommended setting.  One legend below the panels.
    """
    from matplotlib.ticker import NullFormatter

    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.6), layout="constrained")
    families = list(dict.fromkeys(ds["family"].values.tolist()))
    markers = dict(zip(families, "osD^v<>", strict=False))
    colours = dict(zip(families, plt.rcParams["axes.prop_cycle"].by_key()["color"], strict=False))
    level_colours = {"quasi_static": "tab:purple", "linearized": "tab:brown"}
    recommended = ds.attrs.get("recommended_case", "")
    for ax, var, title in (
        (axes[0], "max_impulse_error", "contact sequence: first 3 impulses vs reference"),
        (axes[1], "time_error", "time stepping alone: first 3 impulses vs smallest step"),
        (axes[2], "flying_error", "flying (no contact): gimbal height vs reference"),
    ):
        for fam in families:
            sel = ds.where(ds["family"] == fam, drop=True)
            if var == "time_error" and fam not in ("fixed step", "adaptive step"):
                continue
            wall = sel["wall_per_run"].values.astype(float)
            err = sel[var].values.astype(float)
            if var == "time_error":  # the family's own reference has no error to show
                keep = err > 0.0
                sel, wall, err = sel.isel(case=keep), wall[keep], err[keep]
            err = np.maximum(err, 1e-7)
            if fam == "air-bearing level":
                for w, e, lab in zip(wall, err, sel["case"].values, strict=True):
                    ax.loglog(w, e, marker="X", ms=10, ls="none", color=level_colours.get(str(lab), "k"),
                              label=f"{lab} (built once per scene)")  # fmt: skip
                continue
            order = np.argsort(wall)
            ax.loglog(wall[order], err[order], marker=markers[fam], color=colours[fam], label=fam)
            for w, e, lab in zip(wall, err, sel["case"].values, strict=True):
                ax.annotate(str(lab), (w, e), fontsize=6.5, xytext=(3, 3), textcoords="offset points")
        if recommended and recommended in ds["case"].values and var != "time_error":
            r = ds.sel(case=recommended)
            rr = r.isel(case=0) if "case" in r.dims else r
            ax.loglog(float(rr["wall_per_run"]), max(float(rr[var]), 1e-7), marker="*", ms=16, color="gold",
                      mec="k", ls="none", label="recommended", zorder=5)  # fmt: skip
        if var != "flying_error":
            ax.axhline(0.01, color="k", ls="--", lw=0.8)
            ax.text(ax.get_xlim()[0], 0.0105, " 1 % target", fontsize=8, va="bottom")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time per 300-us run [s] (one core)")
        ax.set_ylabel("relative error [-]" if var != "flying_error" else "max |z - z_ref| / max |z_ref - z_s| [-]")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=8)
    fig.suptitle(f"Scene 1 speed against error (reference {ds.attrs.get('reference', '')})", fontsize=11)
    return fig
