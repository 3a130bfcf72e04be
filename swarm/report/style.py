"""One look across the project: matplotlib set up for files, and the palette (`swarm.palette`)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # reports are files; never ask for a display

import matplotlib.pyplot as plt

from swarm.palette import (
    LINESTYLES,
    OKABE_ITO,
    REGION_STYLES,
    ROLE_COLOURS,
    ROUTE_COLOURS,
    SERIES,
    TERRAIN_COLOURS,
    TERRAIN_FALLBACK,
    terrain_colours,
)

__all__ = [
    "LINESTYLES",
    "OKABE_ITO",
    "REGION_STYLES",
    "ROLE_COLOURS",
    "ROUTE_COLOURS",
    "SERIES",
    "TERRAIN_COLOURS",
    "TERRAIN_FALLBACK",
    "new_figure",
    "plt",
    "terrain_colours",
]


def new_figure(width_in: float, height_in: float, **kwargs) -> tuple[plt.Figure, object]:
    plt.rcParams.update({"axes.grid": True, "grid.alpha": 0.3, "font.size": 9})
    return plt.subplots(figsize=(width_in, height_in), **kwargs)
