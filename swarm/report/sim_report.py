"""A simulated mission as a report: `report.md` (verdict and tables) and a self-contained
`report.html` (the same, plus the figures of `swarm.report.sim_figures` as embedded PNG; no network).

```python
log = simulate(mission, seed=3)
write_log(log, out)            # trajectories.npz, events.jsonl, outcome.json
write_sim_report(log, out)     # report.md, report.html
```

The tables here (`criteria_rows`, `loss_rows`, `end_state_rows`, `mine_rows`) are also what
`swarm simulate` prints, so the terminal and the report always say the same thing.
"""

from __future__ import annotations

import datetime
import html
from collections.abc import Callable
from pathlib import Path

import swarm
from swarm.files import write_text_atomic
from swarm.report import sim_figures as figs
from swarm.report.html_page import html_figure, html_page, html_table, md_table
from swarm.sim.layout import PHASES
from swarm.sim.run import MissionLog

#: What each criterion measures, for readers who do not know the schema.
CRITERIA = {
    "landing": "landing zones held by their robots",
    "detection": "mines detected",
    "relay": "relay connected, fraction of beach operations",
    "surveillance": "observation points watched long enough",
    "beacon": "beacon points held",
    "recovered": "robots picked up at sea",
}


def format_value(criterion: str, value: float) -> str:
    """A criterion's value as people read it: a count of robots, else a percentage."""
    return f"{value:.0f}" if criterion == "recovered" else f"{value:.1%}"


def criteria_rows(outcome: dict) -> list[list[str]]:
    """criterion, what it measures, value, target, met."""
    rows = [["criterion", "measures", "value", "target", "met"]]
    for name, c in outcome.get("criteria", {}).items():
        rows.append(
            [
                name,
                CRITERIA.get(name, name),
                format_value(name, c["value"]),
                format_value(name, c["target"]),
                "yes" if c["met"] else "NO",
            ]
        )
    return rows


def verdict(outcome: dict) -> str:
    """SUCCESS or FAILED, with the criteria that were missed."""
    crit = outcome.get("criteria", {})
    if outcome.get("success"):
        return f"SUCCESS: all {len(crit)} criteria met" if crit else "SUCCESS (the mission sets no criteria)"
    missed = [k for k, c in crit.items() if not c["met"]]
    return f"FAILED: {len(missed)} of {len(crit)} criteria not met ({', '.join(missed)})"


def loss_rows(log: MissionLog) -> list[list[str]]:
    """Losses by cause (rows) and the phase the robot was in (columns), with totals."""
    by_phase = log.losses_by_phase()
    phases = [p for p in PHASES if p in by_phase] + sorted(set(by_phase) - set(PHASES))
    rows = [["cause", *phases, "total"]]
    for cause, total in log.losses_by_cause().items():
        rows.append([cause, *(str(by_phase[p].get(cause, 0)) for p in phases), str(total)])
    rows.append(["total", *(str(sum(by_phase[p].values())) for p in phases), str(len(log.losses))])
    return rows


def end_state_rows(log: MissionLog) -> list[list[str]]:
    """How every robot ended: recovered, expended, stopped at the time limit, or lost (by cause)."""
    rows = [["end state", "robots"]]
    rows += [[k, str(v)] for k, v in log.summary()["end_states"].items()]
    return rows


def mine_rows(log: MissionLog) -> list[list[str]]:
    """Mines in the field and what became of them; empty without mines or detections."""
    s = log.summary()
    if not s["mines"] and not s["false_alarms"]:
        return []
    marked = sum(log.mines_state.get("marked", []))
    exploded = sum(log.mines_state.get("exploded", []))
    return [
        ["mines", "count"],
        ["in the field", str(s["mines"])],
        ["detected", str(s["mines_detected"])],
        ["marked at the end", str(marked)],
        ["set off by robots", str(exploded)],
        ["cleared", str(s["mines_cleared"])],
        ["false alarms", str(s["false_alarms"])],
    ]


def header_rows(log: MissionLog, date: str) -> list[list[str]]:
    s = log.summary()
    return [
        ["mission", log.mission],
        ["map", log.map],
        ["seed", str(log.seed)],
        ["robots", str(s["robots"])],
        ["mission time", f"{s['duration_s']:.0f} s ({s['duration_s'] / 60.0:.1f} min)"],
        ["robots lost", str(s["lost"])],
        ["surf-swarm", getattr(swarm, "__version__", "unknown")],
        ["date", date],
    ]


#: (heading, figure function, what to say when it has nothing to show) in report order.
FIGURES: list[tuple[str, Callable[[MissionLog], bytes | None], str]] = [
    ("Executed paths over the plan", figs.trajectories_png, "No plan in the log: no map."),
    ("Where robots were lost", figs.losses_map_png, "No robot was lost."),
    ("Losses by cause and phase", figs.losses_bar_png, ""),
    ("Mines found and marked", figs.mines_png, ""),
    ("Relay connectivity", figs.relay_png, ""),
    ("Robots by phase over time", figs.phases_png, ""),
]


def _sections(log: MissionLog, date: str) -> list[tuple[str, list[list[str]], bool]]:
    """(heading, rows, has a header row) of every table, in report order."""
    out = [("Run", header_rows(log, date), False), ("Criteria", criteria_rows(log.outcome), True)]
    if log.losses:
        out.append(("Losses by cause and phase", loss_rows(log), True))
    out.append(("End states", end_state_rows(log), True))
    mines = mine_rows(log)
    if mines:
        out.append(("Mines", mines, True))
    return out


def write_sim_report(log: MissionLog, out_dir: str | Path, *, date: str | None = None) -> dict[str, Path]:
    """Write report.md and report.html into `out_dir` (created), atomically; returns their paths.
    `date` (default: today, UTC) is the only part that differs between two runs of the same seed."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    date = date or datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d")
    title = f"Mission simulation: {log.mission} on {log.map} (seed {log.seed})"
    verdict_text = verdict(log.outcome)
    tables = _sections(log, date)

    md = [f"# {title}", f"**{verdict_text}**"]
    for heading, rows, header in tables:
        md += [f"## {heading}", md_table(rows, header=header)]
    md.append(
        "Figures (executed paths, losses, mines, relay, phases): report.html. Data: trajectories.npz, "
        "events.jsonl, outcome.json, plan.json."
    )

    colour = "#009E73" if log.outcome.get("success") else "#D55E00"
    body = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p style='font-size:20px;font-weight:bold;color:{colour}'>{html.escape(verdict_text)}</p>",
    ]
    for heading, rows, header in tables:
        body.append(f"<h2>{html.escape(heading)}</h2>{html_table(rows, header=header)}")
    for heading, make, absent in FIGURES:
        png = make(log)
        if png is not None:
            body.append(html_figure(heading, png))
        elif absent:
            body.append(f"<h2>{html.escape(heading)}</h2><p>{html.escape(absent)}</p>")
    page = html_page(title, body)
    paths = {"report.md": out / "report.md", "report.html": out / "report.html"}
    write_text_atomic(paths["report.md"], "\n\n".join(md) + "\n")
    write_text_atomic(paths["report.html"], page)
    return paths
