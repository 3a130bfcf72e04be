"""One look across the project: matplotlib set up for files, and the palette (`swarm.palette`)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # reports are files; never ask for a display

import io

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

#: Resolution of every report figure.
PNG_DPI = 110

__all__ = [
    "LINESTYLES",
    "OKABE_ITO",
    "PNG_DPI",
    "REGION_STYLES",
    "ROLE_COLOURS",
    "ROUTE_COLOURS",
    "SERIES",
    "TERRAIN_COLOURS",
    "TERRAIN_FALLBACK",
    "as_words",
    "new_figure",
    "plt",
    "png_bytes",
    "terrain_colours",
]


def new_figure(width_in: float, height_in: float, **kwargs) -> tuple[plt.Figure, object]:
    plt.rcParams.update({"axes.grid": True, "grid.alpha": 0.3, "font.size": 9})
    return plt.subplots(figsize=(width_in, height_in), **kwargs)


def png_bytes(fig) -> bytes:
    """The figure as PNG bytes without a timestamp (same data, same bytes); closes it."""
    try:
        buf = io.BytesIO()
        fig.savefig(
            buf, format="png", dpi=PNG_DPI, bbox_inches="tight", pad_inches=0.08, metadata={"Software": None}
        )
        return buf.getvalue()
    finally:
        plt.close(fig)


def as_words(name: str) -> str:
    """A snake_case name as words for legends and axes."""
    return name.replace("_", " ")
