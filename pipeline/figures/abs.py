"""Figures of scene kind "abs": the source-style history and spectrum of one run, the sweep of a study,
and the steady pressure over the air-bearing surface.  Functions of datasets only."""

from __future__ import annotations

import textwrap
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from pipeline.data.units import display_scale
from pipeline.figures.common import pyplot

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def plot_run(ds: xr.Dataset) -> Figure:
    """Flying height, pitch, roll and contact force against time (left), their spectra (right)."""
    plt = pyplot()
    fig, axes = plt.subplots(4, 2, figsize=(11.0, 9.0), constrained_layout=True, gridspec_kw={"width_ratios": [3, 2]})
    t_ms = ds["time"].values * 1e3
    settle = float(ds.attrs.get("settle_time", 0.0)) * 1e3
    rows = [
        ("flying_height", 1e9, "flying height [nm]", "flying_height_spectrum", "[nm]"),
        ("pitch", 1e6, "pitch [urad]", "pitch_spectrum", "[urad]"),
        ("roll", 1e6, "roll [urad]", "roll_spectrum", "[urad]"),
        ("contact_force", 1e3, "contact force [mN]", None, ""),
    ]
    f_khz = ds["frequency"].values * 1e-3
    for k, (name, scale, label, spec, sunit) in enumerate(rows):
        ax = axes[k, 0]
        ax.plot(t_ms, ds[name].values * scale, color="k", lw=0.7)
        ax.axvspan(t_ms[0], settle, color="0.9", lw=0)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.set_xlim(t_ms[0], t_ms[-1])
        sax = axes[k, 1]
        if spec is not None:
            amp = ds[spec].values * scale
            sax.plot(f_khz[1:], amp[1:], color="tab:blue", lw=0.8)
            peak = 1 + int(np.argmax(amp[1:])) if amp.size > 1 else 0
            if peak:
                sax.annotate(f"{f_khz[peak]:.0f} kHz", (f_khz[peak], amp[peak]), textcoords="offset points",
                             xytext=(4, 2), fontsize=8)  # fmt: skip
            sax.set_xscale("log")
            sax.set_ylabel(f"amplitude {sunit}")
            sax.grid(alpha=0.3, which="both")
        else:
            sax.axis("off")
            text = (
                f"3$\\sigma$ bouncing  {float(ds['bouncing_3sigma']) * 1e9:.3f} nm\n"
                f"mean FH  {float(ds['mean_flying_height']) * 1e9:.3f} nm\n"
                f"mean contact force  {float(ds['mean_contact_force']) * 1e3:.4f} mN\n"
                f"contact fraction  {float(ds['contact_fraction']):.3f}\n"
                f"steady FH  {float(ds['steady_flying_height']) * 1e9:.3f} nm"
            )
            sax.text(0.02, 0.95, text, va="top", family="monospace", fontsize=9, transform=sax.transAxes)
    axes[3, 0].set_xlabel("time [ms] (grey: settling, left out of the statistics)")
    axes[2, 1].set_xlabel("frequency [kHz]")
    fig.suptitle(f"{ds.attrs.get('scene', '')}: partial-contact run", fontsize=11)
    return fig


def plot_study(ds: xr.Dataset) -> Figure:
    """3-sigma bouncing and mean contact force against the first axis, one line per value of the others."""
    plt = pyplot()
    dims = [d for d in ds["status"].dims if d != "realization"]
    first, rest = dims[0], dims[1:]
    n_real = ds.sizes.get("realization", 1)
    if n_real > 1:  # each cell's mean over the realisations, with its 95 % confidence interval as error bar
        ds = ds.assign({name: ds[f"{name}_mean"] for name in ("bouncing_3sigma", "mean_contact_force")})
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.0), constrained_layout=True)
    x = ds[first].values
    scale_x, xunit = _scale(ds[first])
    names = None
    if x.dtype.kind in "OUS":  # a named axis (a model law): the cells side by side, named on the ticks
        names, x, scale_x = [str(v) for v in x], np.arange(x.size, dtype=float), 1.0
    stacked = ds.stack(line=rest) if rest else ds.expand_dims(line=[0])
    force_scale, force_unit = _force_scale(ds["mean_contact_force"].values)
    lines = range(stacked.sizes["line"])
    panels = ((axes[0], "bouncing_3sigma", 1e9), (axes[1], "mean_contact_force", force_scale))
    every = {name: np.array([stacked.isel(line=k)[name].values * scale for k in lines]) for _, name, scale in panels}
    for k in lines:
        cell = stacked.isel(line=k)
        label = ", ".join(_cell_label(cell, ds, d) for d in rest) or None
        for ax, name, scale in panels:
            y = every[name][k]
            half = cell[f"{name}_ci95"].values * scale if n_real > 1 else None
            (line, *_) = ax.errorbar(x * scale_x, y, yerr=half, fmt="o-", label=label, lw=1.2, capsize=3)
            for i, (xi, yi) in enumerate(zip(x * scale_x, y, strict=True)):  # the values, readable on either scale
                if np.isfinite(yi):
                    offset = _label_offset(every[name][:, i], k)  # away from the other lines where it can
                    ax.annotate(f"{yi:.3g}", (xi, yi), textcoords="offset points", xytext=offset, fontsize=7,
                                color=line.get_color())  # fmt: skip
    axes[0].set_ylabel("3$\\sigma$ bouncing [nm]")
    axes[1].set_ylabel(f"mean contact force [{force_unit}]")
    decades = names is None and x.size > 1 and np.all(x > 0.0) and x.max() > 100.0 * x.min()
    for ax in axes:
        ax.set_xlabel(textwrap.fill(_short_name(ds[first], first) + ("" if names else f" [{xunit}]"), 60))
        ax.grid(alpha=0.3)
        ax.set_ylim(bottom=0.0)
        if names:
            ax.set_xticks(x, [n.replace("_", " ") for n in names])
            ax.set_xlim(x[0] - 0.5, x[-1] + 0.5)
        if decades:  # an axis over decades (a kick's size): log scale
            ax.set_xscale("log")
    force = np.concatenate([line.get_ydata() for line in axes[1].get_lines()])
    force = force[np.isfinite(force) & (force > 0.0)]
    if force.size and force.max() > 100.0 * force.min():  # forces over decades: a log scale shows all of them
        axes[1].set_yscale("symlog", linthresh=10.0 ** np.floor(np.log10(max(force.min(), 1e-4 * force.max()))))
        axes[1].set_ylabel(f"mean contact force [{force_unit}], log scale")
        axes[1].set_ylim(bottom=0.0)
    if rest:
        axes[1].legend(fontsize=8, frameon=False)
    failed = int(np.count_nonzero(ds["status"].values == -1))
    note = f" ({failed} failed runs)" if failed else ""
    samples = f"\nmean of {n_real} realisations, 95 % intervals" if n_real > 1 else ""
    fig.suptitle(f"{ds.attrs.get('title', ds.attrs.get('study', ''))}{samples}{note}", fontsize=11)
    return fig


def _label_offset(column: np.ndarray, k: int) -> tuple[int, int]:
    """Where line k labels its point among every line's values at that x (points): above it if it is the top one,
    below it if it is the bottom one, else above for even k and below for odd k."""
    others = np.delete(column, k)
    others = others[np.isfinite(others)]
    if others.size == 0 or column[k] >= others.max():
        return (4, 4)
    if column[k] <= others.min():
        return (4, -11)
    return (4, 4) if k % 2 == 0 else (4, -11)


def _force_scale(forces: np.ndarray) -> tuple[float, str]:
    """(factor, unit) of a study's contact-force axis: mN, or uN where every cell's force is below 0.1 mN."""
    finite = np.abs(forces[np.isfinite(forces)])
    return (1e6, "uN") if finite.size and finite.max() < 1e-4 else (1e3, "mN")


def _cell_label(cell: xr.Dataset, ds: xr.Dataset, dim: str) -> str:
    """ "dim = value unit" of one line's coordinate (a named value as it is)."""
    value = cell[dim].values
    if value.dtype.kind in "OUS":
        return f"{dim} = {value}"
    scale, unit = _scale(ds[dim])
    return f"{dim} = {float(value) * scale:g} {unit}"


def _scale(coord: xr.DataArray) -> tuple[float, str]:
    units = coord.attrs.get("units", "")
    if coord.dtype.kind in "OUS":
        return 1.0, ""
    if units == "m":
        span = float(np.nanmax(np.abs(coord.values))) if coord.size else 0.0
        return (1e6, "um") if span >= 1e-6 else (1e9, "nm")
    if units == "N":
        return 1.0 / 9.80665e-3, "gram-force"
    if units == "s":
        span = float(np.nanmax(np.abs(coord.values))) if coord.size else 0.0
        return (1e6, "us") if span < 1e-3 else (1e3, "ms")
    return 1.0, units or "1"


def _short_name(coord: xr.DataArray, default: str) -> str:
    """A coordinate's long name without its remarks (after " (" or ": "), for an axis label."""
    return coord.attrs.get("long_name", default).split(" (")[0].split(": ")[0]


def _face_scene(ds: xr.Dataset):
    """The fly file's scene (its ``scene_toml``), or None for a file without one."""
    import tomllib

    from solver.kinds import scene_from_dict

    try:
        scene = scene_from_dict(tomllib.loads(ds.attrs.get("scene_toml", "")))
        return scene if hasattr(scene, "abs") else None
    except Exception:  # a file without its scene is drawn without the outlines
        return None


def _zoom_regions(shapes: list[np.ndarray], pad: np.ndarray | None, length: float) -> list[int]:
    """Regions [indices] of the trailing-end zoom: the pad, and those behind mid-length that overlap it across the
    track and end at most 0.15 mm ahead of it (the face's last 15 % without a pad)."""
    if pad is None:
        return [k for k, v in enumerate(shapes) if v[:, 0].min() >= 0.85 * length] or [len(shapes) - 1]
    (px0, py0), (_, py1) = pad.min(axis=0), pad.max(axis=0)
    return [k for k, v in enumerate(shapes) if v[:, 0].min() >= 0.5 * length and v[:, 0].max() >= px0 - 0.15
            and v[:, 1].min() < py1 and v[:, 1].max() > py0]  # fmt: skip


def _draw_face(ax, ds, scene, x, y, window=None, labelled=()):
    """Etch depth (log scale) with each region's outline, and its name and depth where it shows on the face (the
    node it paints nearest its painted area's centroid); ``window`` ((x0, x1), (y0, y1)) [mm] zooms, and labels the
    regions ``labelled`` (indices) with their sizes (the whole face leaves them, and any below 1 % of it, out)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Polygon, Rectangle

    from solver.abs.face import inside_polygon, region_geometry

    # The regions' exact polygons, painted in the scene's order (a later region covers an earlier one, as in the
    # solver's depth), over the base depth: slanted sides are drawn as they are, not as the nodes sample them.
    floor = lambda d: max(d * 1e9, 1.0)  # noqa: E731  pad tops (0) drawn at 1 nm
    depths = [scene.abs.base_depth] + [r.depth for r in scene.abs.regions]
    m = ScalarMappable(norm=LogNorm(1.0, max(2.0, max(floor(d) for d in depths))), cmap="Greys")
    length, width = scene.slider.length * 1e3, scene.slider.width * 1e3
    ax.add_patch(Rectangle((0.0, -0.5 * width), length, width, color=m.to_rgba(floor(scene.abs.base_depth)), lw=0))
    X, Y = np.meshgrid(x, y, indexing="ij")
    owner = np.full(X.shape, -1)
    shapes = [region_geometry(r, scene) * 1e3 for r in scene.abs.regions]
    for k, v in enumerate(shapes):
        owner[inside_polygon(X, Y, v)] = k
    area = np.outer(np.gradient(x), np.gradient(y))
    stacked = 0
    for region, v in zip(scene.abs.regions, shapes, strict=True):
        ax.add_patch(Polygon(v, closed=True, facecolor=m.to_rgba(floor(region.depth)), edgecolor="none"))
    for k, (region, v) in enumerate(zip(scene.abs.regions, shapes, strict=True)):
        closed = np.vstack([v, v[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="tab:blue", lw=0.8)
        on = owner == k
        if window is None:
            if k in labelled or area[on].sum() < 0.01 * area.sum():  # the zoom labels these
                continue
        elif k not in labelled or not on.any():  # the zoom labels its own regions
            continue
        cx, cy = X[on].mean(), Y[on].mean()
        k_near = np.argmin((X[on] - cx) ** 2 + (Y[on] - cy) ** 2)
        anchor = X[on][k_near], Y[on][k_near]
        label = f"{region.name}, {region.depth * 1e9:.0f} nm"
        style = {
            "fontsize": 7,
            "color": "tab:blue",
            "bbox": {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none"},
        }
        if window is None:
            (x0, y0), (x1, y1) = v.min(axis=0), v.max(axis=0)
            tall = (y1 - y0) > 4.0 * (x1 - x0)  # a narrow strip across the face: its label runs along it
            text = label if tall else label.replace(", ", "\n")
            ax.text(*anchor, text, ha="center", va="center", rotation=90 if tall else 0, **style)
            continue
        (x0, y0), (x1, y1) = v.min(axis=0), v.max(axis=0)
        label += f", {(x1 - x0) * 1e3:.0f} x {(y1 - y0) * 1e3:.0f} um"
        (wx0, wx1), (wy0, wy1) = window
        spot = (wx0 + 0.02 * (wx1 - wx0), wy1 - (0.06 + 0.07 * stacked) * (wy1 - wy0))
        ax.annotate(label, anchor, spot, ha="left", va="center", arrowprops={"arrowstyle": "-", "color": "tab:blue",
                    "lw": 0.6}, **style)  # fmt: skip
        stacked += 1
    if window is not None:
        ax.set_xlim(*window[0])
        ax.set_ylim(*window[1])
    else:
        ax.set_xlim(0.0, length)
        ax.set_ylim(-0.5 * width, 0.5 * width)
    return m


def plot_fly(ds: xr.Dataset) -> Figure:
    """The face, its regions (etch depth, outlines, names; the trailing end zoomed, with sizes) and the steady
    pressure over it; the element is the star."""
    plt = pyplot()
    from matplotlib.colors import TwoSlopeNorm

    from solver.abs.face import region_geometry

    x, y = ds["x"].values * 1e3, ds["y"].values * 1e3
    scene = _face_scene(ds) if "depth" in ds else None
    p = ds["pressure"].values / 101.325e3
    norm = TwoSlopeNorm(vmin=0.0, vcenter=1.0, vmax=max(2.0, float(p.max())))  # sub-ambient blue, above red
    title = (f"{ds.attrs.get('scene', '')}: flying height {float(ds['flying_height']) * 1e9:.2f} nm, "
             f"pitch {float(ds['pitch']) * 1e6:.1f} urad, roll {float(ds['roll']) * 1e6:.2f} urad")  # fmt: skip
    if scene is None:
        fig, ax = plt.subplots(figsize=(7.0, 5.2), constrained_layout=True)
        fig.colorbar(
            ax.pcolormesh(x, y, p.T, shading="gouraud", cmap="RdBu_r", norm=norm), ax=ax, label="p / p_ambient"
        )
        ax.set_title(title, fontsize=10)
        axes = [ax]
    else:
        fig, grid = plt.subplots(2, 2, figsize=(12.0, 9.0), constrained_layout=True,
                                 gridspec_kw={"width_ratios": [1.6, 1.0]})  # fmt: skip
        axes = list(grid.ravel())
        fig.suptitle(title, fontsize=11)
        shapes = [region_geometry(r, scene) * 1e3 for r in scene.abs.regions]
        pad = [v for r, v in zip(scene.abs.regions, shapes, strict=True) if r.name == scene.abs.refine_region]
        near = _zoom_regions(shapes, pad[0] if pad else None, x.max())
        m = _draw_face(axes[0], ds, scene, x, y, labelled=near)
        fig.colorbar(m, ax=axes[0], label="etch depth [nm] (pad tops drawn at 1)")
        axes[0].set_title("(a) the face: regions and etch depths", fontsize=10)
        m = axes[2].pcolormesh(x, y, p.T, shading="gouraud", cmap="RdBu_r", norm=norm)
        fig.colorbar(m, ax=axes[2], label="p / p_ambient")
        axes[2].set_title("(c) steady pressure", fontsize=10)
        # the zoom: the trailing pad and the regions behind mid-length beside or ahead of it (up to 0.15 mm)
        trailing = np.vstack([shapes[k] for k in near])
        (lo_x, lo_y), hi_y = trailing.min(axis=0), trailing[:, 1].max()
        window = ((lo_x - 0.01, x.max()), (lo_y - 0.02, hi_y + 0.02))
        _draw_face(axes[1], ds, scene, x, y, window, near)
        axes[1].set_title("(b) the trailing end", fontsize=10)
        axes[3].pcolormesh(x, y, p.T, shading="gouraud", cmap="RdBu_r", norm=norm)
        for v in shapes:
            closed = np.vstack([v, v[:1]])
            axes[3].plot(closed[:, 0], closed[:, 1], color="k", lw=0.5)
        axes[3].set_xlim(*window[0])
        axes[3].set_ylim(*window[1])
        axes[3].set_title("(d) pressure at the trailing end", fontsize=10)
    for a in axes:
        a.set_aspect("equal")
        a.set_xlabel("x from the leading edge [mm]")
        a.set_ylabel("y [mm]")
        if scene is not None:
            a.plot(scene.slider.element_x * 1e3, scene.slider.element_y * 1e3, "*", color="gold", mec="k", ms=9)
    return fig


#: Colours of the regimes of kind "abs" (flying, intermittent, sustained contact, stuck) on a regime map.
REGIME_COLOURS = ("#9ecae1", "#fdd49e", "#fc8d59", "#b30000")


def plot_regime_map(ds: xr.Dataset, overlay: xr.Dataset | None = None) -> Figure:
    """Regime map over the study's first two axes: each cell coloured by its dominant regime over the
    realisations (the share of that regime written in it), contours of the mean 3-sigma bouncing [nm] on top.

    A study with a boundary (its own, or ``overlay``: a boundary-mode study of the same axes) gets the boundary
    drawn: the mean over the realisations of the tracks' bracket midpoints with its 95 % interval, each track's
    midpoint as a dot (one realisation: the midpoint with its bracket).  Cells a bisection did not probe are
    left white."""
    if overlay is not None and overlay.attrs.get("boundary_method") != "bisection":
        raise ValueError("the overlay must be a boundary-mode study (hdi run STUDY --mode boundary)")
    plt = pyplot()
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    xdim, ydim = [d for d in ds["dominant_regime"].dims][:2]
    sx, xunit = _scale(ds[xdim])
    sy, yunit = _scale(ds[ydim])
    x, y = ds[xdim].values * sx, ds[ydim].values * sy
    dominant = ds["dominant_regime"].transpose(ydim, xdim).values.astype(float)
    dominant[dominant < 0] = np.nan
    share = ds["regime_fraction"].max("regimes").transpose(ydim, xdim).values
    labels = [str(v) for v in ds["regimes"].values]
    fig, ax = plt.subplots(figsize=(7.5, 5.6), constrained_layout=True)
    cmap = ListedColormap(REGIME_COLOURS[: len(labels)])
    ax.pcolormesh(x, y, dominant, shading="nearest", cmap=cmap, norm=BoundaryNorm(np.arange(len(labels) + 1) - 0.5,
                  cmap.N))  # fmt: skip
    sigma = ds["bouncing_3sigma_mean"].transpose(ydim, xdim).values * 1e9
    if np.isfinite(sigma).mean() >= 0.9 and len(x) > 1 and len(y) > 1:  # not on a bisection's sparse lattice
        low, high = np.nanpercentile(sigma, [5.0, 95.0])  # a single extreme cell does not take every level
        levels = np.linspace(low, high, 6) if high > low else 6
        lines = ax.contour(x, y, sigma, levels=levels, colors="k", linewidths=0.9)
        ax.clabel(lines, fmt="%.3g nm", fontsize=8)
    for j, yj in enumerate(y):
        for i, xi in enumerate(x):
            if np.isfinite(share[j, i]) and len(x) <= 9 and len(y) <= 9:  # not on a bisection's fine lattice
                ax.annotate(f"{share[j, i]:.2f}", (xi, yj), ha="center", va="center", fontsize=8, color="0.15")
    present = sorted({int(v) for v in dominant[np.isfinite(dominant)]})
    handles = [Patch(color=REGIME_COLOURS[k], label=labels[k].replace("_", " ")) for k in present]
    classes = ""
    for source, colour in ((ds, "k"), (overlay, "tab:purple")):
        if source is not None and "boundary_lower" in source:
            handles += _draw_regime_boundary(ax, source, xdim, ydim, (sx, sy), colour)
            low, high = (c.split(" (")[0].replace("_", " ") for c in source.attrs["boundary_classes"].split(" / "))
            classes = f"\nboundary: {low} | {high}"
    title = "dominant regime" + ("\n(number: its share)" if len(x) <= 9 and len(y) <= 9 else "")
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9,
              title=title, title_fontsize=9)  # fmt: skip
    for setter, dim, unit in ((ax.set_xlabel, xdim, xunit), (ax.set_ylabel, ydim, yunit)):
        setter(f"{_short_name(ds[dim], dim)} [{unit}]")
    if len(x) <= 9:
        ax.set_xticks(x)
    if len(y) <= 9:
        ax.set_yticks(y)
    n_real = ds.sizes.get("realization", 1)
    failed = int(np.count_nonzero(ds["status"].values == -1))
    ran = int(np.count_nonzero(ds["status"].values != -2))
    what = (f"bisection, {ran} runs; {n_real} tracks" if ds.attrs.get("boundary_method") == "bisection" else
            f"{n_real} realisations per cell; contours: mean 3$\\sigma$ bouncing [nm]")  # fmt: skip
    ax.set_title(f"{ds.attrs.get('title', '')}\n{what}" + (f"; {failed} failed runs" if failed else "") + classes,
                 fontsize=10)  # fmt: skip
    return fig


def _draw_regime_boundary(ax, ds: xr.Dataset, xdim: str, ydim: str, scales: tuple[float, float], colour: str):
    """Draw a study's class boundary on a regime map; the legend handles it adds."""
    from matplotlib.lines import Line2D

    bdim = ds.attrs["boundary_axis"]
    odim = ydim if bdim == xdim else xdim
    sb, so = scales if bdim == xdim else scales[::-1]
    across = ds[odim].values * so
    label = "boundary (" + ds.attrs["boundary_method"] + ")"
    if "boundary_mean" in ds:
        mean = ds["boundary_mean"].transpose(odim).values * sb
        half = ds["boundary_ci95"].transpose(odim).values * sb
        mids = 0.5 * (ds["boundary_lower"] + ds["boundary_upper"]).transpose(odim, "realization").values * sb
        dots = np.broadcast_to(across[:, None], mids.shape)
        along, spread = (mids, dots) if bdim == xdim else (dots, mids)
        ax.plot(along.ravel(), spread.ravel(), ".", color=colour, ms=3, alpha=0.6)
        points, err = mean, half
        label += f":\nmean of {ds.sizes['realization']} tracks, 95 %"
    else:
        lower = ds["boundary_lower"].transpose(odim).values * sb
        upper = ds["boundary_upper"].transpose(odim).values * sb
        points = 0.5 * (lower + upper)
        err = np.array([points - lower, upper - points])
        label += ": bracket"
    xy = (points, across) if bdim == xdim else (across, points)
    key = "xerr" if bdim == xdim else "yerr"
    ax.errorbar(*xy, **{key: err}, fmt="D-", ms=4, color=colour, capsize=3, lw=1.2)
    return [Line2D([], [], marker="D", ms=4, color=colour, label=label)]


def plot_statistics(ds: xr.Dataset) -> Figure:
    """Sampling and refinement report of a "statistics" study (:func:`pipeline.data.sampling.refinement_report`).

    One row per reported variable: the 95 % half-width from the first n realisations against n on log axes,
    each cell's points with the fit of its standard error (slope in the legend, compare -1/2 and the range of
    independent samples) and the half-widths independent samples would give (slope -1/2); the intervals of the mean at
    each value of the refinement axis side by side; the paired differences to the reference with their intervals.
    """
    plt = pyplot()
    dim = ds.attrs["refinement_axis"]
    names = [str(v)[: -len("_se_slope")] for v in ds.data_vars if str(v).endswith("_se_slope")]
    low, high = (float(v) for v in ds["se_slope_range"].values)
    fig, axes = plt.subplots(len(names), 3, figsize=(13.0, 3.2 * len(names)), constrained_layout=True, squeeze=False)
    sd, dunit = _scale(ds[dim])
    values = ds[dim].values * sd
    n = ds["samples"].values
    others = [d for d in ds[f"{names[0]}_mean"].dims if d != dim]
    for row, name in zip(axes, names, strict=True):
        units = ds[name].attrs.get("units", "")
        scale, shown = display_scale(units)
        cells = ds.stack(cell=others) if others else ds.expand_dims(cell=[0])
        for c in range(cells.sizes["cell"]):
            cell = cells.isel(cell=c)
            for k, v in enumerate(values):
                at = {dim: k}
                half = cell[f"{name}_ci95_nested"].isel(at).values * scale
                slope = float(cell[f"{name}_se_slope"].isel(at))
                (line,) = row[0].loglog(n, half, "o", ms=3.5, label=f"{dim} = {v:g} {dunit}: slope {slope:+.2f}")
                row[0].loglog(n, cell[f"{name}_ci95_fitted"].isel(at).values * scale, "-", color=line.get_color(),
                              lw=1.0)  # fmt: skip
                row[0].loglog(n, cell[f"{name}_ci95_independent"].isel(at).values * scale, ":",
                              color=line.get_color(), lw=0.9)  # fmt: skip
            mean = cell[f"{name}_mean"].values * scale
            half = cell[f"{name}_ci95"].values * scale
            row[1].errorbar(values, mean, yerr=half, fmt="o", capsize=4)
            diff = cell[f"{name}_paired_difference"].values * scale
            dhalf = cell[f"{name}_paired_difference_ci95"].values * scale
            row[2].errorbar(values, diff, yerr=dhalf, fmt="s", capsize=4, color="tab:red")
        if not np.any(ds[f"{name}_ci95_nested"].values > 0.0):  # every realisation the same value: no spread
            row[0].set_yscale("linear")
            row[0].text(0.5, 0.5, "no spread: every realisation gives the same value", transform=row[0].transAxes,
                        ha="center", va="center", fontsize=9)  # fmt: skip
        row[0].set_title(f"{name}: 95 % half-width h$_n$ of the first n (line: fit, dotted: slope -1/2)",
                         fontsize=9)  # fmt: skip
        row[0].set_xlabel("realisations n")
        row[0].set_xticks(n, [str(int(k)) for k in n])  # plain integers on the log axis, not 2 x 10^0
        row[0].xaxis.set_minor_formatter("")
        row[0].set_ylabel(f"half-width [{shown}]")
        row[0].legend(fontsize=7, frameon=False, title=f"fitted se slope; independent: [{low:.2f}, {high:.2f}]",
                      title_fontsize=7)  # fmt: skip
        row[1].set_title(f"{name}: mean and 95 % interval [{shown}]", fontsize=9)
        row[2].set_title(f"paired difference to {dim} = {values[-1]:g} {dunit} (same seeds) [{shown}]", fontsize=9)
        row[2].axhline(0.0, color="k", lw=0.6)
        for ax in row[1:]:
            ax.set_xscale("log", base=2)
            ax.set_xticks(values, [f"{v:g}" for v in values])
            ax.minorticks_off()
            ax.set_xlabel(f"{dim} [{dunit}]")
        for ax in row:
            ax.grid(alpha=0.3, which="both")
    fig.suptitle(f"{ds.attrs.get('title', '')} ({ds.sizes.get('realization', 1)} realisations per cell)", fontsize=11)
    return fig


def plot_ladder(ds: xr.Dataset) -> Figure:
    """A grid ladder (:mod:`pipeline.ladder`): each fitted quantity against the grid interval h = 1 / (nx - 1),
    with the least-squares f0 + b h^p, its limit and Richardson's where there is one; the scene's grid marked."""
    from pipeline.ladder import QUANTITIES

    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10.0, 7.0), constrained_layout=True)
    h = ds["h"].values
    hh = np.linspace(0.0, float(np.nanmax(h)) * 1.05, 200)
    scene_nx = int(_face_scene(ds).numerics.nx) if _face_scene(ds) is not None else None
    for ax, (name, (unit, scale, long_name)) in zip(axes.ravel(), QUANTITIES.items(), strict=True):
        f = ds[name].values * scale
        ax.plot(h, f, "o", color="C0", label="steady flight")
        for nx, hx, fx in zip(ds["nx"].values, h, f, strict=True):
            if np.isfinite(fx):
                ax.annotate(f"{nx}", (hx, fx), textcoords="offset points", xytext=(4, 4), fontsize=7)
        if scene_nx in ds["nx"].values:
            k = int(np.flatnonzero(ds["nx"].values == scene_nx)[0])
            ax.plot(h[k], f[k], "s", mfc="none", ms=11, color="C3", label=f"scene grid ({scene_nx} nodes)")
        f0, p = float(ds[f"{name}_fit_limit"]), float(ds[f"{name}_fit_order"])
        if np.isfinite(f0):
            ok = np.isfinite(f)
            b = np.linalg.lstsq(h[ok, None] ** p, f[ok] - f0 * scale, rcond=None)[0][0]
            ax.plot(hh, f0 * scale + b * hh**p, "-", color="C1", lw=1, label=f"fit: p = {p:.2f}")
            ax.axhline(f0 * scale, color="C1", ls=":", lw=1, label=f"fitted limit {f0 * scale:.5g} {unit}")
        if f"{name}_richardson_limit" in ds and np.isfinite(float(ds[f"{name}_richardson_limit"])):
            r0, rp = float(ds[f"{name}_richardson_limit"]) * scale, float(ds[f"{name}_richardson_order"])
            ax.plot([0.0], [r0], "D", color="C2", label=f"Richardson: {r0:.5g} {unit} (p = {rp:.2f})")
        ax.set_xlabel("grid interval h = 1 / (nx - 1)")
        ax.set_ylabel(f"{long_name} [{unit}]")
        ax.set_xlim(left=0.0)
        ax.legend(fontsize=7)
    fig.suptitle(textwrap.fill(ds.attrs.get("title", "grid ladder"), 100), fontsize=10)
    return fig
