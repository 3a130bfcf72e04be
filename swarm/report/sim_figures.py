"""Figures of a simulated mission (`MissionLog`), each as PNG bytes for the self-contained report:
executed paths over the plan, where and why robots were lost, mines found and marked against the
truth, relay connectivity over time and robots per phase over time.

Colours follow the rest of the project: terrain as `plot_map`, robots by role as the plan report,
losses by cause as the animation (`swarm.sim.render.CAUSE_COLOURS`), phases as `PHASE_COLOURS`.
Every function returns None when the mission has nothing to show (no losses, no mines, no relay).
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from swarm.report.map_figure import map_axes
from swarm.report.style import OKABE_ITO, ROLE_COLOURS, as_words, new_figure, plt, png_bytes
from swarm.sim.layout import PHASES, ROLES
from swarm.sim.render import EXPLODED_FACE, MINE_COLOUR, NOT_LOST, cause_colour
from swarm.sim.run import MissionLog

#: Loss markers by cause (with `CAUSE_COLOURS`, two cues for colour-blind readers).
CAUSE_MARKERS = {
    "failure": "X",
    "wave_impact": "v",
    "immobilized": "s",
    "rock": "D",
    "mine": "*",
    "battery": "P",
    "cut_off": "p",
    "sea_timeout": "<",
    "surf_timeout": ">",
    "blast": "h",
}
#: Scatter area against the nominal one, for markers whose thin arms the white edge all but
#: covers at map sizes: matplotlib's star drew a twelfth of a square's ink at the study map's size.
MARKER_AREA_SCALE = {"*": 3.0}


def loss_marker(cause: str, area: float) -> tuple[str, float]:
    """A loss cause's marker and its scatter area (pt^2) for the nominal `area`, so that every
    cause's marks carry about as much ink as the others' (a legend's `ms` is the root of it)."""
    marker = CAUSE_MARKERS.get(cause, "o")
    return marker, area * MARKER_AREA_SCALE.get(marker, 1.0)


#: Robot states over time: the phases of `swarm.sim.layout.PHASES`, then how robots ended.
PHASE_COLOURS = {
    "waiting": "#DDDDDD",
    "sea_transit": OKABE_ITO["blue"],
    "surf_crossing": OKABE_ITO["sky"],
    "beach": OKABE_ITO["orange"],
    "returning": OKABE_ITO["purple"],
    "done": OKABE_ITO["green"],
    "recovered": OKABE_ITO["green"],
    "expended": OKABE_ITO["black"],
    "lost": OKABE_ITO["vermillion"],
    "time_limit": "#888888",
}


def robot_roles(log: MissionLog) -> list[str]:
    """Each robot's role: the last logged one when the log records roles over time (takeovers
    change them), else the planned one ("spare" without a plan)."""
    logged = getattr(log, "role", None)
    if logged is not None and len(logged):
        return [ROLES[int(r)] for r in np.asarray(logged)[-1]]
    if log.plan is None:
        return ["spare"] * len(log.robots)
    return [b.role for b in log.plan.robots]


def has_map(log: MissionLog) -> bool:
    """Whether the log carries its plan with the map (a log read back without its map does not)."""
    return log.plan is not None and getattr(log.plan, "beach_map", None) is not None


def _map_figure(
    log: MissionLog, legend_rows: int = 2, bounds: tuple[float, float, float, float] | None = None
):
    """A figure with the mission's map drawn in it (`map_axes`)."""
    return map_axes(log.plan.beach_map, legend_rows, bounds)


def _finish_map(fig, ax, handles: list, title: str) -> None:
    ax.set_title(title, fontsize=9)
    fig.legend(handles=handles, loc="outside lower center", ncol=5, fontsize=7, frameon=False)


def _loss_markers(ax, log: MissionLog, size: float = 60.0) -> list:
    """Every loss as its cause's marker at the place it happened; returns legend handles."""
    handles, extra = [], {}
    by_cause: dict[str, list[tuple[float, float]]] = {}
    for x in log.losses:
        by_cause.setdefault(x["cause"], []).append((x["x_m"], x["y_m"]))
    for cause, pts in sorted(by_cause.items()):
        xy = np.array(pts)
        colour = cause_colour(cause, extra)
        marker, area = loss_marker(cause, size)
        ax.scatter(
            xy[:, 0], xy[:, 1], s=area, marker=marker, c=colour, edgecolors="white", linewidths=0.8, zorder=12
        )
        handles.append(
            Line2D(
                [],
                [],
                ls="",
                marker=marker,
                ms=loss_marker(cause, 49.0)[1] ** 0.5,
                color=colour,
                mec="white",
                label=f"lost: {as_words(cause)} ({len(pts)})",
            )
        )
    return handles


def trajectories_png(log: MissionLog) -> bytes | None:
    """(a) Executed paths coloured by role over the planned routes (faint), losses by cause."""
    if not has_map(log):
        return None
    fig, ax, handles = _map_figure(log, 3)
    roles = robot_roles(log)
    for b in log.plan.robots:
        xy = b.waypoints_m
        ax.plot(
            xy[:, 0], xy[:, 1], "--", color=ROLE_COLOURS.get(b.role, "#777777"), lw=0.8, alpha=0.35, zorder=7
        )
    colours = [ROLE_COLOURS.get(r, "#777777") for r in roles]
    paths = [log.xy_m[:, i, :] for i in range(len(log.robots))]
    ax.add_collection(LineCollection(paths, colors=colours, linewidths=1.2, zorder=9))
    handles.append(Line2D([], [], ls="--", color="#555555", alpha=0.5, label="planned route"))
    handles += [
        Line2D([], [], color=ROLE_COLOURS.get(r, "#777777"), lw=1.6, label=f"executed: {r}")
        for r in dict.fromkeys(roles)
    ]
    handles += _loss_markers(ax, log)
    _finish_map(
        fig,
        ax,
        handles,
        f"{log.mission} on {log.map}, seed {log.seed}: executed paths by role over the plan (dashed)",
    )
    return png_bytes(fig)


def losses_map_png(log: MissionLog) -> bytes | None:
    """(b) Where robots were lost, a marker per cause; None when no robot was lost."""
    if not has_map(log) or not log.losses:
        return None
    fig, ax, handles = _map_figure(log, 3)
    for i in range(len(log.robots)):
        ax.plot(log.xy_m[:, i, 0], log.xy_m[:, i, 1], "-", color="#333333", lw=0.5, alpha=0.35, zorder=8)
    handles.append(Line2D([], [], color="#333333", lw=0.6, alpha=0.5, label="executed paths"))
    handles += _loss_markers(ax, log, size=80.0)
    _finish_map(fig, ax, handles, f"{len(log.losses)} robots lost: where, and why")
    return png_bytes(fig)


def losses_bar_png(log: MissionLog) -> bytes | None:
    """(b) Losses by cause, stacked by the phase the robot was in; None without losses."""
    by_phase = log.losses_by_phase()
    if not by_phase:
        return None
    causes = list(log.losses_by_cause())
    phases = [p for p in PHASES if p in by_phase] + sorted(set(by_phase) - set(PHASES))
    fig, ax = new_figure(max(4.5, 0.9 * len(causes) + 2.5), 3.4, layout="constrained")
    bottom = np.zeros(len(causes))
    for p in phases:
        counts = np.array([by_phase[p].get(c, 0) for c in causes], dtype=float)
        ax.bar(
            [as_words(c) for c in causes],
            counts,
            bottom=bottom,
            color=PHASE_COLOURS.get(p, "#777777"),
            edgecolor="white",
            lw=0.6,
            label=as_words(p),
        )
        bottom += counts
    ax.set_ylabel("robots lost")
    ax.set_xlabel("cause")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.grid(axis="x", visible=False)
    ax.legend(title="phase when lost", fontsize=7, title_fontsize=7, loc="upper right")
    ax.set_title(f"losses by cause and phase ({len(log.losses)} of {len(log.robots)} robots)", fontsize=9)
    plt.setp(ax.get_xticklabels(), rotation=20, ha="right")
    return png_bytes(fig)


def _zoom(log: MissionLog) -> tuple[float, float, float, float]:
    """Bounds around the search areas, mines and detections, with a margin, inside the map."""
    pts = [log.mines_m.reshape(-1, 2), log.objects_m.reshape(-1, 2)]
    for sp in log.plan.search:
        pts += [np.asarray(r, dtype=float).reshape(-1, 2) for r in sp.rings() if len(r)]
    xy = np.vstack(pts)
    x0, y0, x1, y1 = log.plan.beach_map.bounds_m
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    margin = max(5.0, 0.05 * float(max(hi - lo)))
    return (
        max(x0, lo[0] - margin),
        max(y0, lo[1] - margin),
        min(x1, hi[0] + margin),
        min(y1, hi[1] + margin),
    )


def mines_png(log: MissionLog) -> bytes | None:
    """(c) Mines detected, marked, set off and cleared against the truth, zoomed on the search area;
    None when there were neither mines nor detections."""
    if not has_map(log) or (not len(log.mines_m) and not len(log.objects_m)):
        return None
    fig, ax, handles = _map_figure(log, 3, _zoom(log))
    roles = robot_roles(log)
    for i, r in enumerate(roles):
        if r == "search":
            ax.plot(
                log.xy_m[:, i, 0],
                log.xy_m[:, i, 1],
                "-",
                color=ROLE_COLOURS["search"],
                lw=0.6,
                alpha=0.4,
                zorder=8,
            )
    handles.append(Line2D([], [], color=ROLE_COLOURS["search"], lw=0.8, alpha=0.6, label="searchers' paths"))
    pos, st = log.mines_m.reshape(-1, 2), {k: np.asarray(v, bool) for k, v in log.mines_state.items()}
    n = len(pos)

    def flag(name: str) -> np.ndarray:
        return st.get(name, np.zeros(n, bool)) if n else np.zeros(0, bool)

    layers = [
        (
            np.ones(n, bool),
            {"s": 30, "facecolors": "none", "edgecolors": MINE_COLOUR, "linewidths": 0.8},
            Line2D([], [], ls="", marker="o", mfc="none", mec=MINE_COLOUR, label=f"mine (truth, {n})"),
        ),
        (
            flag("detected"),
            {"s": 14, "c": MINE_COLOUR},
            Line2D(
                [],
                [],
                ls="",
                marker="o",
                ms=4,
                color=MINE_COLOUR,
                label=f"detected ({flag('detected').sum()})",
            ),
        ),
        (
            flag("marked"),
            {"s": 120, "facecolors": "none", "edgecolors": OKABE_ITO["vermillion"], "linewidths": 1.4},
            Line2D(
                [],
                [],
                ls="",
                marker="o",
                ms=10,
                mfc="none",
                mec=OKABE_ITO["vermillion"],
                mew=1.4,
                label=f"marked ({flag('marked').sum()})",
            ),
        ),
        (
            flag("exploded"),
            {"s": 160, "marker": "*", "facecolors": EXPLODED_FACE, "edgecolors": MINE_COLOUR},
            Line2D(
                [],
                [],
                ls="",
                marker="*",
                ms=11,
                mfc=EXPLODED_FACE,
                mec=MINE_COLOUR,
                label=f"set off by a robot ({flag('exploded').sum()})",
            ),
        ),
        (
            flag("cleared") & ~flag("exploded"),
            {"s": 160, "marker": "*", "facecolors": "white", "edgecolors": MINE_COLOUR},
            Line2D(
                [],
                [],
                ls="",
                marker="*",
                ms=11,
                mfc="white",
                mec=MINE_COLOUR,
                label=f"cleared ({flag('cleared').sum()})",
            ),
        ),
    ]
    for k, (mask, style, handle) in enumerate(layers):
        if n and (k == 0 or mask.any()):
            ax.scatter(pos[mask, 0], pos[mask, 1], zorder=11, **style)
            handles.append(handle)
    false = log.objects_m.reshape(-1, 2)[np.asarray(log.object_mine) < 0]
    if len(false):
        ax.scatter(
            false[:, 0], false[:, 1], s=40, marker="+", c=OKABE_ITO["purple"], linewidths=1.2, zorder=11
        )
        handles.append(
            Line2D(
                [],
                [],
                ls="",
                marker="+",
                color=OKABE_ITO["purple"],
                mew=1.2,
                label=f"false alarm ({len(false)})",
            )
        )
    _finish_map(fig, ax, handles, "mines found and marked against the truth (search area)")
    return png_bytes(fig)


#: Relay events: the source reaching every sink (first time, again) and losing them.
RELAY_UP_EVENTS = ("relay_connected", "relay_repair")
RELAY_DOWN_EVENTS = ("relay_break",)


def relay_intervals(log: MissionLog) -> list[tuple[float, float, bool]]:
    """(start s, end s, up) spans of the relay from its connect, break and repair events. The state
    before the first event is the opposite of it; without events, up if the relay criterion is
    above 0 (never connected otherwise)."""
    changes = [
        (float(ev["t_s"]), ev["kind"] in RELAY_UP_EVENTS)
        for ev in log.events
        if ev["kind"] in RELAY_UP_EVENTS + RELAY_DOWN_EVENTS
    ]
    end = float(log.times_s[-1]) if len(log.times_s) else 0.0
    if changes:
        state = not changes[0][1]
    else:
        state = log.outcome.get("criteria", {}).get("relay", {}).get("value", 0.0) > 0
    spans, t = [], 0.0
    for at, up in changes:
        if at > t:
            spans.append((t, at, state))
        t, state = at, up
    if end > t or not spans:
        spans.append((t, max(end, t), state))
    return spans


def has_relay(log: MissionLog) -> bool:
    return (log.plan is not None and log.plan.relay is not None) or "relay" in log.outcome.get("criteria", {})


def relay_png(log: MissionLog) -> bytes | None:
    """(d) Source-to-sinks connectivity over time (with the planned redundancy); None without a relay."""
    if not has_relay(log):
        return None
    spans = relay_intervals(log)
    fig, ax = new_figure(8.0, 2.2, layout="constrained")
    for a, b, up in spans:
        ax.fill_between(
            [a / 60.0, b / 60.0], 0, 1 if up else 0, step="post", color=OKABE_ITO["green"], alpha=0.5, lw=0
        )
    xs = [s[0] / 60.0 for s in spans] + [spans[-1][1] / 60.0]
    ys = [1 if s[2] else 0 for s in spans] + [1 if spans[-1][2] else 0]
    ax.step(xs, ys, where="post", color=OKABE_ITO["green"], lw=1.5)
    breaks = [ev["t_s"] / 60.0 for ev in log.events if ev["kind"] == "relay_break"]
    for t in breaks:
        ax.axvline(t, color=OKABE_ITO["vermillion"], lw=0.8, ls=":")
    ax.set_yticks([0, 1], ["down", "up"])
    ax.set_ylim(-0.1, 1.1)
    ax.set_xlim(0, max(xs[-1], 1e-6))
    ax.set_xlabel("mission time (min)")
    ax.set_ylabel("source to sinks")
    value = log.outcome.get("criteria", {}).get("relay", {}).get("value")
    frac = f", connected {value:.0%} of beach operations" if value is not None else ""
    plural = "" if len(breaks) == 1 else "s"
    ax.set_title(f"relay connectivity: {len(breaks)} break{plural}{frac}", fontsize=9)
    ax.legend(
        handles=[
            Patch(color=OKABE_ITO["green"], alpha=0.5, label="connected"),
            Line2D([], [], color=OKABE_ITO["vermillion"], ls=":", label="break"),
        ],
        fontsize=7,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        frameon=False,
    )
    return png_bytes(fig)


def phase_counts(log: MissionLog) -> dict[str, np.ndarray]:
    """Robots in each state at every logged time: live robots by phase, then how the others ended."""
    n = log.alive.shape[1]
    ends = [r or "lost" for r in log.end_reasons] if log.end_reasons else ["lost"] * n
    end_state = np.array([r if r in NOT_LOST else "lost" for r in ends])
    out: dict[str, np.ndarray] = {}
    for j, p in enumerate(PHASES):
        if p == "done":
            continue
        out[p] = (log.alive & (log.phase == j)).sum(axis=1)
    for state in ("recovered", "expended", "lost", "time_limit"):
        out[state] = (~log.alive & (end_state == state)[None, :]).sum(axis=1)
    return {s: c for s, c in out.items() if c.any()}


def phases_png(log: MissionLog) -> bytes | None:
    """(e) Robots per phase (and ended, by how) over mission time, stacked."""
    if not len(log.times_s):
        return None
    counts = phase_counts(log)
    fig, ax = new_figure(8.0, 3.2, layout="constrained")
    labels = {"time_limit": "stopped at the time limit", "beach": "on the beach"}
    ax.stackplot(
        log.times_s / 60.0,
        *counts.values(),
        colors=[PHASE_COLOURS[s] for s in counts],
        labels=[labels.get(s, as_words(s)) for s in counts],
    )
    ax.set_xlim(0, float(log.times_s[-1]) / 60.0 or 1.0)
    ax.set_ylim(0, len(log.robots))
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("mission time (min)")
    ax.set_ylabel("robots")
    ax.set_title("robots by phase over time", fontsize=9)
    fig.legend(loc="outside right center", fontsize=7, frameon=False)
    return png_bytes(fig)
