"""A mission plan as a report: `report.md` (summary and robot tables) and a self-contained
`report.html` (the map with routes by role, search tracks and the relay graph as an embedded PNG,
and the same tables)."""

from __future__ import annotations

import html
import io
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D

from swarm.files import write_text_atomic
from swarm.mission.plan import MissionPlan
from swarm.report.html_page import html_figure, html_page, html_table, md_table
from swarm.report.map_figure import figure_size, plot_map
from swarm.report.style import OKABE_ITO, ROLE_COLOURS, new_figure, plt


def summary_rows(plan: MissionPlan) -> list[list[str]]:
    s = plan.summary()
    rows = [
        ["robots", str(s["robots"])],
        ["roles", ", ".join(f"{k} {v}" for k, v in s["roles"].items())],
        ["first arrival", f"{s['first_arrival_s']:.0f} s"],
        ["last arrival", f"{s['last_arrival_s']:.0f} s"],
        ["total route length", f"{s['total_length_m']:.0f} m"],
    ]
    if plan.relay is not None:
        r = plan.relay
        hop = float(r.hop_lengths_m.max()) if len(r.hop_lengths_m) else 0.0
        rows.append(
            ["relays", f"{len(r.positions_m)} (range {r.comm_range_m:.0f} m, longest hop {hop:.0f} m)"]
        )
    for sp in plan.search:
        rows.append(
            [
                f"search {sp.task}",
                f"{len(sp.tracks)} searchers, spacing {sp.spacing_m:g} m, W {sp.sweep_width_m:g} m, "
                f"expected detection {sp.expected_detection:.1%} ({sp.model}), swath coverage "
                f"{sp.swath_coverage:.1%}",
            ]
        )
    return rows


def robot_rows(plan: MissionPlan) -> list[list[str]]:
    rows = [["robot", "role", "task", "launch (m)", "goal (m)", "ETA s", "length m"]]
    for b in plan.robots:
        goal = b.ground_m[-1] if len(b.ground_m) else b.sea_leg_m[-1]
        rows.append(
            [
                b.id,
                b.role,
                b.task or "-",
                f"({b.launch_m[0]:.1f}, {b.launch_m[1]:.1f})",
                f"({goal[0]:.1f}, {goal[1]:.1f})",
                f"{b.eta_s:.0f}",
                f"{b.length_m:.0f}",
            ]
        )
    return rows


def plan_figure_png(plan: MissionPlan) -> bytes:
    """The map with the routes coloured by role, search tracks and relay links, as PNG bytes."""
    bm = plan.beach_map
    w, h = figure_size(bm.width_m, bm.height_m, 2)
    fig, ax = new_figure(w, h, layout="constrained")
    try:
        plot_map(bm, None, ax=ax)
        legend = ax.get_legend()
        handles = list(legend.legend_handles) if legend is not None else []
        if legend is not None:
            legend.remove()
        for sp in plan.search:
            for run in sp.tracks:
                for t in run:
                    xy = np.asarray(t.coords)
                    ax.plot(xy[:, 0], xy[:, 1], "-", color="#333333", lw=0.4, alpha=0.6, zorder=6)
        if plan.search:
            handles.append(Line2D([], [], color="#333333", lw=0.6, label="search tracks"))
        seen = set()
        for b in plan.robots:
            xy = np.vstack([b.sea_leg_m, b.ground_m.reshape(-1, 2)])
            colour = ROLE_COLOURS[b.role]
            ax.plot(xy[:2, 0], xy[:2, 1], ":", color=colour, lw=1.0, zorder=7)
            ax.plot(xy[1:, 0], xy[1:, 1], "-", color=colour, lw=1.4, zorder=8)
            ax.plot(xy[-1, 0], xy[-1, 1], "s", ms=4, color=colour, mec="white", zorder=9)
            if b.role not in seen:
                seen.add(b.role)
                handles.append(Line2D([], [], color=colour, lw=1.6, label=f"route: {b.role}"))
        if plan.relay is not None:
            r = plan.relay
            nodes = np.vstack([r.source_m[None, :], r.sinks_m, r.positions_m.reshape(-1, 2)])
            for a, c in r.edges:
                ax.plot(*nodes[[a, c]].T, "--", color=OKABE_ITO["purple"], lw=1.0, zorder=7)
            ax.plot(*nodes.T, "o", ms=4, color=OKABE_ITO["purple"], mec="white", zorder=9)
            handles.append(Line2D([], [], color=OKABE_ITO["purple"], ls="--", label="relay links"))
        ax.set_title(f"{plan.mission} on {bm.name}: routes (dotted: sea leg), seed {plan.seed}", fontsize=9)
        fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=7, frameon=False)
        buf = io.BytesIO()
        fig.savefig(
            buf, format="png", dpi=110, bbox_inches="tight", pad_inches=0.08, metadata={"Software": None}
        )
        return buf.getvalue()
    finally:
        plt.close(fig)


def write_plan_report(plan: MissionPlan, out_dir: str | Path) -> dict[str, Path]:
    """Write report.md and report.html into `out_dir`; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary, robots = summary_rows(plan), robot_rows(plan)
    title = f"Mission plan: {plan.mission} on {plan.map} (seed {plan.seed})"
    md = "\n\n".join(
        [
            f"# {title}",
            "## Summary",
            md_table(summary, header=False),
            "## Robots",
            md_table(robots),
            "Files: plan.json (every waypoint), plan.geojson (routes, regions, tracks, relay links), "
            "report.html (with the map).",
        ]
    )
    page = html_page(
        title,
        [
            f"<h1>{html.escape(title)}</h1><h2>Summary</h2>{html_table(summary, header=False)}",
            html_figure("Map", plan_figure_png(plan)),
            f"<h2>Robots</h2>{html_table(robots)}",
        ],
    )
    paths = {"report.md": out / "report.md", "report.html": out / "report.html"}
    write_text_atomic(paths["report.md"], md + "\n")
    write_text_atomic(paths["report.html"], page)
    return paths
