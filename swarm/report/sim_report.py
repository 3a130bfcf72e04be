"""A simulated mission as a report (`Report`: report.json, report.md, report.html): the verdict (the
outcome against the success criteria), the run, criteria, loss, end-state, mine, relay and phase
tables, and the figures of `swarm.report.sim_figures` (executed paths over the plan, where and why
robots were lost, mines found and marked against the truth, relay connectivity, robots by phase).

```python
log = simulate(mission, seed=3)
write_log(log, out)            # trajectories.npz, events.jsonl, outcome.json
write_sim_report(log, out)     # report.html, report.md, report.json
```

The tables here (`criteria_rows`, `loss_rows`, `end_state_rows`, `mine_rows`) are also what
`swarm simulate` prints, so the terminal and the report always say the same thing. A log read back
from its files (`swarm.sim.run.read_log`) gives the same report as the log in memory.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from swarm.report import sim_figures as figs
from swarm.report.document import Figure, Report, Table, header, seconds
from swarm.report.document import verdict as make_verdict
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
    """criterion, what it measures, value, target, met (`outcome`: anything with "criteria")."""
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


def loss_table(by_cause: dict[str, int], by_phase: dict[str, dict[str, int]]) -> list[list[str]]:
    """Losses by cause (rows) and the phase the robot was in (columns), with totals."""
    phases = [p for p in PHASES if p in by_phase] + sorted(set(by_phase) - set(PHASES))
    rows = [["cause", *phases, "total"]]
    for cause, total in by_cause.items():
        rows.append([cause, *(str(by_phase[p].get(cause, 0)) for p in phases), str(total)])
    rows.append(["total", *(str(sum(by_phase[p].values())) for p in phases), str(sum(by_cause.values()))])
    return rows


def loss_rows(log: MissionLog) -> list[list[str]]:
    """Losses by cause and phase of a log, with totals."""
    return loss_table(log.losses_by_cause(), log.losses_by_phase())


def end_state_table(end_states: dict[str, int]) -> list[list[str]]:
    return [["end state", "robots"], *([k, str(v)] for k, v in end_states.items())]


def end_state_rows(log: MissionLog) -> list[list[str]]:
    """How every robot ended: recovered, expended, stopped at the time limit, or lost (by cause)."""
    return end_state_table(log.summary()["end_states"])


def mines(log: MissionLog) -> dict | None:
    """Mines in the field and what became of them; None without mines or detections."""
    s = log.summary()
    if not s["mines"] and not s["false_alarms"]:
        return None
    return {
        "in_field": s["mines"],
        "detected": s["mines_detected"],
        "marked": int(sum(log.mines_state.get("marked", []))),
        "set_off": int(sum(log.mines_state.get("exploded", []))),
        "cleared": s["mines_cleared"],
        "false_alarms": s["false_alarms"],
    }


MINE_LABELS = {
    "in_field": "in the field",
    "detected": "detected",
    "marked": "marked at the end",
    "set_off": "set off by robots",
    "cleared": "cleared",
    "false_alarms": "false alarms",
}


def mine_table(m: dict | None) -> list[list[str]]:
    if not m:
        return []
    return [["mines", "count"], *([MINE_LABELS[k], str(v)] for k, v in m.items())]


def mine_rows(log: MissionLog) -> list[list[str]]:
    """Mines in the field and what became of them; empty without mines or detections."""
    return mine_table(mines(log))


def _relay(log: MissionLog) -> dict | None:
    if not figs.has_relay(log):
        return None
    spans = figs.relay_intervals(log)
    up = sum(b - a for a, b, state in spans if state)
    total = sum(b - a for a, b, _ in spans)
    return {
        "connected_fraction_of_beach_operations": log.outcome.get("criteria", {})
        .get("relay", {})
        .get("value"),
        "connected_fraction_of_mission": round(up / total, 4) if total > 0 else None,
        "breaks": sum(1 for ev in log.events if ev["kind"] == "relay_break"),
        "spans": [{"from_s": round(a, 1), "to_s": round(b, 1), "up": state} for a, b, state in spans],
    }


def _phases(log: MissionLog) -> list[dict]:
    """The mission's phases by when the first robot entered each (the env's phase events)."""
    out = [{"phase": ev["phase"], "start_s": ev["t_s"]} for ev in log.events if ev["kind"] == "phase"]
    end = float(log.times_s[-1]) if len(log.times_s) else 0.0
    for i, p in enumerate(out):
        p["end_s"] = out[i + 1]["start_s"] if i + 1 < len(out) else end
    return out


def sim_data(log: MissionLog, date: str | None = None) -> dict:
    """The simulation report's numbers (report.json)."""
    s = log.summary()
    crit = log.outcome.get("criteria", {})
    order = [k for k in CRITERIA if k in crit] + sorted(set(crit) - set(CRITERIA))
    criteria = {
        name: {
            "measures": CRITERIA.get(name, name),
            "value": crit[name]["value"],
            "target": crit[name]["target"],
            "met": bool(crit[name]["met"]),
        }
        for name in order
    }
    by_phase = s["losses_by_phase"]
    phases = [p for p in PHASES if p in by_phase] + sorted(set(by_phase) - set(PHASES))
    return {
        "header": header("simulation", log.mission, log.map, log.seed, date),
        "verdict": make_verdict(
            verdict(log.outcome), "met" if log.outcome.get("success") else "not met", success=s["success"]
        ),
        "run": {
            "robots": s["robots"],
            "duration_s": s["duration_s"],
            "completed_s": s["completed_s"],
            "lost": s["lost"],
        },
        "success": bool(log.outcome.get("success")),
        "criteria": criteria,
        "losses": [dict(x) for x in log.losses],
        "losses_by_cause": s["losses_by_cause"],
        "losses_by_phase": {p: dict(sorted(by_phase[p].items())) for p in phases},
        "end_states": s["end_states"],
        "mines": mines(log),
        "relay": _relay(log),
        "phases": _phases(log),
    }


def run_table(data: dict) -> list[list[str]]:
    r = data["run"]
    done = r["completed_s"]
    return [
        ["robots", str(r["robots"])],
        ["mission time", f"{seconds(r['duration_s'])} s ({r['duration_s'] / 60.0:.1f} min)"],
        ["every criterion met at", "never" if done is None else f"{seconds(done)} s"],
        ["robots lost", str(r["lost"])],
    ]


def where_lost_table(data: dict) -> list[list[str]]:
    rows = [["robot", "cause", "phase", "time (s)", "x (m)", "y (m)"]]
    for x in sorted(data["losses"], key=lambda x: (x["t_s"], x["robot"])):
        rows.append(
            [x["robot"], x["cause"], x["phase"], seconds(x["t_s"]), f"{x['x_m']:.1f}", f"{x['y_m']:.1f}"]
        )
    return rows


def relay_table(data: dict) -> list[list[str]]:
    rows = [["from (s)", "to (s)", "source to sinks"]]
    rows += [
        [seconds(s["from_s"]), seconds(s["to_s"]), "up" if s["up"] else "down"]
        for s in data["relay"]["spans"]
    ]
    return rows


def phase_table(data: dict) -> list[list[str]]:
    rows = [["phase", "first robot in it at (s)", "until (s)"]]
    rows += [[p["phase"], seconds(p["start_s"]), seconds(p["end_s"])] for p in data["phases"]]
    return rows


#: (heading, figure function, what to say when it has nothing to show, alt text) in report order.
FIGURES: list[tuple[str, Callable[[MissionLog], bytes | None], str, str]] = [
    (
        "Executed paths over the plan",
        figs.trajectories_png,
        "No plan or map with the log: no map.",
        "Map with every robot's executed path coloured by role over its planned route, and loss markers",
    ),
    (
        "Where robots were lost",
        figs.losses_map_png,
        "No robot was lost.",
        "Map with a marker per lost robot, shaped and coloured by the cause of the loss",
    ),
    (
        "Losses by cause and phase",
        figs.losses_bar_png,
        "",
        "Bar chart of robots lost by cause, stacked by the phase they were in",
    ),
    (
        "Mines found and marked",
        figs.mines_png,
        "",
        "Close-up of the search area: true mines, detections, marks, mines set off and cleared, false alarms",
    ),
    (
        "Relay connectivity",
        figs.relay_png,
        "",
        "Relay connectivity over mission time: up or down, with the breaks marked",
    ),
    (
        "Robots by phase over time",
        figs.phases_png,
        "",
        "Stacked area chart of robots in each phase, and how the others ended, over mission time",
    ),
]


def sim_report(log: MissionLog, *, date: str | None = None) -> Report:
    """The report of a finished run (a log in memory or read back with `read_log`)."""
    data = sim_data(log, date)
    blocks: list = [Table("Run", run_table(data), header=False), Table("Criteria", criteria_rows(data))]
    if data["losses"]:
        blocks.append(
            Table("Losses by cause and phase", loss_table(data["losses_by_cause"], data["losses_by_phase"]))
        )
        blocks.append(Table("Where robots were lost", where_lost_table(data)))
    blocks.append(Table("End states", end_state_table(data["end_states"])))
    if data["mines"]:
        blocks.append(Table("Mines", mine_table(data["mines"])))
    if data["relay"] is not None:
        blocks.append(Table("Relay connectivity spans", relay_table(data)))
    if data["phases"]:
        blocks.append(Table("Mission phases", phase_table(data)))
    for heading, make, absent, alt in FIGURES:
        blocks.append(Figure(heading, (lambda make=make: make(log)), alt=alt, absent=absent))
    h = data["header"]
    return Report(
        "simulation",
        f"Mission simulation: {h['mission']} on {h['map']} (seed {h['seed']})",
        data,
        blocks,
        files_note="Data: trajectories.npz, events.jsonl, outcome.json, plan.json.",
    )


def write_sim_report(log: MissionLog, out_dir: str | Path, *, date: str | None = None) -> dict[str, Path]:
    """Write report.html, report.md and report.json into `out_dir` (created), atomically; returns their
    paths. `date` (default: today, UTC) is the only part that differs between two runs of the same seed."""
    return sim_report(log, date=date).write_all(out_dir)


__all__ = [
    "CRITERIA",
    "criteria_rows",
    "end_state_rows",
    "format_value",
    "loss_rows",
    "mine_rows",
    "sim_data",
    "sim_report",
    "verdict",
    "write_sim_report",
]
