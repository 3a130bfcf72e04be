"""A Monte Carlo study as a report (`Report`: report.json, report.md, report.html): the answer (the
required value for the target, the verdict), the study, point and loss tables, and the figures of
`swarm.report.study_figures` (success against the swept key with interval bars, losses by cause and
phase, where robots were lost, time-to-success histograms).

```python
write_study_report(study_dir, table, summary, beach_map)   # report.html, report.md, report.json
```

`summary` is the study's summary.json as a dict, `table` its results table (`swarm.studies.table`).
The tables here (`settings_rows`, `study_rows`, `loss_rows`) and the sentence `answer` are also what
`swarm study` prints, so the terminal and the report always say the same thing.
"""

from __future__ import annotations

import math
from pathlib import Path

import pyarrow as pa

from swarm.report import study_figures as figs
from swarm.report.document import Figure, Report, Table, Text, header, jsonable, seconds, verdict
from swarm.report.study_figures import KEY_NOUNS, format_value, point_label, swept_keys
from swarm.sim.hazards import CAUSE_DESCRIPTIONS, CAUSES
from swarm.studies import stats
from swarm.world.beachmap import BeachMap

#: The interval half-width whose run count the point table shows (summary key "0.05").
WIDTH = 0.05
MISSING = "-"


def percent(fraction: float) -> str:
    """0.95 as '95%', 0.975 as '97.5%'."""
    return f"{fraction * 100:g}%"


def _number(value: object) -> float | None:
    """A finite float, or None for absent, null or NaN (JSON has no NaN; summaries may use null)."""
    if value is None or isinstance(value, bool):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _fmt(value: object, spec: str) -> str:
    x = _number(value)
    return MISSING if x is None else format(x, spec)


def _seconds(value: object) -> str:
    """`document.seconds`, MISSING without a number."""
    x = _number(value)
    return MISSING if x is None else seconds(x)


def required_value_text(key: str, value: object) -> str:
    """'30 robots' for a count the project names, else 'key = value'."""
    if key in KEY_NOUNS:
        return f"{format_value(value)} {KEY_NOUNS[key]}"
    return f"{key} = {format_value(value)}"


def answer(summary: dict) -> str:
    """The study's answer in one sentence: the required value for the target at the confidence,
    else the summary's note on why there is none; without a sweep, the overall success rate."""
    mission = summary.get("mission", "the mission")
    required = summary.get("required") or {}
    target = required.get("target", summary.get("target"))
    confidence = required.get("confidence", summary.get("confidence", 0.95))
    # the other swept (and set) keys at the values the answer holds them at
    held = ", ".join(required_value_text(k, v) for k, v in (required.get("held") or {}).items())
    where = f", with {held}" if held else ""
    if required.get("value") is not None and target is not None:
        what = required_value_text(required.get("key", "?"), required["value"])
        goal = f"P(success) >= {target:g} at {percent(confidence)} confidence"
        return f"{mission} needs {what} for {goal}{where}{_plan_says(required, target)}"
    if required.get("note"):
        return f"{required['note']}{where}{_plan_says(required, target)}"
    points = summary.get("points") or []
    if len(points) == 1:
        p = points[0]
        held = ", ".join(required_value_text(k, v) for k, v in (p.get("params") or {}).items())
        where = f" with {held}" if held else ""
        return (
            f"{mission}{where}: P(success) = {p['success_rate']:.3f} over {p['runs']} runs "
            f"({percent(confidence)} Wilson interval {p['wilson_low']:.3f} to {p['wilson_high']:.3f})"
            f"{_against_target(p, target, confidence)}"
        )
    return f"{mission}: no required value was computed for this study"


def _plan_says(required: dict, target: float | None) -> str:
    """The plan's own answer beside the runs' ('; the plan expects P(success) >= 0.95 from 18
    robots'), empty where the plans give no chance of success."""
    planned = required.get("planned")
    if not planned or target is None:
        return ""
    key = required.get("key", "?")
    if planned.get("value") is None:
        best_value, best = max(planned["chances"], key=lambda vc: vc[1])
        return (
            f"; no swept plan expects P(success) >= {target:g} (the best, "
            f"{required_value_text(key, best_value)}, expects {best:.3f})"
        )
    return f"; the plan expects P(success) >= {target:g} from {required_value_text(key, planned['value'])}"


def _against_target(point: dict, target: float | None, confidence: float) -> str:
    """What one point's runs say of the target: shown, not yet shown (and the runs that would show
    it at the rate seen: 64 successes in 64 cannot show 0.95, 73 would), or below it."""
    if target is None or not point.get("runs"):
        return ""
    goal = f"{target:g} at {percent(confidence)} confidence"
    if point["wilson_low"] >= target:
        return f": reaches {goal}"
    need = stats.runs_for_lower_bound(point["success_rate"], target, confidence)
    if need is None:
        return f": short of {goal}, and more runs will not lift a rate of {point['success_rate']:.3f}"
    return f": not yet shown to reach {goal}; about {need} runs would show it at the rate seen"


def answered(summary: dict) -> bool:
    """Whether the study found a required value (the report shows its answer in green)."""
    return (summary.get("required") or {}).get("value") is not None


def settings_rows(summary: dict) -> list[list[str]]:
    """How the study ran: runs, sweep, target, backend, and when and with which version it ran."""
    points = summary.get("points") or []
    runs = figs.total_runs(summary)
    per = summary.get("runs_per_point")
    runs_text = f"{runs} ({len(points)} points × {per} runs)" if per else str(runs)
    sweeps = summary.get("sweeps") or {}
    swept = "; ".join(f"{k}: {', '.join(format_value(v) for v in vs)}" for k, vs in sweeps.items())
    target = summary.get("target")
    confidence = summary.get("confidence", 0.95)
    workers = summary.get("workers")
    backend = str(summary.get("backend", "unknown")) + (f", {workers} workers" if workers else "")
    return [
        ["runs", runs_text],
        ["swept", swept or "nothing (one point)"],
        [
            "target",
            f"P(success) >= {target:g} at {percent(confidence)} confidence"
            if target is not None
            else MISSING,
        ],
        ["backend", backend],
        ["study run on", str(summary.get("date") or "unknown")],
        ["study run with", f"surf-swarm {summary.get('version', 'unknown')}"],
    ]


def runs_for_width(point: dict, width: float = WIDTH) -> object:
    """Runs the point would need for a Wilson interval of ± `width` (keys may be '0.05' or 0.05)."""
    for k, v in (point.get("runs_for_width") or {}).items():
        if _number(k) is not None and abs(float(k) - width) < 1e-9:
            return v
    return None


def _bounds(interval: object) -> tuple[float, float] | None:
    """A summary's t interval of a mean as two numbers; None where there is none (one run, runs
    that all gave the same value, or a summary written before intervals were kept)."""
    if not isinstance(interval, list | tuple) or len(interval) != 2:
        return None
    low, high = (_number(v) for v in interval)
    return None if low is None or high is None else (low, high)


def _mean_cell(mean: object, interval: object, spec: str) -> str:
    """'9.70 ± 0.56': a per-run mean and the half-width of its t interval (`stats.mean_interval`;
    the wider side where the interval stops at a bound, as a share's at 100%), the bare mean
    without one."""
    text, bounds, m = _fmt(mean, spec), _bounds(interval), _number(mean)
    if text == MISSING or bounds is None or m is None:
        return text
    return f"{text} ± {format(max(m - bounds[0], bounds[1] - m), spec).rstrip('%')}"


def _plan_cell(planned: object, interval: object, spec: str, *, more_is_better: bool = True) -> str:
    """'9.51 (agrees)': the plan's value and where it lies against the runs' t interval of the mean
    (`stats.agreement`: agrees, optimistic, conservative), the bare value without one."""
    text, bounds = _fmt(planned, spec), _bounds(interval)
    if text == MISSING or bounds is None:
        return text
    return f"{text} ({stats.agreement(_number(planned), bounds, more_is_better=more_is_better)})"


def _gives_chances(summary: dict) -> bool:
    """Whether some point's plan gives a chance of success (`planned_success`)."""
    return any(_number(p.get("planned_success")) is not None for p in summary.get("points") or [])


def _has_takeovers(summary: dict) -> bool:
    """Whether some point's runs or plan have the spares take over lost robots' stations."""
    return any(
        (_number(p.get("takeovers_mean")) or 0) > 0 or (_number(p.get("planned_takeovers")) or 0) > 0
        for p in summary.get("points") or []
    )


def _wilson(point: dict) -> list | None:
    """A point's Wilson interval of its success rate, as `_plan_cell` takes an interval."""
    low, high = _number(point.get("wilson_low")), _number(point.get("wilson_high"))
    return None if low is None or high is None else [low, high]


def points_note(summary: dict) -> str:
    """What the point table's ± and the plan's verdicts mean."""
    confidence = summary.get("confidence", 0.95)
    chances = _gives_chances(summary)
    success = "; its P(success) against the runs' Wilson interval alike" if chances else ""
    if _has_takeovers(summary):
        success += "; the stations taken over as the robots lost (optimistic when it expects fewer)"
    return (
        f"A mean's ± is the half-width of its {percent(confidence)} t interval over the point's runs. "
        "The plan's expectation agrees when it lies inside that interval; outside it, it is optimistic "
        "when it promises fewer robots lost or more mines found than the runs give, conservative when "
        f"fewer found or more lost{success}. A plan that holds misses its interval by chance in about "
        f"{percent(1 - confidence)} of points: more runs tell chance from a real miss."
    )


def study_rows(summary: dict) -> list[list[str]]:
    """One row per parameter point: its swept values, runs, successes, success rate, Wilson interval,
    whether the interval's lower bound reaches the target, median time to success, mean robots lost
    and the plan's expected losses, the mean share of the mines found and the plan's where a point
    has a search, the mean mines cleared and robots back at sea where any point has some, the
    stations the spares took over a run and the plan's where any point has some, and the runs a
    ±0.05 interval would need."""
    keys = swept_keys(summary)
    found = [
        title
        for title in ("mean detection", "plan's detection")
        if any(_number(p.get("detection_mean")) is not None for p in summary.get("points") or [])
    ]
    ends = [
        (key, title)
        for key, title in (
            ("mines_cleared_mean", "mean mines cleared"),
            ("recovered_mean", "mean back at sea"),
        )
        if any((_number(p.get(key)) or 0) > 0 for p in summary.get("points") or [])
    ]
    takeovers = _has_takeovers(summary)
    confidence = summary.get("confidence", 0.95)
    target = _number(summary.get("target"))
    chances = _gives_chances(summary)
    head = keys or ["point"]
    # a point that could not run says why, in a last column there only when one could not
    why = any(p.get("infeasible") for p in summary.get("points") or [])
    rows = [
        [
            *head,
            "runs",
            "successes",
            "P(success)",
            f"{percent(confidence)} Wilson interval",
            *(["plan's P(success)"] if chances else []),
            "lower bound ≥ target",
            "median time to success (s)",
            "mean lost per run",
            "plan's expected losses",
            *found,
            *(title for _, title in ends),
            *(["stations taken over", "plan's takeovers"] if takeovers else []),
            f"runs for ±{WIDTH:g}",
            *(["infeasible"] if why else []),
        ]
    ]
    for p in summary.get("points") or []:
        params = p.get("params", {})
        cells = [format_value(params.get(k, MISSING)) for k in keys] if keys else [point_label(params)]
        low = _number(p.get("wilson_low"))
        meets = MISSING if target is None or low is None else ("yes" if low >= target else "no")
        completed = p.get("completed_s") or {}
        median = completed.get("median") if completed.get("completed", 1) else None
        needed = _number(runs_for_width(p))
        rows.append(
            [
                *cells,
                str(p.get("runs", MISSING)),
                str(p.get("successes", MISSING)),
                _fmt(p.get("success_rate"), ".3f"),
                f"{_fmt(p.get('wilson_low'), '.3f')} to {_fmt(p.get('wilson_high'), '.3f')}",
                *([_plan_cell(p.get("planned_success"), _wilson(p), ".3f")] if chances else []),
                meets,
                _seconds(median),
                _mean_cell(p.get("lost_mean"), p.get("lost_interval"), ".2f"),
                _plan_cell(p.get("planned_lost"), p.get("lost_interval"), ".2f", more_is_better=False),
                *(
                    [
                        _mean_cell(p.get("detection_mean"), p.get("detection_interval"), ".1%"),
                        _plan_cell(p.get("planned_detection"), p.get("detection_interval"), ".1%"),
                    ]
                    if found
                    else []
                ),
                *(_fmt(p.get(key), ".2f") for key, _ in ends),
                *(_takeover_cells(p) if takeovers else []),
                MISSING if needed is None else f"{needed:.0f}",
                *([p.get("infeasible") or ""] if why else []),
            ]
        )
    return rows


def _takeover_cells(point: dict) -> list[str]:
    """The stations a point's runs took over a run (mean ± half-width) and the plan's, with where
    it lies (optimistic when the plan expects the spares to take fewer)."""
    interval = point.get("takeovers_interval")
    return [
        _mean_cell(point.get("takeovers_mean"), interval, ".2f"),
        _plan_cell(point.get("planned_takeovers"), interval, ".2f", more_is_better=False),
    ]


def pooled_losses_by_cause(summary: dict) -> dict[str, int]:
    """Losses by cause over every run: the summary's own, else summed over its points."""
    pooled = summary.get("losses_by_cause")
    if pooled:
        return dict(pooled)
    out: dict[str, int] = {}
    for p in summary.get("points") or []:
        for cause, n in (p.get("losses_by_cause") or {}).items():
            out[cause] = out.get(cause, 0) + n
    return out


def loss_rows(summary: dict) -> list[list[str]]:
    """Losses over all runs by cause (rows) and the phase the robot was in (columns), with totals,
    the mean per run and what the cause means; empty when no robot was lost."""
    by_cause = {c: n for c, n in pooled_losses_by_cause(summary).items() if n}
    if not by_cause:
        return []
    by_phase = figs.pooled_losses_by_phase(summary)
    phases = figs.ordered_phases([p for p, cs in by_phase.items() if any(cs.values())])
    causes = [c for c in CAUSES if c in by_cause] + sorted(set(by_cause) - set(CAUSES))
    runs = figs.total_runs(summary)
    rows = [["cause", *phases, "total", "per run", "what it means"]]
    for c in causes:
        rows.append(
            [
                c,
                *(str(by_phase.get(p, {}).get(c, 0)) for p in phases),
                str(by_cause[c]),
                f"{by_cause[c] / runs:.2f}" if runs else MISSING,
                CAUSE_DESCRIPTIONS.get(c, ""),
            ]
        )
    total = sum(by_cause.values())
    rows.append(
        [
            "total",
            *(str(sum(by_phase.get(p, {}).values())) for p in phases),
            str(total),
            f"{total / runs:.2f}" if runs else MISSING,
            "",
        ]
    )
    return rows


def cause_rows(summary: dict) -> list[list[str]]:
    """Each cause's robots lost a run against the plan's expectation, a pair of columns a point
    (`figs.causes_by_point`): the runs' mean with its interval's half-width, the plan's value with
    its verdict; a cause in a row where any point's runs lost a robot to it or its plan expects
    some. Empty when no point's plan gives its losses by cause."""
    points, causes, entries = figs.causes_by_point(summary)
    if not points:
        return []
    if len(summary.get("points") or []) == 1:  # a sweep names its points, even where one has no plan
        head = ["runs: lost per run", "plan's expectation"]
    else:
        head = [f"{point_label(p.get('params', {}))}: {what}" for p in points for what in ("runs", "plan")]
    rows = [["cause", *head]]
    for j, cause in enumerate(causes):
        cells = []
        for point_entries in entries:
            c = point_entries[j]
            cells += [
                _mean_cell(c["mean"], c["interval"], ".2f"),
                _plan_cell(c["planned"], c["interval"], ".2f", more_is_better=False),
            ]
        rows.append([cause, *cells])
    return rows


def causes_note(summary: dict) -> str:
    """What the cause table's ± and verdicts mean."""
    confidence = summary.get("confidence", 0.95)
    return (
        f"A cause's ± is the half-width of the {percent(confidence)} interval of its robots lost a run "
        "(t, or Garwood's Poisson interval where every run lost as many). Where the plan's expected "
        "losses and the runs' part ways, this says which cause they part on: the plan is optimistic "
        "where it expects fewer lost than the runs give, conservative where more. With many causes, "
        f"some miss their interval by chance ({percent(1 - confidence)} each when the plan holds)."
    )


def figures(
    table: pa.Table, summary: dict, beach_map: BeachMap | None
) -> list[tuple[str, bytes | None, str]]:
    """(heading, PNG or None, what to say when it is None) of every figure, in report order."""
    return [(f.heading, f.make(), f.absent) for f in _figures(table, _ran(summary), beach_map)]


def _ran(summary: dict) -> dict:
    """`summary` with only the points that ran (the figures have nothing of an infeasible one)."""
    return {**summary, "points": [p for p in summary.get("points") or [] if not p.get("infeasible")]}


def _figures(
    table: pa.Table, summary: dict, beach_map: BeachMap | None, no_map: str = "No map given."
) -> list:
    lost = "No robot was lost."
    return [
        Figure(
            "Success probability",
            lambda: figs.success_png(summary),
            alt="Success probability against the swept parameter, with Wilson interval bars, the plan's "
            "chance of success where it gives one, the target and the required value",
            absent="No parameter points.",
        ),
        Figure(
            "The plan against its runs",
            lambda: figs.agreement_png(summary),
            alt="The plan's expected mines found and robots lost per run against the runs' means with "
            "their t intervals, point by point",
            absent="No plan's expectation to compare: the results table has no planned_lost or "
            "planned_detection column, or the mission has no hazards and no search.",
        ),
        Figure(
            "Losses by cause: the plan against its runs",
            lambda: figs.causes_png(summary),
            alt="Robots lost per run to each cause, the runs' means with their intervals beside the plan's "
            "expectation, point by point",
            absent="No plan's losses by cause to compare: the mission has no hazards, or the results "
            "table was written before the plan's losses by cause were kept.",
        ),
        Figure(
            "Robots lost per run, by cause and phase",
            lambda: figs.losses_png(summary),
            alt="Stacked bars of robots lost per run by cause, by phase and by parameter point",
            absent=lost,
        ),
        Figure(
            "Where robots were lost",
            lambda: figs.loss_map_png(table, beach_map),
            alt="Heat map of where robots were lost over the map, with loss markers by cause",
            absent=no_map if beach_map is None else lost,
        ),
        Figure(
            "Time to success",
            lambda: figs.completion_png(table, summary),
            alt="Histograms of the mission time to success at each parameter point",
            absent="No runs in the results table.",
        ),
    ]


def _status(summary: dict) -> str:
    """met when the study found its required value (or its one point reaches the target), not met
    when it looked and found none, none when there is nothing to judge."""
    if answered(summary):
        return "met"
    if (summary.get("required") or {}).get("note"):
        return "not met"
    points = summary.get("points") or []
    target = _number(summary.get("target"))
    if len(points) == 1 and target is not None and _number(points[0].get("wilson_low")) is not None:
        return "met" if points[0]["wilson_low"] >= target else "not met"
    return "not met" if points else "none"


#: Summary keys the report keeps (its tables and figures read them under the same names).
SUMMARY_KEYS = (
    "mission_path",
    "runs",
    "runs_per_point",
    "sweeps",
    "target",
    "confidence",
    "backend",
    "workers",
    "version",
    "points",
    "required",
    "losses_by_cause",
    "losses_by_phase",
)


def study_data(summary: dict, date: str | None = None) -> dict:
    """The study report's numbers (report.json): the header, the verdict, and the summary's own."""
    sentence = answer(summary)
    out = {
        "header": header("study", summary.get("mission"), summary.get("map"), summary.get("seed"), date),
        "verdict": verdict(sentence, _status(summary), required=summary.get("required")),
        "run_date": summary.get("date"),
    }
    out.update({k: summary[k] for k in SUMMARY_KEYS if k in summary})
    out["runs"] = figs.total_runs(summary)
    return jsonable(out)


def study_report(
    table: pa.Table,
    summary: dict,
    beach_map: BeachMap | None = None,
    *,
    date: str | None = None,
    no_map: str = "No map given.",
) -> Report:
    """The report of a study: its results `table`, `summary` (summary.json) and the mission's map
    (None: no loss map, the page says `no_map`). `date` defaults to the day the study ran."""
    data = study_data(summary, date or summary.get("date"))
    note = (summary.get("required") or {}).get("note") if answered(summary) else None
    blocks: list = []
    if note:
        blocks.append(Text("How the answer was found", str(note)))
    blocks.append(Table("Study", settings_rows(summary), header=False))
    blocks.append(Table("Parameter points", study_rows(data), note=points_note(data)))
    losses = loss_rows(data)
    if losses:
        blocks.append(Table("Losses by cause and phase, all runs", losses))
    causes = cause_rows(data)
    if causes:
        blocks.append(Table("Losses by cause: the runs against the plan", causes, note=causes_note(data)))
    blocks += _figures(table, _ran(summary), beach_map, no_map)
    h = data["header"]
    return Report(
        "study",
        f"Mission study: {h['mission'] or 'unknown'} on {h['map'] or 'unknown'} "
        f"(seed {h['seed'] if h['seed'] is not None else '?'}, {data['runs']} runs)",
        data,
        blocks,
        files_note="Data: results.parquet (one row per run), summary.json, study.json.",
    )


def write_study_report(
    study_dir: str | Path,
    table: pa.Table,
    summary: dict,
    beach_map: BeachMap | None = None,
    *,
    date: str | None = None,
) -> dict[str, Path]:
    """Write report.html, report.md and report.json into `study_dir` (created), atomically; returns
    their paths. The date defaults to the summary's (when the study ran), so the same study gives the
    same report."""
    return study_report(table, summary, beach_map, date=date).write_all(study_dir)
