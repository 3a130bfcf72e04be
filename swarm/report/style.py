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


#: Terrain modes on maps. Families by hue (water blues, sand yellows and tans, vegetation greens,
#: rock greys, kelp olive, driftwood brown) and, for colour-blind readers and greyscale print,
#: neighbours on a beach differ in lightness too (CIELAB L in the comments).
TERRAIN_COLOURS = {
    "deep_water": "#1B4F8A",  # L 33
    "surf": "#4F8FCB",  # L 57
    "shallow_water": "#B3DAF2",  # L 85
    "wet_hard_sand": "#C4A56A",  # L 69
    "soft_sand": "#F5E7B2",  # L 92
    "dirt": "#9C7A54",  # L 54
    "concrete": "#D9D9D9",  # L 87
    "rock": "#A0A0A0",  # L 66
    "boulder": "#505050",  # L 34
    "vegetation": "#3E8A3A",  # L 51
    "kelp_wrack": "#7A7A2E",  # L 50
    "driftwood": "#6B4220",  # L 32
}
#: For user-defined modes the palette does not know, in order of first appearance.
TERRAIN_FALLBACK = ("#CC79A7", "#E69F00", "#009E73", "#D55E00", "#F0E442", "#56B4E9")

#: Map regions by kind: (edge colour, line style, marker for point regions), Okabe-Ito colours.
REGION_STYLES = {
    "launch": (OKABE_ITO["black"], "-", "^"),
    "landing_zone": (OKABE_ITO["green"], "-", "s"),
    "search_area": (OKABE_ITO["blue"], "--", "s"),
    "keep_out": (OKABE_ITO["vermillion"], "-", "X"),
    "rally": (OKABE_ITO["purple"], "-", "o"),
    "observation_point": (OKABE_ITO["orange"], "-", "D"),
    "beacon": (OKABE_ITO["yellow"], "-", "*"),
    "relay_source": (OKABE_ITO["sky"], "-", "P"),
    "relay_sink": (OKABE_ITO["sky"], ":", "p"),
}
#: Overlaid routes, in order.
ROUTE_COLOURS = (
    OKABE_ITO["black"],
    OKABE_ITO["purple"],
    OKABE_ITO["orange"],
    OKABE_ITO["sky"],
    OKABE_ITO["vermillion"],
    OKABE_ITO["blue"],
    OKABE_ITO["green"],
)
