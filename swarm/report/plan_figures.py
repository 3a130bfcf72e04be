"""Figures of a mission plan, each as PNG bytes for the self-contained plan report: the map (terrain
colours, elevation contours, regions) with the routes by role, the search tracks with their sensor
swaths and the relay links coloured by link margin; the relay graph close up with each link's
margin in dB; and the arrival timeline (each robot from release to its ETA, by role).

Colours: terrain and regions as `plot_map`, roles as `ROLE_COLOURS` (Okabe-Ito), link margins on
cividis (readable with any colour vision, and in greyscale). Robots by role also differ in marker.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from scipy.cluster.hierarchy import fclusterdata
from shapely.geometry.base import BaseGeometry
from shapely.plotting import patch_from_polygon

from swarm.mission.plan import MissionPlan
from swarm.report.map_figure import map_axes
from swarm.report.style import OKABE_ITO, ROLE_COLOURS, new_figure, png_bytes

#: Link margins on a colour-blind-safe sequential map (dark: little margin, yellow: plenty).
MARGIN_CMAP = colormaps["cividis"]
SWATH_ALPHA = 0.28
#: Role order in legends and the timeline.
ROLE_ORDER = ("landing", "search", "relay", "surveillance", "beacon", "spare")


def node_names(n_sinks: int, n_relays: int) -> list[str]:
    """Names of the relay graph's nodes in `edges` order: the source, the sinks, the relay robots."""
    return ["source", *(f"sink {i + 1}" for i in range(n_sinks)), *(f"R{i + 1}" for i in range(n_relays))]


def swath(tracks: Sequence, width_m: float) -> BaseGeometry | None:
    """What the sensor sweeps along `tracks` (LineStrings): a band of the sweep width around each."""
    lines = [t for t in tracks if t.length > 0]
    if not lines or not width_m > 0:
        return None
    return shapely.union_all([t.buffer(width_m / 2.0, cap_style="flat") for t in lines])


def _margin_norm(margins: Sequence[float]) -> Normalize:
    lo, hi = min(0.0, float(min(margins))), max(float(max(margins)), 1.0)
    return Normalize(lo, hi if hi > lo else lo + 1.0)


def _draw_relay(ax, plan: MissionPlan, margins: Sequence[float] | None, labels: bool) -> list:
    """Relay links (coloured by margin when known) and nodes; returns legend handles."""
    r = plan.relay
    nodes = r.nodes_m
    segs = [nodes[[a, b]] for a, b in r.edges]
    n_fixed = 1 + len(r.sinks_m.reshape(-1, 2))
    handles: list = []
    if segs:
        if margins is not None and len(margins) == len(segs):
            norm = _margin_norm(margins)
            colours = [MARGIN_CMAP(norm(m)) for m in margins]
            styles = ["solid" if m >= 0 else "dashed" for m in margins]
        else:
            colours, styles = [OKABE_ITO["purple"]] * len(segs), ["dashed"] * len(segs)
        ax.add_collection(LineCollection(segs, colors="white", linewidths=4.2, zorder=9))
        ax.add_collection(LineCollection(segs, colors=colours, linewidths=2.4, linestyles=styles, zorder=10))
        if labels and margins is not None and len(margins) == len(segs):
            span = float(max(np.ptp(nodes[:, 0]), np.ptp(nodes[:, 1]), 1.0))
            placed: list[np.ndarray] = []
            for (a, b), m in zip(r.edges, margins, strict=True):
                # along the link, the first spot clear of the labels already placed (parallel chains)
                spots = [nodes[a] + t * (nodes[b] - nodes[a]) for t in (0.5, 0.3, 0.7, 0.2, 0.8)]
                gap = [min((float(np.hypot(*(p - q))) for q in placed), default=np.inf) for p in spots]
                clear = [k for k, g in enumerate(gap) if g >= 0.06 * span]
                at = spots[clear[0] if clear else int(np.argmax(gap))]
                placed.append(at)
                ax.annotate(
                    f"{m:.1f} dB",
                    at,
                    xytext=(0, 4),
                    textcoords="offset points",
                    ha="center",
                    fontsize=7,
                    zorder=12,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},
                )
        handles.append(Line2D([], [], color=MARGIN_CMAP(0.85), lw=2.4, label="relay link (colour: margin)"))
    ax.plot(*nodes[:1].T, "P", ms=10, color=OKABE_ITO["sky"], mec="black", zorder=11)
    ax.plot(*nodes[1:n_fixed].T, "p", ms=9, color=OKABE_ITO["sky"], mec="black", zorder=11)
    ax.plot(*nodes[n_fixed:].T, "o", ms=6, color=ROLE_COLOURS["relay"], mec="black", zorder=11)
    handles += [
        Line2D([], [], ls="", marker="P", ms=8, color=OKABE_ITO["sky"], mec="black", label="relay source"),
        Line2D([], [], ls="", marker="p", ms=8, color=OKABE_ITO["sky"], mec="black", label="relay sink"),
        Line2D(
            [], [], ls="", marker="o", ms=6, color=ROLE_COLOURS["relay"], mec="black", label="relay robot"
        ),
    ]
    if labels:
        for xy, name in _node_labels(nodes, node_names(n_fixed - 1, len(nodes) - n_fixed)):
            ax.annotate(
                name,
                xy,
                xytext=(-6, -4),
                textcoords="offset points",
                ha="right",
                va="top",
                fontsize=7,
                zorder=12,
                bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.7},
            )
    return handles


def _node_labels(nodes: np.ndarray, names: list[str]) -> list[tuple[np.ndarray, str]]:
    """One label per cluster of nodes closer than 2% of the graph's extent (the chains of a
    redundant relay stand side by side, and their labels overprinted each other): the names
    joined, at the cluster's first node."""
    if len(nodes) < 2:
        return list(zip(nodes, names, strict=True))
    span = float(max(np.ptp(nodes[:, 0]), np.ptp(nodes[:, 1]), 1.0))
    cluster = fclusterdata(nodes, t=0.02 * span, criterion="distance", method="single")
    out = []
    for c in dict.fromkeys(cluster.tolist()):  # clusters in the order of their first node
        members = np.flatnonzero(cluster == c)
        out.append((nodes[members[0]], ", ".join(names[k] for k in members)))
    return out


def unique_handles(handles: list) -> list:
    """Legend handles without repeated labels (the map's region kinds and the plan's own nodes)."""
    seen: set[str] = set()
    out = []
    for h in handles:
        label = h.get_label()
        if label not in seen:
            seen.add(label)
            out.append(h)
    return out


def _margin_colorbar(fig, ax, margins: Sequence[float] | None) -> None:
    if margins is None or not len(margins):
        return
    sm = ScalarMappable(norm=_margin_norm(margins), cmap=MARGIN_CMAP)
    bar = fig.colorbar(sm, ax=ax, shrink=0.7, pad=0.01, aspect=25)
    bar.set_label("relay link margin (dB)", fontsize=8)
    bar.ax.tick_params(labelsize=7)


def plan_map_png(plan: MissionPlan, margins: Sequence[float] | None = None) -> bytes | None:
    """The map with routes by role (dotted: the sea leg), search tracks with their sensor swaths and
    the relay links coloured by margin (with a colour bar); None without the map."""
    if plan.beach_map is None:
        return None
    fig, ax, handles = map_axes(plan.beach_map, 3)
    for sp in plan.search:
        tracks = [t for run in sp.tracks for t in run]
        band = swath(tracks, sp.sweep_width_m)
        if band is not None and not band.is_empty:
            ax.add_patch(
                patch_from_polygon(
                    band, facecolor=ROLE_COLOURS["search"], edgecolor="none", alpha=SWATH_ALPHA, zorder=5
                )
            )
        for t in tracks:
            xy = np.asarray(t.coords)
            ax.plot(xy[:, 0], xy[:, 1], "-", color="#1A1A1A", lw=0.5, alpha=0.7, zorder=6)
    if plan.search:
        width = ", ".join(f"{sp.sweep_width_m:g} m" for sp in plan.search)
        handles.append(
            Patch(facecolor=ROLE_COLOURS["search"], alpha=SWATH_ALPHA, label=f"sensor swath (W {width})")
        )
        handles.append(Line2D([], [], color="#1A1A1A", lw=0.7, label="search tracks"))
    seen: set[str] = set()
    for b in plan.robots:
        xy = np.vstack([b.sea_leg_m, b.ground_m.reshape(-1, 2)])
        colour = ROLE_COLOURS.get(b.role, "#777777")
        ax.plot(xy[:2, 0], xy[:2, 1], ":", color=colour, lw=1.0, zorder=7)
        ax.plot(xy[1:, 0], xy[1:, 1], "-", color=colour, lw=1.5, zorder=8)
        ax.plot(xy[-1, 0], xy[-1, 1], "s", ms=4, color=colour, mec="white", zorder=9)
        seen.add(b.role)
    handles += [
        Line2D([], [], color=ROLE_COLOURS.get(r, "#777777"), lw=1.8, label=f"route: {r}")
        for r in ROLE_ORDER
        if r in seen
    ]
    if plan.relay is not None:
        handles += _draw_relay(ax, plan, margins, labels=False)
        _margin_colorbar(fig, ax, margins)
    shown = ["routes by role (dotted: sea leg)"]
    shown += ["search tracks and swaths"] if plan.search else []
    shown += ["relay links by margin"] if plan.relay is not None else []
    ax.set_title(f"{plan.mission} on {plan.beach_map.name}, seed {plan.seed}: {', '.join(shown)}", fontsize=9)
    fig.legend(handles=unique_handles(handles), loc="outside lower center", ncol=4, fontsize=7, frameon=False)
    return png_bytes(fig)


def _relay_bounds(plan: MissionPlan) -> tuple[float, float, float, float]:
    nodes = plan.relay.nodes_m
    x0, y0, x1, y1 = plan.beach_map.bounds_m
    lo, hi = nodes.min(axis=0), nodes.max(axis=0)
    margin = max(10.0, 0.12 * float(max(hi - lo)))
    return max(x0, lo[0] - margin), max(y0, lo[1] - margin), min(x1, hi[0] + margin), min(y1, hi[1] + margin)


def relay_png(plan: MissionPlan, margins: Sequence[float] | None = None) -> bytes | None:
    """The relay graph close up over the map: source, sinks, relay robots, each link labelled with
    its margin in dB; None without a relay task or the map."""
    if plan.relay is None or plan.beach_map is None:
        return None
    fig, ax, handles = map_axes(plan.beach_map, 2, _relay_bounds(plan))
    handles = [h for h in handles if isinstance(h, Line2D)]  # regions, not the terrain fractions
    handles += _draw_relay(ax, plan, margins, labels=True)
    _margin_colorbar(fig, ax, margins)
    r = plan.relay
    ax.set_title(
        f"relay {r.task}: {len(r.positions_m)} relay robots, range {r.comm_range_m:.0f} m, "
        f"redundancy {r.redundancy}; labels: link margin (dB)",
        fontsize=9,
    )
    fig.legend(handles=unique_handles(handles), loc="outside lower center", ncol=4, fontsize=7, frameon=False)
    return png_bytes(fig)


def arrival_png(robots: Sequence[dict]) -> bytes | None:
    """Each robot from its release to its ETA: swimming (hatched) then driving (solid), coloured by
    role; `robots` are the plan report's robot rows (release_s, sea_time_s, eta_s, role, id)."""
    if not robots:
        return None
    n = len(robots)
    end = max(float(r["eta_s"]) for r in robots)
    minutes = end > 600.0
    scale = 60.0 if minutes else 1.0
    fig, ax = new_figure(9.0, min(12.0, 1.6 + 0.2 * n), layout="constrained")
    for y, r in enumerate(robots):
        colour = ROLE_COLOURS.get(r["role"], "#777777")
        release, sea, eta = float(r["release_s"]), float(r["sea_time_s"]), float(r["eta_s"])
        ax.barh(
            y,
            sea / scale,
            left=release / scale,
            height=0.7,
            color=colour,
            alpha=0.35,
            hatch="///",
            edgecolor=colour,
            lw=0.5,
        )
        ax.barh(
            y,
            max(eta - release - sea, 0.0) / scale,
            left=(release + sea) / scale,
            height=0.7,
            color=colour,
            edgecolor="white",
            lw=0.4,
        )
        ax.plot(eta / scale, y, "|", color="black", ms=8, mew=1.2)
    working = [float(r["eta_s"]) for r in robots if r["role"] != "spare"]
    if working:
        ax.axvline(max(working) / scale, color=OKABE_ITO["vermillion"], ls="--", lw=1.0)
    ax.set_ylim(n - 0.5, -0.5)
    step = max(1, int(np.ceil(n / 40)))
    ax.set_yticks(range(0, n, step), [robots[i]["id"] for i in range(0, n, step)], fontsize=7)
    ax.set_xlim(left=0)
    ax.set_xlabel(f"mission time ({'min' if minutes else 's'}) from the first release")
    ax.set_ylabel("robot")
    ax.grid(axis="y", visible=False)
    roles = [role for role in ROLE_ORDER if any(r["role"] == role for r in robots)]
    handles = [Patch(color=ROLE_COLOURS.get(role, "#777777"), label=role) for role in roles]
    handles += [
        Patch(
            facecolor="#999999", alpha=0.35, hatch="///", edgecolor="#555555", label="swim (release to entry)"
        ),
        Patch(facecolor="#555555", label="drive (entry to goal)"),
        Line2D([], [], ls="", marker="|", color="black", ms=8, mew=1.2, label="ETA"),
    ]
    if working:
        handles.append(Line2D([], [], color=OKABE_ITO["vermillion"], ls="--", label="last arrival"))
    ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_title(
        f"arrival timeline: {n} robots, last working robot arrives at "
        f"{(max(working) if working else end) / scale:.1f} {'min' if minutes else 's'}",
        fontsize=9,
    )
    return png_bytes(fig)


def evaluation_png(
    evaluation: dict, criterion: float | None, expected: list[float], expected_lost: float | None = None
) -> bytes:
    """Histograms of the detected fraction and of the robots lost over the plan's simulated runs,
    each with what the plan expects of a run with its losses (`expected`: each search's detection
    after losses; `expected_lost`: None with the hazards off)."""
    det = evaluation.get("detection_values") or []
    if det:
        fig, (left, right) = new_figure(7.2, 2.8, ncols=2)
    else:  # no search: the losses alone
        fig, right = new_figure(3.8, 2.8)
    if det:
        left.hist(det, bins=min(20, max(5, len(det) // 3)), color=ROLE_COLOURS["search"], alpha=0.8)
        if criterion is not None:
            left.axvline(criterion, color="black", ls="--", lw=1.2, label=f"criterion {criterion:.0%}")
        for e in expected:
            left.axvline(e, color="black", lw=1.2, label=f"plan {e:.1%}")
        left.legend(loc="upper left", fontsize=8)
        left.set_xlabel("mines detected per run (fraction)")
        left.set_ylabel("runs")
    lost = evaluation.get("lost_values") or []
    if lost:
        top = max(max(lost), math.ceil(expected_lost or 0))
        right.hist(lost, bins=np.arange(-0.5, top + 1.5, 1.0), color=ROLE_COLOURS["spare"], alpha=0.8)
    if expected_lost is not None:
        right.axvline(expected_lost, color="black", lw=1.2, label=f"plan {expected_lost:.1f}")
        right.legend(loc="upper left", fontsize=8)
    right.set_xlabel("robots lost per run")
    right.set_ylabel("runs")
    return png_bytes(fig)
