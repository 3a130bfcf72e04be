"""One report, three formats: a `Report` holds the report's numbers as a JSON-ready dict (that dict IS
report.json) and the tables, text and figures built from it, and renders them as Markdown and as one
self-contained HTML page. Because Markdown and HTML are rendered from the same table rows, which
are formatted from the same dict, the three formats cannot disagree.

Every report starts with the same header (mission, map, seed, surf-swarm version, date) and the
verdict against the mission's success criteria (`Verdict`), then its own tables and figures.

```python
report = build_report("reports/landing-sim")      # swarm.report.load: a plan, log, study or validation
report.write("reports/landing-sim/report.html")    # or report.html(), report.markdown(), report.json()
```
"""

from __future__ import annotations

import datetime
import html
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import swarm
from swarm.errors import InputError
from swarm.files import write_text_atomic
from swarm.report.html_page import html_figure, html_page, html_table, md_table

#: Report formats: file suffix by format name.
FORMATS = {"html": ".html", "md": ".md", "json": ".json"}
#: What a verdict's status means, for the page's colours.
STATUSES = ("met", "not met", "not shown", "none")
MISSING = "-"


def seconds(value: float) -> str:
    """Whole seconds, as the reports print times, a half rounded up: the simulator's clock runs in
    half seconds and a median of an even number of runs is often x.5, and format's half-to-even
    printed 2746.5 as 2746 but 2747.5 as 2748."""
    return str(math.floor(value + 0.5))


def today() -> str:
    """Today's date (UTC), ISO: the date reports carry unless they are given one."""
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d")


def version() -> str:
    return str(getattr(swarm, "__version__", "unknown"))


def jsonable(value: object) -> object:
    """A value JSON can hold: numpy scalars and arrays as Python, NaN and infinities as None."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.bool_ | bool):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        x = float(value)
        return x if math.isfinite(x) else None
    return value


def header(
    kind: str,
    mission: object,
    map_name: object,
    seed: object,
    date: str | None,
    **extra: object,
) -> dict:
    """The header every report starts with; `extra` (kind-specific facts) follows the common keys."""
    return {
        "kind": kind,
        "mission": mission,
        "map": map_name,
        "seed": seed,
        "version": version(),
        "date": date or today(),
        **extra,
    }


def header_rows(head: dict) -> list[list[str]]:
    """The header as a two-column table (kind first, absent values as a dash)."""
    labels = {"version": "surf-swarm", "kind": "report"}
    return [[labels.get(k, k.replace("_", " ")), MISSING if v is None else str(v)] for k, v in head.items()]


def verdict(text: str, status: str, **numbers: object) -> dict:
    """The report's verdict: one sentence, its status (met, not met, not shown: too few runs to tell,
    none) and the numbers behind it."""
    if status not in STATUSES:
        raise ValueError(f"verdict status {status!r}, expected one of {STATUSES}")
    return {"text": text, "status": status, **numbers}


@dataclass
class Table:
    heading: str
    rows: list[list[str]]
    header: bool = True  # the first row names the columns
    note: str = ""  # a sentence under the heading


@dataclass
class Text:
    heading: str
    text: str


@dataclass
class Figure:
    """A figure drawn on demand (only the HTML page needs it) as PNG bytes; None when there is
    nothing to show, and then the page says `absent`."""

    heading: str
    make: Callable[[], bytes | None]
    alt: str
    caption: str = ""
    absent: str = ""


Block = Table | Text | Figure


@dataclass
class Report:
    """A report of one `kind` (plan, simulation, study, validation): `data` is report.json."""

    kind: str
    title: str
    data: dict
    blocks: list[Block]
    files_note: str = ""
    _pngs: dict[int, bytes | None] = field(default_factory=dict, repr=False)

    @property
    def verdict(self) -> dict:
        return self.data["verdict"]

    def tables(self) -> dict[str, list[list[str]]]:
        """Every table by heading, header first (the header table is 'Report')."""
        out = {"Report": header_rows(self.data["header"])}
        out.update({b.heading: b.rows for b in self.blocks if isinstance(b, Table)})
        return out

    def figure_png(self, index: int) -> bytes | None:
        """Block `index`'s figure, drawn once."""
        if index not in self._pngs:
            block = self.blocks[index]
            assert isinstance(block, Figure)
            self._pngs[index] = block.make()
        return self._pngs[index]

    def json(self) -> str:
        return json.dumps(jsonable(self.data), indent=1, ensure_ascii=False, allow_nan=False) + "\n"

    def markdown(self) -> str:
        v = self.verdict
        out = [
            f"# {self.title}",
            f"**{v['text']}**",
            "## Report",
            md_table(header_rows(self.data["header"]), False),
        ]
        figures = False
        for b in self.blocks:
            if isinstance(b, Table):
                out.append(f"## {b.heading}")
                if b.note:
                    out.append(b.note)
                if len(b.rows) > (1 if b.header else 0):
                    out.append(md_table(b.rows, header=b.header))
            elif isinstance(b, Text):
                out += [f"## {b.heading}", b.text]
            else:
                figures = True
        tail = []
        if figures:
            tail.append("Figures: report.html.")
        if self.files_note:
            tail.append(self.files_note)
        if tail:
            out.append(" ".join(tail))
        return "\n\n".join(out) + "\n"

    def html(self) -> str:
        v = self.verdict
        cls = {"met": "verdict met", "not met": "verdict not-met"}.get(v["status"], "verdict")
        body = [
            f"<h1>{html.escape(self.title)}</h1>",
            f"<p class='{cls}'>{html.escape(v['text'])}</p>",
            f"<h2>Report</h2>{html_table(header_rows(self.data['header']), header=False)}",
        ]
        for i, b in enumerate(self.blocks):
            if isinstance(b, Table):
                note = f"<p class='note'>{html.escape(b.note)}</p>" if b.note else ""
                table = html_table(b.rows, header=b.header) if len(b.rows) > (1 if b.header else 0) else ""
                body.append(f"<h2>{html.escape(b.heading)}</h2>{note}{table}")
            elif isinstance(b, Text):
                body.append(f"<h2>{html.escape(b.heading)}</h2><p>{html.escape(b.text)}</p>")
            else:
                png = self.figure_png(i)
                if png is not None:
                    body.append(html_figure(b.heading, png, alt=b.alt, caption=b.caption))
                elif b.absent:
                    body.append(
                        f"<h2>{html.escape(b.heading)}</h2><p class='note'>{html.escape(b.absent)}</p>"
                    )
        footer = f"surf-swarm {self.data['header']['version']}, {self.data['header']['date']}."
        if self.files_note:
            footer += " " + self.files_note
        body.append(f"<footer>{html.escape(footer)}</footer>")
        return html_page(self.title, body)

    def render(self, fmt: str) -> str:
        """The report as text in `fmt` (html, md or json)."""
        if fmt == "html":
            return self.html()
        if fmt == "md":
            return self.markdown()
        if fmt == "json":
            return self.json()
        raise InputError("command line", "--format", fmt, f"one of {', '.join(FORMATS)}")

    def write(self, path: str | Path, fmt: str | None = None) -> Path:
        """Write the report to `path` atomically, in `fmt` (default: by the suffix, else html)."""
        path = Path(path)
        fmt = fmt or format_for(path) or "html"
        write_text_atomic(path, self.render(fmt))
        return path

    def write_all(self, out_dir: str | Path) -> dict[str, Path]:
        """report.html, report.md and report.json in `out_dir` (created); returns their paths."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {f"report{suffix}": out / f"report{suffix}" for suffix in FORMATS.values()}
        for fmt, suffix in FORMATS.items():
            self.write(paths[f"report{suffix}"], fmt)
        return paths


def format_for(path: str | Path) -> str | None:
    """The format a file name asks for by its suffix (.html/.htm, .md/.markdown, .json), else None."""
    suffix = Path(path).suffix.lower()
    return {".html": "html", ".htm": "html", ".md": "md", ".markdown": "md", ".json": "json"}.get(suffix)
