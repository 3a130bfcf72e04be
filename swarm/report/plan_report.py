"""A mission plan as a report (`Report`: report.json, report.md, report.html): the verdict a plan can
give against the success criteria (expected detection per search area, relay links that close),
the summary, search, relay-link and robot tables, and the figures of `swarm.report.plan_figures`
(the map with routes by role, search swaths and relay margins; the relay graph; arrival timeline).

The numbers come from the plan's own JSON (`MissionPlan.as_dict`, i.e. plan.json), so a report
built from a plan in memory and one rebuilt from plan.json on disk say the same thing.

```python
write_plan(plan, out)          # plan.json, plan.geojson
write_plan_report(plan, out)   # report.html, report.md, report.json
```
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from swarm.mission import budget
from swarm.mission.exposure import polyline_m
from swarm.mission.plan import MissionPlan, detection_to_expect
from swarm.planning.relay import relayed_links
from swarm.report import plan_figures as figs
from swarm.report.document import MISSING, Figure, Report, Table, header, verdict
from swarm.studies import stats

#: The verdict when nothing a plan can check applies.
NO_VERDICT = "plan only: no verdict (only a simulation can tell whether the mission succeeds)"


def _robots(d: dict) -> list[dict]:
    out = []
    for b in d.get("robots", []):
        ground = b.get("ground_m") or []
        goal = ground[-1] if ground else b["sea_leg_m"][-1]
        out.append(
            {
                "id": b["id"],
                "role": b["role"],
                "task": b.get("task"),
                "launch_m": list(b["launch_m"]),
                "goal_m": list(goal),
                "release_s": b["release_s"],
                "sea_time_s": b["sea_time_s"],
                "ground_time_s": b["ground_time_s"],
                "eta_s": b["eta_s"],
                "length_m": b["length_m"],
            }
        )
    return out


def _search(d: dict) -> list[dict]:
    after = (d.get("budget") or {}).get("search", {})
    out = []
    for s in d.get("search", []):
        design, b = s.get("design") or {}, after.get(s["task"], {})
        tracks = [t for run in s.get("tracks_m", []) for t in run]
        out.append(
            {
                "task": s["task"],
                "area": s.get("area"),
                "searchers": len(s.get("tracks_m", [])),
                "reserves": design.get("reserves", 0),
                "spacing_m": s["spacing_m"],
                "spacing_from": design.get("spacing_from", "mission"),
                "sweep_width_m": s["sweep_width_m"],
                "model": s["model"],
                "expected_detection": s["expected_detection"],
                "expected_detection_after_losses": b.get("expected_detection_after_losses"),
                "p_criterion_met": b.get("p_criterion_met"),
                "p_criterion_met_after_losses": b.get("p_criterion_met_after_losses"),
                "confidence": b.get("confidence"),
                "search_time_s": design.get("search_time_s"),
                "window_s": design.get("window_s"),
                "note": design.get("note", ""),
                "swath_coverage": s["swath_coverage"],
                "track_length_m": round(sum(polyline_m(np.reshape(t, (-1, 2))) for t in tracks), 1),
            }
        )
    return out


def _losses(d: dict) -> dict | None:
    """Expected losses by phase and cause (plan.json's budget), or None for an older plan."""
    b = d.get("budget")
    if not b:
        return None
    # in mission order (plan.json sorts its keys)
    order = {p: i for i, p in enumerate((*budget.PHASE_NAMES, budget.RETURN_PHASE))}
    phases = dict(sorted(b["expected_losses"].items(), key=lambda kv: order.get(kv[0], len(order))))
    return {
        "hazards": b.get("hazards", True),
        "by_phase": phases,
        "total": b["expected_lost"],
        "expended": b.get("expected_expended"),
        "recovered": b.get("expected_recovered"),
        "stranded": b.get("stranded_in_surf") or [],
        "takeovers": b.get("station_takeovers"),
    }


def _relay(d: dict) -> dict | None:
    r = d.get("relay")
    if not r:
        return None
    sinks, positions = r.get("sinks_m", []), r.get("positions_m", [])
    names = figs.node_names(len(sinks), len(positions))
    nodes = np.array([r["source_m"], *sinks, *positions], dtype=float).reshape(-1, 2)
    margins = r.get("link_margins_db")
    links = []
    for k, (a, b) in enumerate(r.get("edges", [])):
        links.append(
            {
                "from": names[a],
                "to": names[b],
                "length_m": round(float(np.hypot(*(nodes[a] - nodes[b]))), 1),
                "margin_db": None if margins is None else round(float(margins[k]), 1),
            }
        )
    return {
        "task": r["task"],
        "comm_range_m": r["comm_range_m"],
        "redundancy": r["redundancy"],
        "relays": len(positions),
        # robots the plan puts on a relay position: fewer than positions when the swarm is too small
        "staffed": sum(1 for robot in d.get("robots", []) if robot.get("role") == "relay"),
        # the share of the window enough positions are expected held for the link, after the
        # losses (plan.json's budget; None for a plan without one)
        "held_after_losses": ((d.get("budget") or {}).get("relay") or {}).get("p_held"),
        "max_hop_m": r.get("max_hop_m"),
        "min_margin_db": None if r.get("min_margin_db") is None else round(float(r["min_margin_db"]), 1),
        "fixed_height_m": r.get("fixed_height_m"),
        # source and sinks in reach of each other on their own masts: linked with no relay
        "direct_links": int(np.sum(~relayed_links(np.array(r.get("edges", [])), 1 + len(sinks)))),
        "links": links,
    }


def _checks(
    search: list[dict],
    relay: dict | None,
    losses: dict | None,
    criteria: dict,
    stations: dict | None = None,
) -> list[dict]:
    """What a plan can hold against the success criteria: each search area's expected detection
    against min_detection_fraction and its chance of meeting it after the losses against the task's
    detection_confidence, every relay position staffed and the share of the window
    enough of them are held for the link after the losses (`budget.p_at_least`) against
    min_relay_connected_fraction, every relay link closing (margin >= 0 dB), the share of each
    surveillance's or beacon's points reached in time for their dwell or hold against its criterion,
    and the robots expected back at sea against min_robots_recovered."""
    out = []
    target = criteria.get("min_detection_fraction")
    if target is not None:
        for s in search:
            value = detection_to_expect(s)
            after = "" if s["expected_detection_after_losses"] is None else " after losses"
            out.append(
                {
                    "criterion": f"expected detection{after} ({s['task']})",
                    "value": value,
                    "target": target,
                    "unit": "fraction",
                    "met": value >= target - 1e-12,
                }
            )
            # the mean can clear the criterion in a plan that misses it in one run of three: the
            # tracks were designed to meet it with the task's detection_confidence
            chance, wanted = s["p_criterion_met_after_losses"], s["confidence"]
            if chance is not None and wanted is not None:
                out.append(
                    {
                        "criterion": f"P(detection criterion met) after losses ({s['task']})",
                        "value": chance,
                        "target": wanted,
                        "unit": "probability",
                        "met": chance >= wanted - 1e-12,
                    }
                )
    if relay is not None and relay["relays"]:
        out.append(
            {
                "criterion": f"robots on the relay's positions ({relay['task']})",
                "value": float(relay["staffed"]),
                "target": float(relay["relays"]),
                "unit": "robots",
                "met": relay["staffed"] >= relay["relays"],
            }
        )
    connected = criteria.get("min_relay_connected_fraction")
    if relay is not None and relay["relays"] and relay.get("held_after_losses") is not None and connected:
        # robots lost before they reach their positions hold none
        share = relay["held_after_losses"]
        out.append(
            {
                "criterion": "share of the time the relay's positions are held after losses"
                f" ({relay['task']})",
                "value": share,
                "target": connected,
                "unit": "fraction",
                "met": share >= connected - 1e-12,
            }
        )
    if relay is not None and relay["min_margin_db"] is not None:
        out.append(
            {
                "criterion": f"least relay link margin ({relay['task']})",
                "value": relay["min_margin_db"],
                "target": 0.0,
                "unit": "dB",
                "met": relay["min_margin_db"] >= 0.0,
            }
        )
    for task, st in (stations or {}).items():
        target = criteria.get("min_surveillance_fraction" if st["kind"] == "dwell" else "min_beacon_fraction")
        if target is None or not st["arrivals_s"]:
            continue
        # a point reached too late for its dwell or hold cannot be counted in any run
        left = [None if a is None else st["end_s"] - a for a in st["arrivals_s"]]
        in_time = [x is not None and x >= st["required_s"] - 1e-9 for x in left]
        least = min((x for x in left if x is not None), default=0.0)
        out.append(
            {
                "criterion": f"points reached in time for their {st['required_s']:g} s {st['kind']} before "
                f"beach operations end ({task}; {max(least, 0.0):.0f} s left at the last point reached)",
                "value": sum(in_time) / len(in_time),
                "target": target,
                "unit": "fraction",
                "met": sum(in_time) / len(in_time) >= target - 1e-12,
            }
        )
    wanted = criteria.get("min_robots_recovered") or 0
    if wanted > 0 and losses is not None and losses.get("recovered") is not None:
        fewest = losses["recovered"][0]  # every mine found marked: the fewest back
        out.append(
            {
                "criterion": "robots expected back at sea, at least",
                "value": fewest,
                "target": float(wanted),
                "unit": "robots",
                "met": fewest >= wanted,
            }
        )
    return out


def _check_value(c: dict, key: str) -> str:
    x = c[key]
    if c["unit"] == "fraction":
        return f"{x:.1%}"
    if c["unit"] == "probability":
        return f"{x:.2f}"
    return f"{x:.1f} robots" if c["unit"] == "robots" else f"{x:.1f} dB"


#: The verdict's lead when the plan meets what it can check and its runs are too few to show the
#: success target (8 of 8 succeeding put the Wilson lower bound at 0.68): not shown, not short.
NOT_SHOWN = "PLAN MEETS the criteria a plan can check; its runs do not show the target yet"


def _verdict(checks: list[dict]) -> dict:
    if not checks:
        return verdict(NO_VERDICT, "none")
    parts = [
        f"{c['criterion']} {_check_value(c, 'value')} {'>=' if c['met'] else '<'} {_check_value(c, 'target')}"
        + (f" (about {c['runs_needed']} runs would show it)" if not c["met"] and c.get("runs_needed") else "")
        for c in checks
    ]
    if all(c["met"] for c in checks):
        lead, status = "PLAN MEETS the criteria a plan can check", "met"
    elif all(c["met"] or c.get("runs_needed") for c in checks):
        lead, status = NOT_SHOWN, "not shown"
    else:
        lead, status = "PLAN FALLS SHORT", "not met"
    return verdict(f"{lead}: {'; '.join(parts)}", status, checks=checks)


def verdict_brief(v: dict) -> str:
    """The verdict in a line for the terminal: what falls short or is not shown yet (the checks
    not met, under their own lead), or that the plan meets what it can check (the report lists
    every check)."""
    if v["status"] == "met":
        return v["text"].split(":")[0]
    if v["status"] == "none":
        return v["text"]
    return _verdict([c for c in v["checks"] if not c["met"]])["text"]


def plan_data(d: dict, date: str | None = None) -> dict:
    """The plan report's numbers (report.json) from a plan's JSON dict (plan.json)."""
    search, relay, losses = _search(d), _relay(d), _losses(d)
    stations = (d.get("budget") or {}).get("stations")
    checks = _checks(search, relay, losses, d.get("criteria") or {}, stations)
    s = d.get("summary", {})
    return {
        "header": header("plan", d.get("mission"), d.get("map"), d.get("seed"), date),
        "verdict": _verdict(checks),
        "summary": {
            "robots": s.get("robots", len(d.get("robots", []))),
            "roles": s.get("roles", {}),
            "first_arrival_s": s.get("first_arrival_s"),
            "last_arrival_s": s.get("last_arrival_s"),
            "total_length_m": s.get("total_length_m"),
            "relays": s.get("relays", 0),
            "search_tracks_m": s.get("search_tracks_m", 0.0),
            "expected_coverage": d.get("expected_coverage"),
        },
        "search": search,
        "losses": losses,
        "relay": relay,
        "robots": _robots(d),
        "source": d.get("source", {}),
    }


def robots_range(pair: list[float]) -> str:
    """A plan's at-least and at-most robots ('0.0 to 12.2', or one figure when they agree)."""
    low, high = pair
    return f"{low:.1f}" if f"{low:.1f}" == f"{high:.1f}" else f"{low:.1f} to {high:.1f}"


def _num(x: object, spec: str, unit: str = "") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return MISSING
    return f"{format(x, spec)}{unit}"


def summary_table(data: dict) -> list[list[str]]:
    """What the plan adds up to: robots by role, arrivals, route length, relays, search."""
    s = data["summary"]
    rows = [
        ["robots", str(s["robots"])],
        ["roles", ", ".join(f"{k} {v}" for k, v in s["roles"].items()) or MISSING],
        ["first arrival", _num(s["first_arrival_s"], ".0f", " s")],
        ["last arrival", _num(s["last_arrival_s"], ".0f", " s")],
        ["total route length", _num(s["total_length_m"], ".0f", " m")],
    ]
    r = data["relay"]
    if r is not None:
        rows.append(
            [
                "relays",
                f"{r['relays']} (range {r['comm_range_m']:.0f} m, "
                f"longest hop {_num(r['max_hop_m'], '.0f', ' m')}, "
                f"least link margin {_num(r['min_margin_db'], '.1f', ' dB')})"
                + (
                    f"; {r['direct_links']} direct link(s) between the source's and sinks' masts"
                    if r["direct_links"]
                    else ""
                ),
            ]
        )
    for sp in data["search"]:
        rows.append(
            [
                f"search {sp['task']}",
                f"{sp['searchers']} searchers and {sp['reserves']} reserves, spacing {sp['spacing_m']:g} m "
                f"({'planned' if sp['spacing_from'] == 'planned' else 'from the mission'}), W "
                f"{sp['sweep_width_m']:g} m, expected detection {sp['expected_detection']:.1%} "
                f"({sp['model']}), swath coverage {sp['swath_coverage']:.1%}",
            ]
        )
        if sp["expected_detection_after_losses"] is not None:
            rows.append(
                [
                    f"after losses {sp['task']}",
                    f"expected detection {sp['expected_detection_after_losses']:.1%} (trips off the "
                    f"tracks included); P(criterion met) "
                    f"{_num(sp['p_criterion_met'], '.2f')} as planned, "
                    f"{_num(sp['p_criterion_met_after_losses'], '.2f')} after losses",
                ]
            )
        if sp["note"]:
            rows.append([f"note {sp['task']}", sp["note"]])
    losses = data.get("losses")
    if losses is not None:
        phases = ", ".join(f"{p} {sum(c.values()):.1f}" for p, c in losses["by_phase"].items())
        text = f"{losses['total']:.1f} robots ({phases})" if losses["hazards"] else "none: hazards off"
        rows.append(["expected losses", text])
        if losses.get("stranded"):
            rows.append(
                [
                    "note surf",
                    f"{len(losses['stranded'])} of {s['robots']} robots cannot finish the surf crossing "
                    "within its time limit at these breakers, at any phase of the wave: the longshore "
                    "current sets them along the beach while they swim",
                ]
            )
        if losses.get("takeovers"):
            taken, spares = losses["takeovers"], s["roles"].get("spare", 0)
            text = f"{taken:.1f} lost robots' stations taken over a run by the {spares} spares"
            rows.append(["spares at work", text])
        ends = []
        if losses.get("expended") and losses["expended"][1] > 0:
            ends.append(f"{robots_range(losses['expended'])} expended marking mines for the clearance")
        if losses.get("recovered") is not None:
            ends.append(f"{robots_range(losses['recovered'])} back at sea")
        if ends:
            rows.append(["expected at the end", ", ".join(ends)])
    if s["expected_coverage"] is not None:
        rows.append(["expected coverage", f"{s['expected_coverage']:.1%}"])
    return rows


def losses_table(data: dict) -> list[list[str]]:
    """Expected robots lost, by cause (rows) and phase (columns)."""
    by_phase = data["losses"]["by_phase"]
    phases = list(by_phase)
    causes = sorted({c for p in phases for c in by_phase[p]})
    rows = [["cause", *phases, "total"]]
    for c in causes:
        vals = [by_phase[p].get(c, 0.0) for p in phases]
        rows.append([c, *(f"{v:.2f}" for v in vals), f"{sum(vals):.2f}"])
    totals = [sum(by_phase[p].values()) for p in phases]
    rows.append(["total", *(f"{v:.2f}" for v in totals), f"{sum(totals):.2f}"])
    return rows


def _met_word(c: dict) -> str:
    """A check's cell in the criteria table: a check that more runs would show is not yet met,
    not failed (the verdict's `not shown`)."""
    if c["met"]:
        return "yes"
    return "not yet" if c.get("runs_needed") else "NO"


def check_table(data: dict) -> list[list[str]]:
    rows = [["criterion", "plan", "target", "met"]]
    for c in data["verdict"].get("checks", []):
        rows.append([c["criterion"], _check_value(c, "value"), _check_value(c, "target"), _met_word(c)])
    return rows


def search_table(data: dict) -> list[list[str]]:
    rows = [
        [
            "task",
            "searchers",
            "spacing (m)",
            "sweep width (m)",
            "sensor",
            "expected detection",
            "swath coverage",
            "track length (m)",
        ]
    ]
    for s in data["search"]:
        rows.append(
            [
                s["task"],
                str(s["searchers"]),
                f"{s['spacing_m']:g}",
                f"{s['sweep_width_m']:g}",
                s["model"],
                f"{s['expected_detection']:.1%}",
                f"{s['swath_coverage']:.1%}",
                f"{s['track_length_m']:.0f}",
            ]
        )
    return rows


def link_table(data: dict) -> list[list[str]]:
    rows = [["link", "from", "to", "length (m)", "margin (dB)"]]
    for k, link in enumerate(data["relay"]["links"]):
        rows.append(
            [str(k + 1), link["from"], link["to"], f"{link['length_m']:.1f}", _num(link["margin_db"], ".1f")]
        )
    return rows


def robot_table(data: dict) -> list[list[str]]:
    rows = [
        [
            "robot",
            "role",
            "task",
            "launch (m)",
            "goal (m)",
            "release (s)",
            "swim (s)",
            "drive (s)",
            "ETA (s)",
            "route (m)",
        ]
    ]
    for b in data["robots"]:
        rows.append(
            [
                b["id"],
                b["role"],
                b["task"] or MISSING,
                f"({b['launch_m'][0]:.1f}, {b['launch_m'][1]:.1f})",
                f"({b['goal_m'][0]:.1f}, {b['goal_m'][1]:.1f})",
                f"{b['release_s']:.0f}",
                f"{b['sea_time_s']:.0f}",
                f"{b['ground_time_s']:.0f}",
                f"{b['eta_s']:.0f}",
                f"{b['length_m']:.0f}",
            ]
        )
    return rows


def summary_rows(plan: MissionPlan) -> list[list[str]]:
    """The summary table of a plan in memory (what `swarm plan` prints)."""
    return summary_table(plan_data(plan.as_dict()))


#: The simulator's phase of a loss (`swarm.sim.layout.PHASES`) -> the plan budget's phase.
BUDGET_PHASE = {
    "waiting": "sea",
    "sea_transit": "sea",
    "surf_crossing": "surf",
    "beach": "beach",
    "returning": "return",
}


def lost_by_phase(ev: dict) -> dict[str, float]:
    """Robots lost a run in each of the plan budget's phases, in a plan's simulations."""
    out: dict[str, float] = {}
    for phase, causes in ev.get("losses_by_phase", {}).items():
        key = BUDGET_PHASE.get(phase, phase)
        out[key] = out.get(key, 0.0) + sum(causes.values()) / ev["runs"]
    return out


def against_plan(
    planned: float, interval: list[float] | None, spec: str, confidence: float, *, more_is_better: bool
) -> str:
    """' (95% interval 96.8% to 99.2%; plan 94.8%: conservative)': the runs' t interval of a mean
    and whether the plan's expectation agrees with it (`stats.agreement`); ' (plan 94.8%)' without
    an interval (one run, runs that all gave the same value, or an evaluation from before it was
    kept)."""
    if not interval:
        return f" (plan {planned:{spec}})"
    low, high = interval
    said = stats.agreement(planned, (low, high), more_is_better=more_is_better)
    return f" ({confidence:.0%} interval {low:{spec}} to {high:{spec}}; plan {planned:{spec}}: {said})"


def evaluation_table(
    ev: dict, expected: dict | None = None, planned_detection: float | None = None
) -> list[list[str]]:
    """What the plan's simulations delivered (`swarm plan --evaluate`), beside the plan's expected
    losses (`plan_data(...)["losses"]`) and detection after losses (`MissionPlan.expected_detection`)
    when given, each with the runs' interval of its mean and the plan's agreement with it."""
    pct = f"{ev['confidence']:.0%}"
    rows = [
        ["runs", str(ev["runs"])],
        [
            "P(success)",
            f"{ev['success_rate']:.3f} ({ev['successes']} of {ev['runs']}), {pct} Wilson interval "
            f"{ev['wilson_low']:.3f} to {ev['wilson_high']:.3f}; target {ev['target']:g}",
        ],
    ]
    chance = ev.get("planned_success")
    if chance is not None:  # against the Wilson interval, as a mean against its t interval
        wilson = (ev["wilson_low"], ev["wilson_high"])
        text = f"{ev['success_rate']:.3f}" + against_plan(
            chance, wilson, ".3f", ev["confidence"], more_is_better=True
        )
        rows.append(["P(success): simulated against planned", text])
    det = ev.get("detection")
    if det:
        rows.append(
            [
                "detection per run",
                f"mean {det['mean']:.1%}, median {det['median']:.1%}, {det['min']:.1%} to {det['max']:.1%}",
            ]
        )
        if planned_detection is not None:
            rows.append(
                [
                    "detection per run: simulated against planned",
                    f"{det['mean']:.1%}"
                    + against_plan(
                        planned_detection,
                        ev.get("detection_interval"),
                        ".1%",
                        ev["confidence"],
                        more_is_better=True,
                    ),
                ]
            )
    lost = ev["lost"]
    causes = ", ".join(f"{c} {n}" for c, n in ev["losses_by_cause"].items()) or "none"
    rows.append(
        ["robots lost per run", f"mean {lost['mean']:.1f}, {lost['min']:g} to {lost['max']:g} ({causes})"]
    )
    if expected is not None and expected["hazards"]:
        simulated = lost_by_phase(ev)
        phases = [*expected["by_phase"], *(p for p in simulated if p not in expected["by_phase"])]
        pairs = ", ".join(
            f"{p} {simulated.get(p, 0.0):.1f} / {sum(expected['by_phase'].get(p, {}).values()):.1f}"
            for p in phases
        )
        rows.append(
            ["lost per run: simulated / planned", f"{lost['mean']:.1f} / {expected['total']:.1f} ({pairs})"]
        )
        rows.append(
            [
                "lost per run: simulated against planned",
                f"{lost['mean']:.1f}"
                + against_plan(
                    expected["total"], ev.get("lost_interval"), ".1f", ev["confidence"], more_is_better=False
                ),
            ]
        )
    by_cause = ev.get("lost_by_cause") or []
    if by_cause:
        pairs = ", ".join(
            f"{c['cause']} {c['mean']:.2f} / {c['planned']:.2f} "
            f"({stats.agreement(c['planned'], c['interval'], more_is_better=False) or 'no interval'})"
            for c in by_cause
        )
        rows.append(["lost per run by cause: simulated / planned", pairs])
    taken = ev.get("takeovers_mean")
    planned_taken = None if expected is None else expected.get("takeovers")
    if (taken or 0) > 0 or (planned_taken or 0) > 0:
        text = _num(taken, ".2f")
        if planned_taken is not None:
            interval = ev.get("takeovers_interval")
            text += against_plan(planned_taken, interval, ".2f", ev["confidence"], more_is_better=False)
        rows.append(["stations taken over per run: simulated against planned", text])
    for key, label in (
        ("expended", "robots expended in the clearance per run"),
        ("recovered", "robots back at sea per run"),
    ):
        got = ev.get(key)
        planned = None if expected is None else expected.get(key)
        if got and ((planned is not None and planned[1] > 0) or got["max"] > 0):
            text = f"mean {got['mean']:.1f}, {got['min']:g} to {got['max']:g}"
            rows.append([label, text if planned is None else f"{text}; planned {robots_range(planned)}"])
    for size in ev.get("sizes", []):
        rows.append(
            [
                f"quick sweep, {size['count']} robots",
                f"P(success) {size['success_rate']:.3f} over {size['runs']} "
                f"runs ({size['wilson_low']:.3f} to {size['wilson_high']:.3f})",
            ]
        )
    if ev.get("runs_needed"):
        rows.append(["runs to show the target", f"about {ev['runs_needed']} at this rate"])
    if ev.get("sizes"):
        suggested = ev.get("suggested_count")
        rows.append(["suggested size", str(suggested) if suggested else "none of the quick sweep's sizes"])
    return rows


def plan_report(
    plan: MissionPlan,
    *,
    date: str | None = None,
    plan_dict: dict | None = None,
    evaluation: dict | None = None,
) -> Report:
    """The report of `plan`; `plan_dict` is its JSON (default: `plan.as_dict()`); `evaluation`, the
    plan simulated N times (`swarm.studies.evaluate`). The plan's `beach_map` may be None (a map
    that cannot be found): the tables stay, the map figures go."""
    d = plan_dict if plan_dict is not None else plan.as_dict()
    data = plan_data(d, date)
    if evaluation is not None:
        data["evaluation"] = {k: v for k, v in evaluation.items() if not k.endswith("_values")}
        checks = [
            *data["verdict"].get("checks", []),
            {
                # judged by the interval's lower end, as a study judges a size (`stats.required_value`):
                # 2 runs of 2 succeeding do not show 0.9
                "criterion": (
                    f"P(success) in simulation, the lower end of its {evaluation['confidence']:.0%} Wilson"
                    f" interval ({evaluation['successes']} of {evaluation['runs']} runs succeeded: "
                    f"{evaluation['wilson_low']:.2f} to {evaluation['wilson_high']:.2f})"
                ),
                "value": evaluation["wilson_low"],
                "target": evaluation["target"],
                "unit": "fraction",
                "met": evaluation["wilson_low"] >= evaluation["target"],
                # the rate seen is above the target: more runs would show it (`runs_for_lower_bound`),
                # so the plan is not short of it, only not shown to reach it
                "runs_needed": evaluation.get("runs_needed"),
            },
        ]
        data["verdict"] = _verdict(checks)
    relay = data["relay"]
    margins = (
        None
        if relay is None or any(x["margin_db"] is None for x in relay["links"])
        else [x["margin_db"] for x in relay["links"]]
    )
    no_map = "The map could not be found (plan.json names its file under source.map_file): no map figures."
    blocks: list = [Table("Plan summary", summary_table(data), header=False)]
    if data["verdict"].get("checks"):
        blocks.append(Table("Criteria a plan can check", check_table(data)))
    if data.get("losses") is not None and data["losses"]["hazards"]:
        title = "Expected losses (robots) by cause and phase, from the mission's hazards"
        blocks.append(Table(title, losses_table(data)))
    if evaluation is not None:
        criterion = (d.get("criteria") or {}).get("min_detection_fraction")
        blocks.append(
            Table(
                "The plan in simulation (swarm plan --evaluate)",
                evaluation_table(evaluation, data.get("losses"), plan.expected_detection),
                header=False,
            )
        )
        searched = bool(evaluation.get("detection_values"))
        # what a run with the plan's losses should show: the simulation loses robots too
        after_losses = [detection_to_expect(s) for s in data["search"]]
        losses = data.get("losses")
        expected_lost = losses["total"] if losses is not None and losses["hazards"] else None
        blocks.append(
            Figure(
                "Detection and losses per simulated run" if searched else "Losses per simulated run",
                lambda: figs.evaluation_png(evaluation, criterion, after_losses, expected_lost),
                alt="Histograms over the simulated runs of the fraction of mines detected, with the "
                "criterion and the plan's expected detection after losses, and of the robots lost "
                "per run, with the plan's expected losses"
                if searched
                else "Histogram of the robots lost per simulated run, with the plan's expected losses",
                caption="Left: mines detected per run, the success criterion (dashed) and the plan's "
                "expected detection after its losses (solid). Right: robots lost per run and the "
                "plan's expected losses (solid)."
                if searched
                else "Robots lost per simulated run and the plan's expected losses (solid).",
            )
        )
    shows = [
        (
            "routes by role",
            "every robot's route coloured by role",
            "routes by role (dotted: the swim from the launch point to the entry)",
        )
    ]
    if data["search"]:
        shows.append(
            (
                "search swaths",
                "the search tracks with their sensor swaths",
                "search tracks with the swept band of the sensor",
            )
        )
    if relay is not None:
        shows.append(
            (
                "relay links",
                "the relay links coloured by link margin",
                "relay links coloured by link margin (dB)",
            )
        )
    blocks.append(
        Figure(
            "Map: " + ", ".join(x[0] for x in shows),
            lambda: figs.plan_map_png(plan, margins),
            alt=f"Map of {data['header']['map']}: terrain colours, elevation contours and regions, with "
            + " and ".join(x[1] for x in shows),
            caption="Terrain by class, elevation contours (m), regions by kind; "
            + "; ".join(x[2] for x in shows)
            + ".",
            absent=no_map,
        )
    )
    if data["search"]:
        blocks.append(Table("Search", search_table(data)))
    if relay is not None:
        note = (
            f"{relay['relays']} relay robots, communication range {relay['comm_range_m']:.0f} m, redundancy "
            f"{relay['redundancy']}. Link margin: received power beyond sensitivity and fade margin, with "
            "the robots' antenna heights (the source's and sinks' own at those ends); >= 0 dB closes."
        )
        blocks.append(Table("Relay links", link_table(data), note=note))
        blocks.append(
            Figure(
                "Relay graph and link margins",
                lambda: figs.relay_png(plan, margins),
                alt="Close-up of the relay graph: source, sinks and relay robots on the map, each link "
                "labelled with its margin in dB",
                caption="Nodes: the offshore source, the sinks inland and the relay robots (R1, R2, ...); "
                "each link labelled with its margin in dB.",
                absent=no_map,
            )
        )
    blocks.append(
        Figure(
            "Arrival timeline",
            lambda: figs.arrival_png(data["robots"]),
            alt="Arrival timeline: one bar per robot from its release, swimming then driving, to its ETA, "
            "coloured by role",
            caption="Each robot from its release: the swim to its entry (hatched), then the drive to its "
            "goal (solid), ending at its ETA.",
        )
    )
    blocks.append(Table("Robots", robot_table(data)))
    h = data["header"]
    return Report(
        "plan",
        f"Mission plan: {h['mission']} on {h['map']} (seed {h['seed']})",
        data,
        blocks,
        files_note="Data: plan.json (every waypoint), plan.geojson (routes, regions, tracks, relay links).",
    )


def write_plan_report(
    plan: MissionPlan, out_dir: str | Path, *, date: str | None = None, evaluation: dict | None = None
) -> dict[str, Path]:
    """Write report.html, report.md and report.json into `out_dir`; returns their paths."""
    return plan_report(plan, date=date, evaluation=evaluation).write_all(out_dir)
