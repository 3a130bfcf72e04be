"""Loss markers on the report maps: every cause's mark must be visible at the size the maps draw it."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure

from swarm.report.sim_figures import CAUSE_MARKERS, loss_marker
from swarm.sim.render import cause_colour

#: The maps' nominal marker areas (pt^2) and white edge widths: the study's heat map, the simulation's.
MAP_SIZES = ((22.0, 0.5), (60.0, 0.8))


def _ink(marker: str, area: float, colour: str, edge: float) -> int:
    """Pixels of `colour` one white-edged marker leaves on a sand-coloured map at 200 dpi."""
    fig = Figure(figsize=(1, 1), dpi=200, facecolor="#F5E6B8")
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_axis_off()
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.scatter([0], [0], s=area, marker=marker, c=colour, edgecolors="white", linewidths=edge)
    canvas.draw()
    rgb = np.asarray(canvas.buffer_rgba())[..., :3] / 255.0
    return int(np.count_nonzero(np.abs(rgb - to_rgb(colour)).sum(axis=2) < 0.3))


@pytest.mark.parametrize(("area", "edge"), MAP_SIZES)
@pytest.mark.parametrize("cause", sorted(CAUSE_MARKERS))
def test_every_loss_cause_leaves_a_visible_mark_on_the_map(cause: str, area: float, edge: float) -> None:
    """At least a quarter of the ink of a square of the same nominal size (the triangles, the
    thinnest plain shapes, leave 0.30-0.36). The star of a mine loss left 0.08-0.11 before its
    area was scaled: a faint dot that the legend showed too."""
    colour = cause_colour(cause)
    marker, scaled = loss_marker(cause, area)
    assert _ink(marker, scaled, colour, edge) >= 0.25 * _ink("s", area, colour, edge)
