"""Figures of a Monte Carlo study, each as PNG bytes for the self-contained study report: success
probability against the swept parameter (with Wilson intervals, the target and the required value),
losses by phase and cause, where robots were lost over the map, and time to success per point.

Inputs are the study's `summary` (summary.json as a dict) and its results table
(`swarm.studies.table`, one row per run). Losses by cause use the animation's colours
(`swarm.sim.render.CAUSE_COLOURS`); series use the Okabe-Ito palette plus a marker and line style
each, so no figure relies on colour alone. Every function returns None when there is nothing to show.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
from matplotlib import colormaps
from matplotlib.colors import ListedColormap
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from swarm.report.map_figure import map_axes
from swarm.report.sim_figures import loss_marker
from swarm.report.style import OKABE_ITO, as_words, new_figure, plt, png_bytes
from swarm.sim.hazards import CAUSES
from swarm.sim.layout import PHASES
from swarm.sim.render import cause_colour
from swarm.world.beachmap import BeachMap

#: One style per series (a value of the second swept key): colour, marker, line style.
SERIES_STYLES = [
    (OKABE_ITO["blue"], "o", "-"),
    (OKABE_ITO["vermillion"], "s", "--"),
    (OKABE_ITO["green"], "^", "-."),
    (OKABE_ITO["orange"], "D", ":"),
    (OKABE_ITO["purple"], "v", "-"),
    (OKABE_ITO["sky"], "P", "--"),
    (OKABE_ITO["black"], "X", "-."),
]
#: Units a key's name carries (`hazards.surf.wave_height_m`), for axis labels.
KEY_UNITS = (
    ("_per_km", "per km"),
    ("_per_ha", "per ha"),
    ("_per_h", "per h"),
    ("_per_s", "per s"),
    ("_mps", "m/s"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_m", "m"),
    ("_s", "s"),
    ("_h", "h"),
)
#: Keys whose values are counts of something nameable.
KEY_NOUNS = {"swarm.count": "robots", "mines.count": "mines"}
#: Above this many losses the loss map shows only the heat map (markers would hide it).
MAX_LOSS_MARKERS = 200
#: Loss heat map colours: inferno (perceptually uniform, colour-blind safe) without its near-black
#: end, which would read as boulders or deep water on the map.
HEAT_CMAP = ListedColormap(colormaps["inferno"](np.linspace(0.25, 0.95, 256)), name="losses")
#: Small multiples of the completion-time figure per row.
PANELS_PER_ROW = 4


def key_unit(key: str) -> str:
    """The unit a swept key's name implies ('robots' for swarm.count, 'm' for ..._m), or ''."""
    if key in KEY_NOUNS:
        return KEY_NOUNS[key]
    for suffix, unit in KEY_UNITS:
        if key.endswith(suffix):
            return unit
    return ""


def key_label(key: str) -> str:
    """An axis label for a swept key: its path and its unit."""
    unit = key_unit(key)
    return f"{key} ({unit})" if unit else key


def format_value(value: object) -> str:
    """A swept value as people read it: integers without a point, floats with up to 4 digits."""
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def point_label(params: dict) -> str:
    """A point's parameters in one short line ('all runs' when nothing is swept)."""
    if not params:
        return "all runs"
    return ", ".join(f"{k} = {format_value(v)}" for k, v in params.items())


def short_label(params: dict) -> str:
    """A point's parameters for a tick label: the last part of each key path ('count = 10,
    wave_height_m = 0.5'), whole paths where two would read the same."""
    names = [k.rsplit(".", 1)[-1] for k in params]
    if not params or len(set(names)) < len(names):
        return point_label(params)
    return ", ".join(f"{n} = {format_value(v)}" for n, v in zip(names, params.values(), strict=True))


def swept_keys(summary: dict) -> list[str]:
    """The swept keys in sweep order, or those of the points' params when `sweeps` is absent."""
    keys = list(summary.get("sweeps") or {})
    if not keys:
        for p in summary.get("points", []):
            keys += [k for k in p.get("params", {}) if k not in keys]
    return keys


def x_key(summary: dict) -> str | None:
    """The key on the success figure's x axis: the key the required value is for when it is swept
    (the question the study answers), else the first swept key; None when nothing is swept."""
    keys = swept_keys(summary)
    required = (summary.get("required") or {}).get("key")
    if required in keys:
        return required
    return keys[0] if keys else None


def _hashable(value: object) -> object:
    """A swept value as a key of the figures' lookups: itself, or a list's or mapping's JSON."""
    return json.dumps(value, sort_keys=True, default=str) if isinstance(value, list | dict) else value


def _numeric(values: Sequence[object]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _x_positions(summary: dict, key: str | None) -> tuple[dict, list[str] | None]:
    """Each x value's position, and tick labels when the values are not numbers (categories)."""
    if key is None:
        return {None: 0.0}, ["all runs"]
    values = list((summary.get("sweeps") or {}).get(key) or [])
    for p in summary.get("points", []):
        v = p.get("params", {}).get(key)
        if v not in values:
            values.append(v)
    if _numeric(values):
        return {v: float(v) for v in values}, None
    return {_hashable(v): float(i) for i, v in enumerate(values)}, [format_value(v) for v in values]


def _series(summary: dict, key: str | None) -> tuple[dict, list[str] | None, list[str], dict, float]:
    """The x positions and tick labels of `key`'s values, the other swept keys, the points grouped
    by those keys' values (one line each) and the smallest gap between x positions (for dodging)."""
    positions, ticks = _x_positions(summary, key)
    others = [k for k in swept_keys(summary) if k != key]
    series: dict[tuple, list[dict]] = {}
    for p in summary.get("points") or []:
        params = p.get("params", {})
        series.setdefault(tuple(_hashable(params.get(k)) for k in others), []).append(p)
    xs = sorted(set(positions.values()))
    gap = float(min(np.diff(xs))) if len(xs) > 1 else 1.0
    return positions, ticks, others, series, gap


def _x_axis(ax, key: str | None, positions: dict, ticks: list[str] | None) -> None:
    """The swept key's label and ticks: category names, or whole numbers for a count."""
    ax.set_xlabel(key_label(key) if key is not None else "")
    if ticks is not None:
        ax.set_xticks(sorted(positions.values()), ticks)
        if len(ticks) == 1:
            ax.set_xlim(-1.0, 1.0)
    elif key is not None and all(isinstance(v, int) for v in positions):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))


def success_png(summary: dict) -> bytes | None:
    """Success probability against the swept key with Wilson interval error bars, one line per value
    of the other swept keys, the plan's chance of success as a hollow marker where it gives one,
    the target as a horizontal line and the required value marked; None without points."""
    points = summary.get("points") or []
    if not points:
        return None
    key = x_key(summary)
    positions, ticks, others, series, gap = _series(summary, key)
    fig, ax = new_figure(7.5, 4.2, layout="constrained")
    for i, (combo, pts) in enumerate(series.items()):
        colour, marker, style = SERIES_STYLES[i % len(SERIES_STYLES)]
        pts = sorted(pts, key=lambda p: positions[_hashable(p.get("params", {}).get(key))])
        dodge = 0.04 * gap * (i - (len(series) - 1) / 2)  # keeps overlapping error bars apart
        x = np.array([positions[_hashable(p.get("params", {}).get(key))] for p in pts]) + dodge
        rate = np.array([p["success_rate"] for p in pts], dtype=float)
        lo = np.clip(rate - np.array([p["wilson_low"] for p in pts], dtype=float), 0.0, None)
        hi = np.clip(np.array([p["wilson_high"] for p in pts], dtype=float) - rate, 0.0, None)
        label = ", ".join(f"{k} = {format_value(v)}" for k, v in zip(others, combo, strict=True))
        ax.errorbar(
            x,
            rate,
            yerr=[lo, hi],
            color=colour,
            marker=marker,
            ls=style,
            ms=5,
            capsize=3,
            lw=1.4,
            label=label or "P(success)",
            zorder=5,
        )
        chances = [(xi, p.get("planned_success")) for xi, p in zip(x, pts, strict=True)]
        planned = [(xi, c) for xi, c in chances if c is not None]
        if planned:
            px, py = zip(*planned, strict=True)
            ax.plot(px, py, ls="none", marker=marker, ms=9, mfc="none", mec=OKABE_ITO["black"], mew=1.3,
                    label="plan" + (f": {label}" if label else ""), zorder=6)  # fmt: skip
    target = summary.get("target")
    if target is not None:
        ax.axhline(target, color=OKABE_ITO["black"], ls="--", lw=1.0, label=f"target {target:g}", zorder=3)
    required = summary.get("required") or {}
    value = required.get("value")
    if value is not None and required.get("key") == key and _hashable(value) in positions:
        ax.axvline(
            positions[_hashable(value)],
            color=OKABE_ITO["green"],
            ls=":",
            lw=2.0,
            label=f"required: {format_value(value)}" + (f" {key_unit(key)}" if key_unit(key) else ""),
            zorder=4,
        )
    ax.set_ylim(-0.02, 1.05)
    ax.set_ylabel("P(success) (fraction of runs)")
    _x_axis(ax, key, positions, ticks)
    confidence = summary.get("confidence", 0.95)
    runs = summary.get("runs_per_point")
    per = f", {runs} runs per point" if runs else ""
    planned = any(p.get("planned_success") is not None for p in points)
    hollow = ", the plan's chance hollow" if planned else ""
    ax.set_title(f"success probability with {confidence:.0%} Wilson intervals{per}{hollow}", fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return png_bytes(fig)


#: The plan-against-runs panels: (the point's mean, its interval, the plan's value, axis label, as %).
AGREEMENT_PANELS = (
    ("detection_mean", "detection_interval", "planned_detection", "mines found per run", True),
    ("lost_mean", "lost_interval", "planned_lost", "robots lost per run", False),
)


def agreement_png(summary: dict) -> bytes | None:
    """What the plan expects against what its runs gave, point by point: each panel the runs' mean
    with its t interval (`stats.mean_interval`) and the plan's expectation as a hollow marker, for
    the mines found (where the mission has a search) and the robots lost (where it has hazards);
    None when no point has a plan's expectation."""
    points = summary.get("points") or []
    panels = [
        panel
        for panel in AGREEMENT_PANELS
        if any(p.get(panel[2]) is not None and p.get(panel[0]) is not None for p in points)
    ]
    if not panels:
        return None
    key = x_key(summary)
    positions, ticks, others, series, gap = _series(summary, key)
    fig, axes = new_figure(
        4.2 * len(panels) + 1.6, 3.8, ncols=len(panels), layout="constrained", squeeze=False
    )
    for ax, (mean_key, interval_key, plan_key, label, as_percent) in zip(axes[0], panels, strict=True):
        scale = 100.0 if as_percent else 1.0
        for i, (combo, pts) in enumerate(series.items()):
            colour, marker, _ = SERIES_STYLES[i % len(SERIES_STYLES)]
            pts = sorted(
                (p for p in pts if p.get(mean_key) is not None),
                key=lambda p: positions[_hashable(p.get("params", {}).get(key))],
            )
            if not pts:
                continue
            dodge = 0.06 * gap * (i - (len(series) - 1) / 2)
            x = np.array([positions[_hashable(p.get("params", {}).get(key))] for p in pts]) + dodge
            mean = np.array([p[mean_key] for p in pts], dtype=float) * scale
            bounds = [p.get(interval_key) or [p[mean_key], p[mean_key]] for p in pts]
            lo = np.clip(mean - np.array([b[0] for b in bounds], dtype=float) * scale, 0.0, None)
            hi = np.clip(np.array([b[1] for b in bounds], dtype=float) * scale - mean, 0.0, None)
            name = ", ".join(f"{k} = {format_value(v)}" for k, v in zip(others, combo, strict=True))
            ax.errorbar(x, mean, yerr=[lo, hi], color=colour, marker=marker, ls="none", ms=5, capsize=3,
                        lw=1.4, label=f"runs{': ' + name if name else ''}", zorder=5)  # fmt: skip
            planned = [
                (xi, p[plan_key] * scale) for xi, p in zip(x, pts, strict=True) if p.get(plan_key) is not None
            ]
            if planned:
                px, py = zip(*planned, strict=True)
                ax.plot(px, py, ls="none", marker=marker, ms=9, mfc="none", mec=OKABE_ITO["black"], mew=1.3,
                        label=f"plan{': ' + name if name else ''}", zorder=6)  # fmt: skip
        ax.set_ylabel(label + (" (%)" if as_percent else ""))
        _x_axis(ax, key, positions, ticks)
        ax.legend(fontsize=7, frameon=False)
    confidence = summary.get("confidence", 0.95)
    fig.suptitle(f"the plan's expectation (hollow) against the runs' means with {confidence:.0%} t intervals",
                 fontsize=9)  # fmt: skip
    return png_bytes(fig)


def causes_by_point(summary: dict) -> tuple[list[dict], list[str], list[list[dict]]]:
    """The points whose plan gives its losses by cause (`summarize`'s `lost_by_cause`), the causes
    any of them has (in `CAUSES` order), and each point's entry for each cause: its runs' mean and
    interval and the plan's value (0 lost, none planned, where the point has no entry)."""
    points = [p for p in summary.get("points") or [] if p.get("lost_by_cause")]
    found = [{c["cause"]: c for c in p["lost_by_cause"]} for p in points]
    causes = ordered_causes({c for entries in found for c in entries})
    none = {"mean": 0.0, "interval": None, "planned": 0.0}
    return points, causes, [[entries.get(c, none) for c in causes] for entries in found]


def causes_png(summary: dict) -> bytes | None:
    """Robots lost a run to each cause against the plan's expectation: per cause, each point's runs'
    mean with its interval (`causes_by_point`) and the plan's value as a hollow marker around it,
    as `agreement_png` draws them; None when no point's plan gives its losses by cause."""
    points, causes, entries = causes_by_point(summary)
    if not points:
        return None
    fig, ax = new_figure(max(5.5, min(1.1 * len(causes) + 0.25 * len(causes) * len(points) + 2.0, 14.0)), 3.8,
                         layout="constrained")  # fmt: skip
    x = np.arange(len(causes), dtype=float)
    step = 0.8 / max(len(points), 1)
    for i, (point, rows) in enumerate(zip(points, entries, strict=True)):
        colour, marker, _ = SERIES_STYLES[i % len(SERIES_STYLES)]
        at = x - 0.4 + step * (i + 0.5)
        mean = np.array([r["mean"] for r in rows], dtype=float)
        bounds = np.array([r["interval"] or [r["mean"], r["mean"]] for r in rows], dtype=float)
        name = short_label(point.get("params", {})) if len(points) > 1 else ""
        ax.errorbar(at, mean, yerr=[np.clip(mean - bounds[:, 0], 0, None),
                    np.clip(bounds[:, 1] - mean, 0, None)], color=colour, marker=marker, ls="none", ms=5,
                    capsize=3, lw=1.4, label=f"runs{': ' + name if name else ''}", zorder=5)  # fmt: skip
        planned = [(a, r["planned"]) for a, r in zip(at, rows, strict=True) if r["planned"] is not None]
        if planned:
            px, py = zip(*planned, strict=True)
            ax.plot(px, py, ls="none", marker=marker, ms=9, mfc="none", mec=colour,
                    mew=1.3, label=f"plan{': ' + name if name else ''}", zorder=6)  # fmt: skip
    ax.set_xticks(x, [as_words(c) for c in causes])
    plt.setp(ax.get_xticklabels(), rotation=20, ha="right")
    ax.set_ylabel("robots lost per run")
    ax.set_ylim(bottom=0.0)
    ax.grid(axis="x", visible=False)
    ax.legend(fontsize=7, frameon=False, ncols=2 if len(points) > 3 else 1)
    confidence = summary.get("confidence", 0.95)
    ax.set_title(f"the plan's expectation (hollow) against the runs' mean with its {confidence:.0%} interval",
                 fontsize=9)  # fmt: skip
    return png_bytes(fig)


def ordered_phases(names: Sequence[str]) -> list[str]:
    """Phases in mission order (`PHASES`), unknown ones after, sorted."""
    present = set(names)
    return [p for p in PHASES if p in present] + sorted(present - set(PHASES))


def ordered_causes(names: Sequence[str]) -> list[str]:
    """Causes in `CAUSES` order (as every loss table), unknown ones after, sorted."""
    present = set(names)
    return [c for c in CAUSES if c in present] + sorted(present - set(CAUSES))


def pooled_losses_by_phase(summary: dict) -> dict[str, dict[str, int]]:
    """Losses by phase then cause over every run: the summary's own, else summed over its points."""
    pooled = summary.get("losses_by_phase")
    if pooled:
        return pooled
    out: dict[str, dict[str, int]] = {}
    for p in summary.get("points", []):
        for phase, causes in (p.get("losses_by_phase") or {}).items():
            for cause, n in causes.items():
                out.setdefault(phase, {})[cause] = out.setdefault(phase, {}).get(cause, 0) + n
    return out


def total_runs(summary: dict) -> int:
    """Runs in the study: the summary's count, else the sum over its points."""
    return int(summary.get("runs") or sum(p.get("runs", 0) for p in summary.get("points", [])))


def losses_png(summary: dict) -> bytes | None:
    """Mean robots lost per run, stacked by cause: by the phase they were in (all runs pooled, left)
    and by parameter point (right: how losses change with the swept values); None without losses."""
    by_phase = pooled_losses_by_phase(summary)
    runs = total_runs(summary)
    if not runs or not any(n for causes in by_phase.values() for n in causes.values()):
        return None
    points = [p for p in summary.get("points", []) if p.get("runs")]
    causes = ordered_causes([c for cs in by_phase.values() for c, n in cs.items() if n])
    phases = ordered_phases([p for p, cs in by_phase.items() if any(cs.values())])
    extra: dict[str, str] = {}
    colours = {c: cause_colour(c, extra) for c in causes}

    width = 3.0 + 0.8 * len(phases) + 0.55 * len(points)
    fig, (left, right) = new_figure(
        max(7.5, min(width, 14.0)),
        3.8,
        ncols=2,
        sharey=True,
        layout="constrained",
        gridspec_kw={"width_ratios": [max(len(phases), 2), max(len(points), 2)]},
    )
    bottom = np.zeros(len(phases))
    point_bottom = np.zeros(len(points))
    for cause in causes:
        mean = np.array([by_phase.get(p, {}).get(cause, 0) / runs for p in phases])
        left.bar(
            [as_words(p) for p in phases],
            mean,
            bottom=bottom,
            color=colours[cause],
            edgecolor="white",
            lw=0.6,
            label=as_words(cause),
        )
        bottom += mean
        per_point = np.array([(p.get("losses_by_cause") or {}).get(cause, 0) / p["runs"] for p in points])
        right.bar(
            np.arange(len(points)),
            per_point,
            bottom=point_bottom,
            color=colours[cause],
            edgecolor="white",
            lw=0.6,
        )
        point_bottom += per_point
    left.set_xlabel("phase when lost")
    left.set_ylabel("robots lost per run (mean)")
    left.set_title(f"by phase, all {runs} runs", fontsize=9)
    left.grid(axis="x", visible=False)
    plt.setp(left.get_xticklabels(), rotation=20, ha="right")
    key = x_key(summary)
    labels = [
        format_value(p.get("params", {}).get(key))
        if len(swept_keys(summary)) == 1
        else short_label(p["params"])
        for p in points
    ]
    right.set_xticks(np.arange(len(points)), labels)
    right.set_xlabel(key_label(key) if len(swept_keys(summary)) == 1 else "parameter point")
    if len(swept_keys(summary)) != 1:
        plt.setp(right.get_xticklabels(), rotation=30, ha="right", fontsize=7)
    right.set_title("by parameter point", fontsize=9)
    right.grid(axis="x", visible=False)
    fig.legend(title="cause", loc="outside right center", fontsize=7, title_fontsize=7, frameon=False)
    fig.suptitle("robots lost per run, by cause", fontsize=10)
    return png_bytes(fig)


def loss_points(table: pa.Table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every loss in the table: x (m), y (m) and cause, as arrays (empty without losses)."""
    if table.num_rows == 0 or "losses" not in table.column_names:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=object)
    flat = pc.list_flatten(table.column("losses"))
    if len(flat) == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=object)
    flat = flat.combine_chunks() if isinstance(flat, pa.ChunkedArray) else flat
    x = flat.field("x_m").to_numpy(zero_copy_only=False).astype(float)
    y = flat.field("y_m").to_numpy(zero_copy_only=False).astype(float)
    cause = np.array(flat.field("cause").to_pylist(), dtype=object)
    return x, y, cause


def loss_bin_m(beach_map: BeachMap) -> float:
    """Heat-map cell size: 5 m on beaches up to 250 m across, 10 m beyond (and never below a map cell)."""
    extent = max(beach_map.width_m, beach_map.height_m)
    return max(5.0 if extent <= 250.0 else 10.0, float(beach_map.cell_m))


def loss_map_png(table: pa.Table, beach_map: BeachMap | None) -> bytes | None:
    """Where robots were lost over all runs: a 2D histogram over the map (empty cells transparent)
    and, when there are few, a marker per loss by cause (`loss_marker`, as the simulation report);
    None without a map or without losses."""
    x, y, cause = loss_points(table)
    if beach_map is None or not len(x):
        return None
    x0, y0, x1, y1 = beach_map.bounds_m
    bin_m = loss_bin_m(beach_map)
    xedges = np.append(np.arange(x0, x1, bin_m), x1)
    yedges = np.append(np.arange(y0, y1, bin_m), y1)
    counts, _, _ = np.histogram2d(x, y, bins=[xedges, yedges])
    outside = len(x) - int(counts.sum())

    fig, ax, handles = map_axes(beach_map, 3, extra_width_in=1.0)  # room for the colour bar
    mesh = ax.pcolormesh(
        xedges,
        yedges,
        np.ma.masked_equal(counts.T, 0),
        cmap=HEAT_CMAP,
        alpha=0.8,
        edgecolors="none",
        zorder=8,
    )
    bar = fig.colorbar(mesh, ax=ax, shrink=0.85, pad=0.01)
    bar.set_label(f"losses per cell ({bin_m:g} m × {bin_m:g} m)")
    bar.locator = MaxNLocator(integer=True)
    bar.update_ticks()
    if len(x) <= MAX_LOSS_MARKERS:
        extra: dict[str, str] = {}
        for c in ordered_causes(list(set(cause))):
            mask = cause == c
            colour = cause_colour(c, extra)
            marker, area = loss_marker(c, 22.0)
            ax.scatter(
                x[mask],
                y[mask],
                s=area,
                marker=marker,
                c=colour,
                edgecolors="white",
                linewidths=0.5,
                zorder=10,
            )
            handles.append(
                Line2D(
                    [],
                    [],
                    ls="",
                    marker=marker,
                    ms=loss_marker(c, 25.0)[1] ** 0.5,
                    color=colour,
                    mec="white",
                    label=f"lost: {as_words(c)}",
                )
            )
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    runs = table.num_rows
    note = f"; {outside} outside the map" if outside else ""
    ax.set_title(f"where robots were lost: {len(x)} losses in {runs} runs{note}", fontsize=9)
    fig.legend(handles=handles, loc="outside lower center", ncol=5, fontsize=7, frameon=False)
    return png_bytes(fig)


def completion_times(table: pa.Table) -> dict[int, np.ndarray]:
    """Each point's completion times (s) of the runs that met every criterion (NaN dropped)."""
    if table.num_rows == 0:
        return {}
    point = table.column("point").to_numpy()
    done = table.column("completed_s").to_numpy(zero_copy_only=False).astype(float)
    return {int(p): done[(point == p) & np.isfinite(done)] for p in np.unique(point)}


def completion_png(table: pa.Table, summary: dict) -> bytes | None:
    """Time to success per parameter point: a histogram of `completed_s` of the completed runs in one
    small panel per point (shared axes, median marked); a note when no run completed; None without
    runs."""
    times = completion_times(table)
    if not times:
        return None
    params = {p.get("index"): p.get("params", {}) for p in summary.get("points", [])}
    runs = {
        int(p): int(n)
        for p, n in zip(*np.unique(table.column("point").to_numpy(), return_counts=True), strict=True)
    }
    every = np.concatenate(list(times.values()))
    if not len(every):
        fig, ax = new_figure(6.0, 2.0, layout="constrained")
        ax.axis("off")
        ax.text(
            0.5,
            0.5,
            f"no run met every criterion ({table.num_rows} runs): no completion times",
            ha="center",
            va="center",
            fontsize=10,
        )
        return png_bytes(fig)
    lo, hi = float(every.min()) / 60.0, float(every.max()) / 60.0
    if hi - lo < 1e-9:
        lo, hi = lo - 0.5, hi + 0.5
    bins = np.linspace(lo, hi, min(30, max(6, int(math.sqrt(len(every))) + 2)))
    n = len(times)
    ncols = min(n, PANELS_PER_ROW)
    nrows = math.ceil(n / ncols)
    fig, axes = new_figure(
        max(6.0, 3.0 * ncols), 0.4 + 2.2 * nrows, nrows=nrows, ncols=ncols, sharex=True, sharey=True,
        layout="constrained", squeeze=False,
    )  # fmt: skip
    colour = OKABE_ITO["blue"]
    for ax, (p, t) in zip(axes.flat, times.items(), strict=False):
        title = short_label(params.get(p, {"point": p}))
        if len(t):
            ax.hist(t / 60.0, bins=bins, histtype="stepfilled", color=colour, alpha=0.35, lw=0)
            ax.hist(t / 60.0, bins=bins, histtype="step", color=colour, lw=1.4)
            ax.axvline(float(np.median(t)) / 60.0, color=OKABE_ITO["vermillion"], ls="--", lw=1.2)
        else:
            ax.text(0.5, 0.5, "none completed", transform=ax.transAxes, ha="center", va="center", fontsize=8)
        ax.set_title(f"{title}: {len(t)} of {runs.get(p, 0)} completed", fontsize=8)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    for i, ax in enumerate(axes.flat):
        if i >= n:
            ax.axis("off")
        elif i + ncols >= n:  # the lowest panel of its column: it carries the x axis
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel("time to success (min)")
    for ax in axes[:, 0]:
        ax.set_ylabel("runs")
    fig.legend(
        handles=[
            plt.Rectangle(
                (0, 0), 1, 1, facecolor=colour, alpha=0.35, edgecolor=colour, label="completed runs"
            ),
            Line2D([], [], color=OKABE_ITO["vermillion"], ls="--", label="median"),
        ],
        loc="outside lower center",
        ncol=2,
        fontsize=7,
        frameon=False,
    )
    fig.suptitle("time until every success criterion was met, completed runs only", fontsize=10)
    return png_bytes(fig)
