"""A beach map as a figure: terrain colours, labelled elevation contours, regions by kind, routes."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib.patheffects as pe
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry
from shapely.plotting import patch_from_polygon

from swarm.files import atomic_path
from swarm.report.style import REGION_STYLES, ROUTE_COLOURS, as_words, new_figure, terrain_colours
from swarm.world.beachmap import BeachMap

MAX_WIDTH_IN = 14.0
MAX_MAP_HEIGHT_IN = 9.0
LABEL_GAP_IN = 1.0
_HALO = [pe.withStroke(linewidth=3.0, foreground="white", alpha=0.85)]
_TEXT_HALO = [pe.withStroke(linewidth=2.2, foreground="white", alpha=0.9)]


def figure_size(width_m: float, height_m: float, legend_rows: int) -> tuple[float, float]:
    """Inches for a map of this extent: as wide as allowed (14 in at most) for long east-west
    beaches, as tall as allowed (9 in of map) for long north-south ones, plus title, axis labels
    and a legend of `legend_rows` rows below."""
    aspect = height_m / width_m
    map_w = MAX_WIDTH_IN - 1.6
    map_h = map_w * aspect
    if map_h > MAX_MAP_HEIGHT_IN:
        map_h = MAX_MAP_HEIGHT_IN
        map_w = map_h / aspect
    fig_w = min(MAX_WIDTH_IN, max(map_w + 1.6, 7.5))
    fig_h = max(map_h, 1.2) + 1.15 + 0.2 * legend_rows + 0.25
    return fig_w, fig_h


def _percent(fraction: float) -> str:
    return "<1%" if 0 < fraction < 0.005 else f"{fraction:.0%}"


def _parts(geom: BaseGeometry) -> list[BaseGeometry]:
    return list(geom.geoms) if hasattr(geom, "geoms") else [geom]


def _draw_region(
    ax,
    name: str,
    kind: str,
    geom: BaseGeometry,
    bounds: tuple[float, float, float, float],
    others: Sequence[BaseGeometry] = (),
) -> object:
    colour, style, marker = REGION_STYLES.get(kind, ("#000000", "-", "o"))
    handle: object = None
    for part in _parts(geom):
        if part.geom_type == "Point":
            ax.plot(
                part.x,
                part.y,
                marker,
                ms=10,
                color=colour,
                mec="white" if colour == "#000000" else "black",
                mew=1.0,
                zorder=6,
            )
            handle = handle or Line2D(
                [], [], ls="", marker=marker, ms=8, color=colour, mec="black", label=as_words(kind)
            )
        elif part.geom_type in ("LineString", "LinearRing"):
            xs, ys = part.xy
            ax.plot(xs, ys, style, color=colour, lw=2.2, zorder=5, path_effects=_HALO)
            handle = handle or Line2D([], [], ls=style, lw=2.2, color=colour, label=as_words(kind))
        elif part.geom_type == "Polygon":
            hatch = "///" if kind == "keep_out" else None
            # a white outline under the coloured one keeps the edge visible on any terrain colour
            ax.add_patch(
                patch_from_polygon(part, fill=False, edgecolor="white", lw=3.6, alpha=0.85, zorder=4)
            )
            ax.add_patch(
                patch_from_polygon(
                    part,
                    fill=False,  # no tint: it would change the terrain colours under it
                    edgecolor=colour,
                    lw=2.0,
                    ls=style,
                    hatch=hatch,
                    zorder=4,
                )
            )
            handle = handle or Patch(
                fill=False, edgecolor=colour, lw=1.6, ls=style, hatch=hatch, label=as_words(kind)
            )
    # names sit by the shape, inside the map: below the point or top edge when near the map's top
    near_top = geom.bounds[3] > bounds[3] - 0.08 * (bounds[3] - bounds[1])
    dy, va = (-3, "top") if near_top else (3, "bottom")
    ha = "left"
    if geom.geom_type in ("Polygon", "MultiPolygon"):
        xy, ha = _label_corner(geom, others)
        offset = (-2 if ha == "right" else 2, dy)
    else:
        at = geom.representative_point()
        xy, offset = (at.x, at.y), (7, 2 * dy)
    ax.annotate(
        name,
        xy,
        xytext=offset,
        textcoords="offset points",
        ha=ha,
        va=va,
        fontsize=7.5,
        zorder=9.5,  # over the paths a report draws (9), under its links and markers (10 and up)
        path_effects=_TEXT_HALO,
    )
    return handle


def _label_corner(geom: BaseGeometry, others: Sequence[BaseGeometry]) -> tuple[tuple[float, float], str]:
    """Where an area's name goes: its top-left corner, clear of what it holds, unless that corner
    lies in another area that does not hold this one (the name would read as that area's:
    gentle_fine's search area starts inside the dunes' keep-out), then its top-right one,
    right-aligned; (corner, alignment). A landing zone inside a search area keeps its top-left."""
    areas = [o for o in others if o.geom_type in ("Polygon", "MultiPolygon") and not o.covers(geom)]
    x0, _, x1, y1 = geom.bounds
    for corner, ha in (((x0, y1), "left"), ((x1, y1), "right")):
        if not any(o.covers(Point(corner)) for o in areas):
            return corner, ha
    return (x0, y1), "left"


def _contours(ax, beach_map: BeachMap) -> None:
    z = beach_map.elevation_m.astype(np.float64)
    zmin, zmax = float(z.min()), float(z.max())
    if not zmax - zmin > 1e-6 or min(beach_map.shape) < 2:
        return
    levels = [
        v for v in MaxNLocator(nbins=8, steps=[1, 2, 2.5, 5, 10]).tick_values(zmin, zmax) if zmin < v < zmax
    ]
    if not levels:
        return
    rows, cols = beach_map.shape
    x, y = beach_map.center_of(np.arange(rows)[:, None], np.arange(cols)[None, :])
    x, y = np.broadcast_to(x, z.shape), np.broadcast_to(y, z.shape)
    widths = [1.6 if abs(v) < 1e-9 else 0.7 for v in levels]  # the 0 m shoreline stands out
    cs = ax.contour(
        x,
        y,
        z,
        levels=levels,
        colors="#1A1A1A",
        linewidths=widths,
        negative_linestyles="solid",
        alpha=0.8,
        zorder=3,
    )
    cs.set(path_effects=[pe.withStroke(linewidth=1.8, foreground="white", alpha=0.35)])
    labels = ax.clabel(cs, fontsize=7, fmt=lambda v: f"{v:g} m", inline=False)
    # a noisy dune field gets a label on every little loop: keep labels at least ~1 inch apart
    box = ax.get_window_extent()
    dpi = ax.figure.dpi
    # with equal aspect the map is drawn at the larger of the two metres-per-inch ratios
    m_per_in = max(
        beach_map.width_m / max(box.width / dpi, 0.5), beach_map.height_m / max(box.height / dpi, 0.5)
    )
    min_gap = LABEL_GAP_IN * m_per_in
    kept: list[tuple[float, float]] = []
    for text in sorted(labels, key=lambda t: t.get_text() != "0 m"):  # the shoreline's first
        tx, ty = text.get_position()
        if all(math.hypot(tx - kx, ty - ky) >= min_gap for kx, ky in kept):
            kept.append((tx, ty))
            text.set_path_effects(_TEXT_HALO)
        else:
            text.remove()


def plot_map(
    beach_map: BeachMap,
    path: str | Path | None,
    *,
    ax=None,
    routes: Sequence[tuple[str, np.ndarray]] | None = None,
):
    """Draw the map: terrain classes in the project's colours, labelled elevation contours (m),
    regions by kind with names, and `routes` (label, Nx2 array of x, y in metres) on top.

    Without `ax`, makes a figure sized for the map's aspect ratio and writes it to `path` (PNG,
    SVG or PDF by suffix; atomically). With `ax`, draws into it, and writes its figure only when
    `path` is given. Returns the axes.
    """
    rows, cols = beach_map.shape
    classes = beach_map.terrain_classes
    counts = np.bincount(beach_map.terrain.ravel().astype(np.intp), minlength=len(classes))
    present = [i for i in range(len(classes)) if counts[i]]
    kinds: dict[str, object] = {}
    n_legend = len(present) + len({r.kind for r in beach_map.regions.values()}) + len(routes or ())

    own_figure = ax is None
    if own_figure:
        fig_w, _ = figure_size(beach_map.width_m, beach_map.height_m, 1)
        ncol = max(1, min(n_legend, int(fig_w // 1.9)))
        fig_w, fig_h = figure_size(beach_map.width_m, beach_map.height_m, math.ceil(n_legend / ncol))
        fig, ax = new_figure(fig_w, fig_h, layout="constrained")
    else:
        fig = ax.figure

    xmin, ymin, xmax, ymax = beach_map.bounds_m
    colours = terrain_colours(classes)
    ax.imshow(
        beach_map.terrain,
        origin="lower",
        extent=(xmin, xmax, ymin, ymax),
        cmap=ListedColormap(colours),
        norm=BoundaryNorm(np.arange(-0.5, len(classes) + 0.5), len(classes)),
        interpolation="nearest",
        zorder=1,
    )
    _contours(ax, beach_map)
    regions = list(beach_map.regions.values())
    for region in regions:
        others = [r.geometry for r in regions if r is not region]
        handle = _draw_region(ax, region.name, region.kind, region.geometry, beach_map.bounds_m, others)
        if handle is not None:
            kinds.setdefault(region.kind, handle)

    route_handles = []
    for i, (label, xy) in enumerate(routes or ()):
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        colour = ROUTE_COLOURS[i % len(ROUTE_COLOURS)]
        (line,) = ax.plot(
            xy[:, 0], xy[:, 1], "-", color=colour, lw=1.8, zorder=8, path_effects=_HALO, label=label
        )
        ax.plot(xy[0, 0], xy[0, 1], "o", ms=5, color=colour, mec="white", zorder=9)
        ax.plot(xy[-1, 0], xy[-1, 1], "s", ms=5, color=colour, mec="white", zorder=9)
        route_handles.append(line)

    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(False)
    ax.set_xlabel("x, east (m)")
    ax.set_ylabel("y, north (m)")
    ax.set_title(
        f"{beach_map.name}: {beach_map.width_m:g} m × {beach_map.height_m:g} m, "
        f"{cols} × {rows} cells of {beach_map.cell_m:g} m; contours: elevation (m)",
        fontsize=9,
    )

    total = max(int(counts.sum()), 1)
    handles = [
        Patch(
            facecolor=colours[i],
            edgecolor="#555555",
            lw=0.5,
            label=f"{as_words(classes[i])} {_percent(counts[i] / total)}",
        )
        for i in present
    ]
    handles += [*kinds.values(), *route_handles]
    if own_figure:
        ncol = max(1, min(len(handles), int(fig.get_figwidth() // 1.9)))
        fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=7.5, frameon=False)
    else:
        ax.legend(handles=handles, fontsize=7, loc="best")

    if path is not None:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=130, bbox_inches="tight", pad_inches=0.08)
    if own_figure:
        plt.close(fig)
    return ax


def map_axes(
    beach_map: BeachMap,
    legend_rows: int,
    bounds: tuple[float, float, float, float] | None = None,
    extra_width_in: float = 0.0,
) -> tuple:
    """A new figure with the map drawn in it, sized for `bounds` (default: the whole map) and
    `legend_rows` of legend below; returns (fig, ax, the map's legend handles) with the map's own
    legend taken off, for the caller to add its layers and one legend for all."""
    x0, y0, x1, y1 = bounds or beach_map.bounds_m
    w, h = figure_size(x1 - x0, y1 - y0, legend_rows)
    fig, ax = new_figure(w + extra_width_in, h, layout="constrained")
    plot_map(beach_map, None, ax=ax)
    legend = ax.get_legend()
    handles = list(legend.legend_handles) if legend is not None else []
    if legend is not None:
        legend.remove()
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    return fig, ax, handles
