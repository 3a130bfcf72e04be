"""One look across the project: a colour-blind-safe palette and matplotlib set up for files."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # reports are files; never ask for a display

import matplotlib.pyplot as plt

#: Okabe & Ito (2008) colour-blind-safe palette.
OKABE_ITO = {
    "black": "#000000",
    "orange": "#E69F00",
    "sky": "#56B4E9",
    "green": "#009E73",
    "yellow": "#F0E442",
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "purple": "#CC79A7",
}

#: What each source of a trajectory is drawn in, everywhere.
SERIES = {
    "truth": OKABE_ITO["black"],
    "skid": OKABE_ITO["blue"],
    "kinematic": OKABE_ITO["orange"],
    "lagrangian": OKABE_ITO["green"],
}
LINESTYLES = {"truth": "-", "skid": "-", "kinematic": "--", "lagrangian": "-."}


def new_figure(width_in: float, height_in: float, **kwargs) -> tuple[plt.Figure, object]:
    plt.rcParams.update({"axes.grid": True, "grid.alpha": 0.3, "font.size": 9})
    return plt.subplots(figsize=(width_in, height_in), **kwargs)
