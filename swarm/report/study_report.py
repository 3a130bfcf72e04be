"""A Monte Carlo study as a report: `report.md` (the answer and the tables) and a self-contained
`report.html` (the same, plus the figures of `swarm.report.study_figures` as embedded PNG; no network).

```python
write_study_report(study_dir, table, summary, beach_map)   # report.md, report.html
```

`summary` is the study's summary.json as a dict, `table` its results table (`swarm.studies.table`).
The tables here (`header_rows`, `study_rows`, `loss_rows`) and the sentence `answer` are also what
`swarm study` prints, so the terminal and the report always say the same thing.
"""

from __future__ import annotations

import datetime
import html
import math
from pathlib import Path

import pyarrow as pa

from swarm.files import write_text_atomic
from swarm.report import study_figures as figs
from swarm.report.html_page import html_figure, html_page, html_table, md_table
from swarm.report.study_figures import KEY_NOUNS, format_value, point_label, swept_keys
from swarm.sim.hazards import CAUSE_DESCRIPTIONS, CAUSES
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
    if required.get("value") is not None and target is not None:
        what = required_value_text(required.get("key", "?"), required["value"])
        return f"{mission} needs {what} for P(success) >= {target:g} at {percent(confidence)} confidence"
    if required.get("note"):
        return str(required["note"])
    points = summary.get("points") or []
    if len(points) == 1:
        p = points[0]
        return (
            f"{mission}: P(success) = {p['success_rate']:.3f} over {p['runs']} runs "
            f"({percent(confidence)} Wilson interval {p['wilson_low']:.3f} to {p['wilson_high']:.3f})"
        )
    return f"{mission}: no required value was computed for this study"


def answered(summary: dict) -> bool:
    """Whether the study found a required value (the report shows its answer in green)."""
    return (summary.get("required") or {}).get("value") is not None


def header_rows(summary: dict) -> list[list[str]]:
    """What was studied, how and when: mission, map, seed, runs, sweep, target, backend, version, date."""
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
        ["mission", str(summary.get("mission", "unknown"))],
        ["map", str(summary.get("map", "unknown"))],
        ["seed", str(summary.get("seed", "unknown"))],
        ["runs", runs_text],
        ["swept", swept or "nothing (one point)"],
        [
            "target",
            f"P(success) >= {target:g} at {percent(confidence)} confidence"
            if target is not None
            else MISSING,
        ],
        ["backend", backend],
        ["surf-swarm", str(summary.get("version", "unknown"))],
        ["date", str(summary.get("date", "unknown"))],
    ]


def runs_for_width(point: dict, width: float = WIDTH) -> object:
    """Runs the point would need for a Wilson interval of ± `width` (keys may be '0.05' or 0.05)."""
    for k, v in (point.get("runs_for_width") or {}).items():
        if _number(k) is not None and abs(float(k) - width) < 1e-9:
            return v
    return None


def study_rows(summary: dict) -> list[list[str]]:
    """One row per parameter point: its swept values, runs, successes, success rate, Wilson interval,
    whether the interval's lower bound reaches the target, median time to success, mean robots lost
    and the runs a ±0.05 interval would need."""
    keys = swept_keys(summary)
    confidence = summary.get("confidence", 0.95)
    target = _number(summary.get("target"))
    head = keys or ["point"]
    rows = [
        [
            *head,
            "runs",
            "successes",
            "P(success)",
            f"{percent(confidence)} Wilson interval",
            "lower bound ≥ target",
            "median time to success (s)",
            "mean lost per run",
            f"runs for ±{WIDTH:g}",
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
                meets,
                _fmt(median, ".0f"),
                _fmt(p.get("lost_mean"), ".2f"),
                MISSING if needed is None else f"{needed:.0f}",
            ]
        )
    return rows


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


def figures(
    table: pa.Table, summary: dict, beach_map: BeachMap | None
) -> list[tuple[str, bytes | None, str]]:
    """(heading, PNG or None, what to say when it is None) of every figure, in report order."""
    no_map = "No map given." if beach_map is None else "No robot was lost."
    return [
        ("Success probability", figs.success_png(summary), "No parameter points."),
        ("Robots lost per run, by cause and phase", figs.losses_png(summary), "No robot was lost."),
        ("Where robots were lost", figs.loss_map_png(table, beach_map), no_map),
        ("Time to success", figs.completion_png(table, summary), "No runs in the results table."),
    ]


def _sections(summary: dict) -> list[tuple[str, list[list[str]], bool]]:
    """(heading, rows, has a header row) of every table, in report order."""
    out = [("Study", header_rows(summary), False), ("Parameter points", study_rows(summary), True)]
    losses = loss_rows(summary)
    if losses:
        out.append(("Losses by cause and phase, all runs", losses, True))
    return out


def write_study_report(
    study_dir: str | Path, table: pa.Table, summary: dict, beach_map: BeachMap | None = None
) -> dict[str, Path]:
    """Write report.md and report.html into `study_dir` (created), atomically; returns their paths.
    The date is the summary's (when the study ran), so the same study gives the same report."""
    out = Path(study_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = {
        **summary,
        "date": summary.get("date") or datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d"),
    }
    title = (
        f"Mission study: {summary.get('mission', 'unknown')} on {summary.get('map', 'unknown')} "
        f"(seed {summary.get('seed', '?')}, {figs.total_runs(summary)} runs)"
    )
    sentence = answer(summary)
    note = (summary.get("required") or {}).get("note") if answered(summary) else None
    tables = _sections(summary)

    md = [f"# {title}", f"**{sentence}.**" if not sentence.endswith(".") else f"**{sentence}**"]
    if note:
        md.append(str(note))
    for heading, rows, header in tables:
        md += [f"## {heading}", md_table(rows, header=header)]
    md.append(
        "Figures (success probability, losses by cause and phase, where robots were lost, time to "
        "success): report.html."
    )

    colour = "#009E73" if answered(summary) else "#D55E00"
    body = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p style='font-size:20px;font-weight:bold;color:{colour}'>{html.escape(sentence)}</p>",
    ]
    if note:
        body.append(f"<p>{html.escape(str(note))}</p>")
    for heading, rows, header in tables:
        body.append(f"<h2>{html.escape(heading)}</h2>{html_table(rows, header=header)}")
    for heading, png, absent in figures(table, summary, beach_map):
        if png is not None:
            body.append(html_figure(heading, png))
        else:
            body.append(f"<h2>{html.escape(heading)}</h2><p>{html.escape(absent)}</p>")
    paths = {"report.md": out / "report.md", "report.html": out / "report.html"}
    write_text_atomic(paths["report.md"], "\n\n".join(md) + "\n")
    write_text_atomic(paths["report.html"], html_page(title, body))
    return paths
