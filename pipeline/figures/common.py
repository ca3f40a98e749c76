"""What every figure shares: lazy pyplot, saving (and closing), and the figure that fits a dataset."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import xarray as xr

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def scene_values(ds: xr.Dataset) -> dict[str, object]:
    import tomllib

    try:
        scene = tomllib.loads(ds.attrs.get("scene_toml", ""))
    except tomllib.TOMLDecodeError:
        return {}
    return {**scene.get("contact", {}), **scene.get("initial", {})}


def save_figure(fig: Figure, path: str | Path, dpi: int = 120) -> Path:
    """Save and close a figure."""
    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
