"""The figures of the bench files: work-precision of scene 1, settings against today's solver of scene 2."""

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


def plot_scene2_bench(ds: xr.Dataset) -> Figure:
    """The scene-2 bench: cost of each setting against the baseline solver, and its statistics over the tracks.

    Left: wall time per simulated millisecond of each timed setting (bars, with the speed-up over the baseline),
    the baseline solver's own default run measured in the same session (dashed) and the 5-s target (dotted).
    Then one panel per run statistic: every track's value (dots, grey lines pair a track across settings) and the
    mean with its 95 % CI, the fine reference's CI shaded.  A setting whose CI is wider than 5 times the median CI
    (a track that went into hard contact) is left off the scale and written in the panel.
    """
    plt = pyplot()
    stats = (("bouncing_3sigma", 1e9, "bouncing 3-sigma [nm]"), ("mean_contact_force", 1e6, "mean contact force [uN]"),
             ("mean_flying_height", 1e9, "mean flying height [nm]"))  # fmt: skip
    fig, axes = plt.subplots(1, 4, figsize=(17, 5.0), layout="constrained")
    ax = axes[0]
    timed = [str(s) for s in ds["timed"].values]
    per_ms = ds["setting_wall_per_ms"].values.astype(float)
    bars = ax.bar(range(len(timed)), per_ms, color="tab:blue")
    for bar, speedup in zip(bars, ds["setting_speedup"].values.astype(float), strict=True):
        if np.isfinite(speedup):
            ax.annotate(f"{speedup:.2f}x", (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center",
                        va="bottom", fontsize=9)  # fmt: skip
    base = float(ds["baseline_wall_per_ms"])
    if np.isfinite(base):
        ax.axhline(base, color="k", ls="--", lw=1.0, label=f"baseline solver's own run, same session ({base:.1f} s)")
    ax.axhline(5.0, color="tab:red", ls=":", lw=1.2, label="target: 5 s per simulated ms")
    ax.margins(y=0.35)  # room for the speed-up labels and the legend above the bars
    ax.set_xticks(range(len(timed)), timed, rotation=30, ha="right", rotation_mode="anchor", fontsize=8)
    ax.set_ylabel("wall time per simulated ms [s] (one core, median)")
    ax.set_title("cost of the default run", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    settings = [str(s) for s in ds["setting"].values]
    x = np.arange(len(settings))
    for ax, (key, scale, label) in zip(axes[1:], stats, strict=True):
        by_seed = ds[key + "_by_seed"].values.astype(float) * scale
        ax.plot(x, by_seed, color="0.75", lw=0.6, marker=".", ms=4, zorder=1)
        mean = ds[key + "_mean"].values.astype(float) * scale
        ci = ds[key + "_ci"].values.astype(float) * scale
        ax.errorbar(x, mean, yerr=ci, fmt="o", color="tab:orange", capsize=4, zorder=3, label="mean, 95 % CI")
        ax.axhspan(mean[-1] - ci[-1], mean[-1] + ci[-1], color="tab:green", alpha=0.15, label="reference CI")
        _zoom_past_outliers(ax, x, mean, ci)
        if key == "mean_contact_force":  # a skewed sample's t-interval reaches below zero: the force does not
            ax.set_ylim(bottom=max(ax.get_ylim()[0], 0.0))
        ax.set_xticks(x, settings, rotation=30, ha="right", rotation_mode="anchor", fontsize=8)
        ax.set_ylabel(label)
        ax.set_title(f"{label.split(' [')[0]} over {ds.sizes['seed']} tracks", fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle(f"Scene 2 bench: {ds.attrs.get('baseline_solver', '')}; recommended "
                 f"{ds.attrs.get('recommended_setting', '')}", fontsize=10)  # fmt: skip
    return fig


def _zoom_past_outliers(ax, x: np.ndarray, mean: np.ndarray, ci: np.ndarray) -> None:
    """Limit the y axis to the settings whose CI is at most 5x the median CI; write the others' mean +- CI."""
    finite = np.isfinite(mean) & np.isfinite(ci)
    if not finite.any():
        return
    typical = ci[finite] <= 5.0 * np.median(ci[finite])
    kept = np.flatnonzero(finite)[typical]
    lo, hi = float(np.min(mean[kept] - ci[kept])), float(np.max(mean[kept] + ci[kept]))
    pad = 0.25 * (hi - lo) if hi > lo else 0.05 * abs(hi) + 1e-30
    ax.set_ylim(lo - pad, hi + pad)
    for k in np.flatnonzero(finite)[~typical]:
        ax.annotate(f"{mean[k]:.3g} +- {ci[k]:.2g}\n(off scale)", (x[k], hi + 0.6 * pad), ha="center", va="center",
                    fontsize=8, color="tab:orange")  # fmt: skip
