"""The project's colours, as plain data: a colour-blind-safe palette, one terrain palette, regions
by kind, robots by role. No plotting library here, so every layer (the simulator's frames, the
reports) can share it."""

from __future__ import annotations

from collections.abc import Sequence

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

#: Robots by role, everywhere (plans, simulation frames, reports).
ROLE_COLOURS = {
    "landing": OKABE_ITO["vermillion"],
    "search": OKABE_ITO["blue"],
    "relay": OKABE_ITO["purple"],
    "surveillance": OKABE_ITO["green"],
    "beacon": OKABE_ITO["orange"],
    "spare": "#777777",
}


def terrain_colours(classes: Sequence[str]) -> list[str]:
    """One colour per class, from the project palette (fallback colours for unknown modes)."""
    out, spare = [], iter(TERRAIN_FALLBACK * (1 + len(classes) // len(TERRAIN_FALLBACK)))
    for name in classes:
        out.append(TERRAIN_COLOURS.get(name) or next(spare))
    return out
