"""The study report: a synthetic results table and the summary it implies, written to a report whose
Markdown and HTML must agree with each other and with the summary, with figures that decode."""

from __future__ import annotations

import base64
import io
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from PIL import Image
from scipy import stats

from swarm.report import study_figures as figs
from swarm.report.study_report import (
    answer,
    cause_rows,
    loss_rows,
    points_note,
    study_rows,
    write_study_report,
)
from swarm.sim.hazards import CAUSES
from swarm.studies.table import CRITERIA, schema
from swarm.world.io import load_map

#: End-to-end: real reports, folders and processes (deselect with -m "not slow").
pytestmark = pytest.mark.slow


ROOT = Path(__file__).resolve().parents[2]
KEY = "swarm.count"
COUNTS = (10, 20, 30)
P_SUCCESS = (0.1, 0.5, 1.0)
RUNS = 40
TARGET = 0.8
Z95 = 1.959963984540054
LOSS_CAUSES = ("failure", "wave_impact", "immobilized", "mine")
LOSS_PHASES = ("sea_transit", "surf_crossing", "beach", "returning")


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def make_table(bounds: tuple[float, float, float, float], completed: bool = True) -> pa.Table:
    """RUNS runs at each of COUNTS with success probabilities P_SUCCESS, random losses on the map."""
    rng = np.random.default_rng(7)
    x0, y0, x1, y1 = bounds
    rows = []
    for point, (count, p) in enumerate(zip(COUNTS, P_SUCCESS, strict=True)):
        for run in range(RUNS):
            success = bool(rng.random() < p)
            n_lost = int(rng.poisson(0.1 * count))
            losses = [
                {
                    "cause": str(rng.choice(LOSS_CAUSES)),
                    "phase": str(rng.choice(LOSS_PHASES)),
                    "t_s": float(rng.uniform(0, 1800)),
                    "x_m": float(rng.uniform(x0, x1)),
                    "y_m": float(rng.uniform(y0, y1)),
                }
                for _ in range(n_lost)
            ]
            row = {
                "point": point,
                "run": run,
                "seed": int(rng.integers(0, 2**63)),
                KEY: count,
                "robots": count,
                "success": success,
                "lost": n_lost,
                "losses": losses,
                "completed_s": float(rng.normal(1200, 150)) if success and completed else math.nan,
                "duration_s": 1800.0,
                "runtime_s": 0.5,
            }
            for c in CRITERIA:
                row[f"value_{c}"], row[f"met_{c}"] = (1.0, success) if c == "detection" else (math.nan, False)
            for c in CAUSES:
                row[f"lost_{c}"] = sum(1 for x in losses if x["cause"] == c)
            rows.append(row)
    return pa.Table.from_pylist(rows, schema=schema([(KEY, pa.int64())]))


def summarise(table: pa.Table) -> dict:
    """The summary the study code would write for `table` (the fields the report reads)."""
    rows = table.to_pylist()
    points = []
    for i, count in enumerate(COUNTS):
        mine = [r for r in rows if r["point"] == i]
        k, n = sum(r["success"] for r in mine), len(mine)
        done = np.array([r["completed_s"] for r in mine if not math.isnan(r["completed_s"])])
        lo, hi = wilson(k, n)
        by_cause: dict[str, int] = {}
        by_phase: dict[str, dict[str, int]] = {}
        for r in mine:
            for x in r["losses"]:
                by_cause[x["cause"]] = by_cause.get(x["cause"], 0) + 1
                by_phase.setdefault(x["phase"], {})[x["cause"]] = (
                    by_phase.get(x["phase"], {}).get(x["cause"], 0) + 1
                )
        points.append(
            {
                "index": i,
                "params": {KEY: count},
                "runs": n,
                "successes": k,
                "success_rate": k / n,
                "wilson_low": lo,
                "wilson_high": hi,
                "completed_s": {
                    "count": n,
                    "completed": len(done),
                    "median": float(np.median(done)) if len(done) else None,
                    "mean": float(done.mean()) if len(done) else None,
                },
                "losses_by_cause": by_cause,
                "losses_by_phase": by_phase,
                "lost_mean": sum(r["lost"] for r in mine) / n,
                "runs_for_width": {"0.1": 100 + i, "0.05": 400 + i},
            }
        )
    first = next(p for p in points if p["wilson_low"] >= TARGET)
    pooled_cause: dict[str, int] = {}
    pooled_phase: dict[str, dict[str, int]] = {}
    for p in points:
        for c, n in p["losses_by_cause"].items():
            pooled_cause[c] = pooled_cause.get(c, 0) + n
        for ph, cs in p["losses_by_phase"].items():
            for c, n in cs.items():
                pooled_phase.setdefault(ph, {})[c] = pooled_phase.get(ph, {}).get(c, 0) + n
    return {
        "mission": "mine_clear",
        "map": "test_small",
        "seed": 0,
        "runs_per_point": RUNS,
        "target": TARGET,
        "confidence": 0.95,
        "sweeps": {KEY: list(COUNTS)},
        "backend": "local",
        "workers": 2,
        "version": "0.1.0",
        "date": "2025-01-02",
        "points": points,
        "required": {
            "key": KEY,
            "value": first["params"][KEY],
            "target": TARGET,
            "confidence": 0.95,
            "note": "the smallest swarm.count whose Wilson lower bound reaches the target",
        },
        "losses_by_cause": pooled_cause,
        "losses_by_phase": pooled_phase,
        "runs": len(rows),
    }


class _Tables(HTMLParser):
    """Every <table> of a page as rows of cell texts."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list) -> None:
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def html_point_table(page: str) -> list[list[str]]:
    parser = _Tables()
    parser.feed(page)
    return next(t for t in parser.tables if "P(success)" in t[0])


def md_point_table(text: str) -> list[list[str]]:
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if "| P(success) |" in line)
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        if not line.startswith("|---"):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def column(rows: list[list[str]], name: str) -> list[str]:
    j = rows[0].index(name)
    return [r[j] for r in rows[1:]]


@pytest.fixture(scope="module")
def beach_map():
    return load_map(ROOT / "maps" / "test_small.yaml")


@pytest.fixture(scope="module")
def study(beach_map):
    table = make_table(beach_map.bounds_m)
    return table, summarise(table)


@pytest.fixture(scope="module")
def report(tmp_path_factory, study, beach_map):
    table, summary = study
    out = tmp_path_factory.mktemp("study")
    paths = write_study_report(out, table, summary, beach_map)
    return (
        paths,
        paths["report.md"].read_text(encoding="utf-8"),
        paths["report.html"].read_text(encoding="utf-8"),
    )


def test_report_files_exist_and_figures_decode(report):
    paths, _, page = report
    assert set(paths) == {"report.md", "report.html", "report.json"}
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths.values())
    assert not [p for p in paths["report.md"].parent.iterdir() if p.name.startswith(".")]  # no temp left
    images = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", page)
    assert len(images) == 4  # success, losses, loss map, completion
    for data in images:
        img = Image.open(io.BytesIO(base64.b64decode(data)))
        img.load()
        assert img.format == "PNG"
        assert 400 <= img.width <= 2000 and 150 <= img.height <= 2000
    assert "http://" not in page and "https://" not in page  # self-contained


def test_markdown_and_html_agree_with_the_summary(report, study):
    _, md, page = report
    _, summary = study
    md_rows, html_rows = md_point_table(md), html_point_table(page)
    assert md_rows == html_rows
    rates = [float(v) for v in column(md_rows, "P(success)")]
    assert rates == pytest.approx([p["success_rate"] for p in summary["points"]], abs=5e-4)
    assert [int(v) for v in column(html_rows, KEY)] == list(COUNTS)
    assert [int(v) for v in column(html_rows, "successes")] == [p["successes"] for p in summary["points"]]
    lows = [float(v.split(" to ")[0]) for v in column(html_rows, "95% Wilson interval")]
    assert lows == pytest.approx([p["wilson_low"] for p in summary["points"]], abs=5e-4)
    assert column(md_rows, "lower bound ≥ target") == ["no", "no", "yes"]
    assert column(md_rows, "runs for ±0.05") == ["400", "401", "402"]
    lost = [float(v) for v in column(md_rows, "mean lost per run")]
    assert lost == pytest.approx([p["lost_mean"] for p in summary["points"]], abs=5e-3)


def test_the_answer_names_the_required_size(report):
    _, md, page = report
    sentence = "mine_clear needs 30 robots for P(success) >= 0.8 at 95% confidence"
    assert sentence in md
    assert sentence.replace(">", "&gt;") in page
    assert md.index(sentence) < md.index("| P(success) |")  # the answer comes before the tables


def test_loss_table_totals_match_the_results_table(study):
    table, summary = study
    rows = loss_rows(summary)
    total = rows[-1]
    assert total[0] == "total"
    lost = sum(table.column("lost").to_pylist())
    assert int(total[rows[0].index("total")]) == lost
    for c in LOSS_CAUSES:
        row = next(r for r in rows if r[0] == c)
        assert int(row[rows[0].index("total")]) == sum(table.column(f"lost_{c}").to_pylist())
    assert rows[0][1:5] == list(LOSS_PHASES)  # phases in mission order


def test_loss_points_are_every_loss_on_the_map(study, beach_map):
    table, _ = study
    x, y, cause = figs.loss_points(table)
    assert len(x) == sum(table.column("lost").to_pylist()) > 0
    assert np.all(beach_map.contains(x, y))
    assert set(cause) <= set(LOSS_CAUSES)
    assert figs.loss_bin_m(beach_map) == 5.0


def test_no_required_value_shows_the_note(tmp_path, study):
    table, summary = study
    note = "no swept swarm.count reaches P(success) >= 0.99; try more robots"
    unmet = {**summary, "required": {"key": KEY, "value": None, "target": 0.99, "note": note}}
    assert answer(unmet) == note
    paths = write_study_report(tmp_path, table, unmet, None)
    md, page = paths["report.md"].read_text(), paths["report.html"].read_text()
    assert note in md and "needs" not in md
    assert "try more robots" in page and "needs 30 robots" not in page
    assert "No map given." in page  # the loss map needs a map
    assert len(re.findall(r"data:image/png;base64,", page)) == 3


def test_two_swept_keys_draw_one_line_per_value():
    points = []
    for i, (count, h) in enumerate([(c, h) for h in (0.5, 1.5) for c in COUNTS]):
        k = min(RUNS, int(RUNS * count / 30 / (1 + h)))
        lo, hi = wilson(k, RUNS)
        points.append(
            {
                "index": i,
                "params": {KEY: count, "hazards.surf.wave_height_m": h},
                "runs": RUNS,
                "successes": k,
                "success_rate": k / RUNS,
                "wilson_low": lo,
                "wilson_high": hi,
            }
        )
    summary = {
        "target": 0.5,
        "confidence": 0.95,
        "sweeps": {KEY: list(COUNTS), "hazards.surf.wave_height_m": [0.5, 1.5]},
        "points": points,
        "required": {"key": KEY, "value": 20},
    }
    assert figs.x_key(summary) == KEY
    assert figs.short_label(points[0]["params"]) == "count = 10, wave_height_m = 0.5"
    assert figs.key_label("hazards.surf.wave_height_m") == "hazards.surf.wave_height_m (m)"
    png = figs.success_png(summary)
    assert png is not None and Image.open(io.BytesIO(png)).width > 400
    assert figs.success_png(summary) == png  # no timestamp: the same study gives the same bytes
    rows = study_rows(summary)
    assert rows[0][:2] == [KEY, "hazards.surf.wave_height_m"]
    assert [r[1] for r in rows[1:]] == ["0.5"] * 3 + ["1.5"] * 3
    assert all(r[-2] == "-" for r in rows[1:])  # no losses or runs for width given: a dash, no error


def test_empty_study_skips_figures(tmp_path, beach_map):
    empty = schema([(KEY, pa.int64())]).empty_table()
    summary = {
        "mission": "mine_clear",
        "map": "test_small",
        "seed": 1,
        "target": 0.9,
        "points": [],
        "runs": 0,
    }
    assert figs.success_png(summary) is None
    assert figs.losses_png(summary) is None
    assert figs.loss_map_png(empty, beach_map) is None
    assert figs.completion_png(empty, summary) is None
    assert len(figs.loss_points(empty)[0]) == 0
    paths = write_study_report(tmp_path, empty, summary, beach_map)
    page = paths["report.html"].read_text()
    assert "data:image/png" not in page
    assert "No runs in the results table." in page and "No robot was lost." in page
    assert study_rows(summary) == study_rows(summary)[:1]  # the header alone


def test_no_completed_run_says_so(beach_map):
    table = make_table(beach_map.bounds_m, completed=False)
    png = figs.completion_png(table, summarise(table))
    assert png is not None
    img = Image.open(io.BytesIO(png))
    assert img.width > img.height  # the one-line note, not a grid of panels


def test_the_answer_says_where_the_other_swept_keys_are_held() -> None:
    """Two sweeps: the required size is the one at the other key's first value, and the sentence
    says so (it read as an answer for every mtbf)."""
    held = {"hazards.attrition.mtbf_h": 1}
    found = {"key": "swarm.count", "value": 12, "target": 0.9, "confidence": 0.95, "held": held}
    assert answer({"mission": "landing", "required": found}) == (
        "landing needs 12 robots for P(success) >= 0.9 at 95% confidence, with hazards.attrition.mtbf_h = 1"
    )
    missed = {**found, "value": None, "note": "none of the swept sizes reaches 0.9 at 95% confidence"}
    assert answer({"mission": "landing", "required": missed}).endswith(", with hazards.attrition.mtbf_h = 1")
    alone = {**found, "held": {}}
    assert answer({"mission": "landing", "required": alone}).endswith("at 95% confidence")


@pytest.mark.parametrize(
    ("median", "shown"), [(2746.5, "2747"), (2747.5, "2748"), (1850.25, "1850"), (None, "-")]
)
def test_a_median_time_of_x_5_rounds_half_up(median: float | None, shown: str) -> None:
    """Two runs that complete at 1846 and 1855 s have median 1850.5: it printed 1850 (Python's
    round half to even), 2747.5 printed 2748. Whole seconds, a half up, as other times are shown."""
    point = {"params": {}, "runs": 2, "successes": 2, "completed_s": {"completed": 2, "median": median}}
    rows = study_rows({"points": [point]})
    assert column(rows, "median time to success (s)") == [shown]


def test_the_points_say_the_mines_cleared_and_the_robots_back_where_a_mission_has_them() -> None:
    """The summary's per-point means of the table's mines cleared and robots back at sea (None
    from a table written before they were counted), and the report's columns for them only where
    some point has any."""
    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(
        str(ROOT / "missions" / "full_conops.yaml"), 2, parse_sweeps(["swarm.count=30,42"]), seed=1
    )
    base = {"success": [True, False, True, True], "losses": [[]] * 4, "completed_s": [1.0, None, 2.0, 3.0]}
    table = pa.table(
        {
            "point": pa.array([0, 0, 1, 1], pa.int32()),
            "run": pa.array([0, 1, 0, 1], pa.int32()),
            **base,
            "mines_cleared": pa.array([3, 0, 9, None], pa.int32()),
            "recovered": pa.array([10, 12, 15, 18], pa.int32()),
        }
    )
    points = summarize(spec, table)["points"]
    assert [(p["mines_cleared_mean"], p["recovered_mean"]) for p in points] == [(1.5, 11.0), (9.0, 16.5)]
    rows = study_rows({"points": points})
    assert column(rows, "mean mines cleared") == ["1.50", "9.00"]
    assert column(rows, "mean back at sea") == ["11.00", "16.50"]
    older = summarize(spec, pa.table({"point": table["point"], "run": table["run"], **base}))["points"]
    assert older[0]["mines_cleared_mean"] is None and older[1]["recovered_mean"] is None
    # a mission that clears nothing and brings nobody back has no such columns
    header = study_rows(
        {"points": [{**p, "mines_cleared_mean": 0.0, "recovered_mean": None} for p in points]}
    )[0]
    assert "mean mines cleared" not in header and "mean back at sea" not in header


def test_the_points_set_the_stations_taken_over_beside_the_plan_s() -> None:
    """The summary's per-point mean of the table's station takeovers with its interval (Garwood's
    where every run took as many), the plan's beside it with its verdict; no columns where no point
    has any, nor from a table written before they were counted."""
    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(str(ROOT / "missions" / "relay.yaml"), 3, parse_sweeps(["swarm.count=12,16"]), seed=1)
    base = {"success": [True] * 6, "losses": [[]] * 6, "completed_s": [1.0] * 6}
    table = pa.table(
        {
            "point": pa.array([0, 0, 0, 1, 1, 1], pa.int32()),
            "run": pa.array([0, 1, 2, 0, 1, 2], pa.int32()),
            **base,
            "takeovers": pa.array([2, 4, 3, 5, 5, 5], pa.int32()),
            "planned_takeovers": pa.array([3.2] * 3 + [1.0] * 3, pa.float64()),
        }
    )
    points = summarize(spec, table)["points"]
    t = stats.t.ppf(0.975, 2) * 1.0 / math.sqrt(3)  # the first point's sd is 1
    assert points[0]["takeovers_mean"] == 3.0
    assert points[0]["takeovers_interval"] == pytest.approx([3.0 - t, 3.0 + t])
    # every run took 5: Garwood's interval of 15 over 3 runs
    low, high = stats.chi2.ppf(0.025, 30) / 6, stats.chi2.ppf(0.975, 32) / 6
    assert points[1]["takeovers_interval"] == pytest.approx([low, high])
    rows = study_rows({"points": points})
    assert column(rows, "plan's takeovers") == ["3.20 (agrees)", "1.00 (optimistic)"]
    assert column(rows, "stations taken over")[0].startswith("3.00 ± ")
    older = summarize(spec, pa.table({"point": table["point"], "run": table["run"], **base}))["points"]
    assert older[0]["takeovers_mean"] is None and older[0]["planned_takeovers"] is None
    assert "stations taken over" not in study_rows({"points": older})[0]
    assert "stations taken over as the robots lost" in points_note({"points": points})
    assert "stations taken over" not in points_note({"points": older})


def test_the_points_set_the_mines_found_beside_the_plan_s_expectation() -> None:
    """The summary's per-point mean of `value_detection` (the runs' share of the mines found) and
    its plan's `planned_detection`, and the report's columns for them, as percentages, only where
    a point has a search; a table written before the plan's column existed has no plan's value."""
    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(
        str(ROOT / "missions" / "mine_clear.yaml"), 2, parse_sweeps(["swarm.count=12,24"]), seed=1
    )
    base = {
        "point": pa.array([0, 0, 1, 1], pa.int32()),
        "run": pa.array([0, 1, 0, 1], pa.int32()),
        "success": [False, True, True, True],
        "losses": [[]] * 4,
        "completed_s": [None, 2.0, 1.0, 3.0],
        "value_detection": [0.80, 0.90, 0.95, None],  # the last run's mission ended before any count
    }
    table = pa.table({**base, "planned_detection": [0.829, 0.829, 0.948, 0.948]})
    points = summarize(spec, table)["points"]
    assert [p["detection_mean"] for p in points] == [pytest.approx(0.85), pytest.approx(0.95)]
    assert [p["planned_detection"] for p in points] == [0.829, 0.948]
    rows = study_rows({"points": points})
    # two runs: t(0.975, 1) = 12.706 times 0.05 is a wide interval; one run: none
    assert column(rows, "mean detection") == ["85.0% ± 63.5", "95.0%"]
    assert column(rows, "plan's detection") == ["82.9% (agrees)", "94.8%"]
    older = summarize(spec, pa.table(base))["points"]
    assert [p["planned_detection"] for p in older] == [None, None]
    no_search = [{**p, "detection_mean": None, "planned_detection": None} for p in points]
    assert "mean detection" not in study_rows({"points": no_search})[0]


def test_the_points_say_whether_the_plan_agrees_with_its_runs() -> None:
    """Each point's mean losses and detection carry the half-width of their 95% Student t interval,
    and the plan's expectation says whether it lies inside (agrees), promises better than the runs
    give (optimistic) or worse (conservative). Four runs: t(0.975, 3) = 3.1824 (a t table)."""
    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(
        str(ROOT / "missions" / "mine_clear.yaml"), 4, parse_sweeps(["swarm.count=12,24"]), seed=1
    )
    loss = {"cause": "failure", "phase": "beach"}
    lost = [2, 3, 4, 3, 5, 5, 5, 5]
    table = pa.table(
        {
            "point": pa.array([0] * 4 + [1] * 4, pa.int32()),
            "run": pa.array([0, 1, 2, 3] * 2, pa.int32()),
            "success": [True] * 8,
            "losses": [[loss] * k for k in lost],
            "completed_s": [1.0] * 8,
            "value_detection": [0.80, 0.90, 0.85, 0.85, 0.90, 1.00, 0.95, 0.95],
            "planned_lost": [1.5] * 4 + [5.0] * 4,
            "planned_detection": [0.95] * 4 + [0.70] * 4,
        }
    )
    points = summarize(spec, table)["points"]
    # losses 2, 3, 4, 3: mean 3, s.d. sqrt(2/3), half-width 3.1824 * 0.8165 / 2 = 1.299
    assert points[0]["lost_interval"] == pytest.approx([3 - 1.2992, 3 + 1.2992], abs=1e-4)
    # every run lost 5: no spread for a t interval; Garwood's exact Poisson limits of a count of 20
    # (12.217 to 30.888, a Poisson table) over 4 runs
    assert points[1]["lost_interval"] == pytest.approx([12.217 / 4, 30.888 / 4], abs=1e-3)
    # detection 0.80, 0.90, 0.85, 0.85: s.d. 0.040825, half-width 3.1824 * 0.020412 = 0.06496
    assert points[0]["detection_interval"] == pytest.approx([0.85 - 0.06496, 0.85 + 0.06496], abs=1e-5)
    # 0.90, 1.00, 0.95, 0.95: the same spread about 0.95, cut at 100%; the cell shows the wider side
    assert points[1]["detection_interval"] == pytest.approx([0.95 - 0.06496, 1.0], abs=1e-5)
    rows = study_rows({"points": points})
    assert column(rows, "mean lost per run") == ["3.00 ± 1.30", "5.00 ± 2.72"]
    # the plan expects 1.5 lost where the runs lose 1.7 to 4.3: it promises too few
    assert column(rows, "plan's expected losses") == ["1.50 (optimistic)", "5.00 (agrees)"]
    assert column(rows, "mean detection") == ["85.0% ± 6.5", "95.0% ± 6.5"]
    assert column(rows, "plan's detection") == ["95.0% (optimistic)", "70.0% (conservative)"]
    # a summary from before the intervals: the bare numbers
    bare = [{k: v for k, v in p.items() if not k.endswith("_interval")} for p in points]
    assert column(study_rows({"points": bare}), "plan's expected losses") == ["1.50", "5.00"]


def test_each_cause_s_losses_are_held_against_the_plan_s(tmp_path) -> None:
    """`summarize` gives each cause's robots lost a run with its interval beside the plan's
    `planned_lost_<cause>`, worked by hand: a t interval where the runs differ, Garwood's where
    they all lost as many; a cause neither the runs nor the plan have is left out; the cause table
    reads them as the points table reads the total, a pair of columns a point."""
    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(
        str(ROOT / "missions" / "mine_clear.yaml"), 4, parse_sweeps(["swarm.count=12,24"]), seed=1
    )
    failure, mine = [3, 4, 5, 4, 1, 1, 1, 1], [0, 1, 0, 0, 0, 0, 0, 0]
    columns = {f"lost_{c}": [0] * 8 for c in CAUSES} | {f"planned_lost_{c}": [0.0] * 8 for c in CAUSES}
    columns["lost_failure"], columns["lost_mine"] = failure, mine
    columns["planned_lost_failure"] = [6.0] * 4 + [1.2] * 4
    columns["planned_lost_mine"] = [0.3] * 4 + [0.0] * 4
    columns["planned_lost_rock"] = [0.5] * 4 + [2.5] * 4
    losses = [
        [{"cause": "failure", "phase": "beach"}] * f + [{"cause": "mine", "phase": "beach"}] * m
        for f, m in zip(failure, mine, strict=True)
    ]
    table = pa.table(
        {
            "point": pa.array([0] * 4 + [1] * 4, pa.int32()),
            "run": pa.array([0, 1, 2, 3] * 2, pa.int32()),
            "success": [True] * 8,
            "losses": losses,
            "completed_s": [1.0] * 8,
            **columns,
        }
    )
    points = summarize(spec, table)["points"]
    first = {c["cause"]: c for c in points[0]["lost_by_cause"]}
    second = {c["cause"]: c for c in points[1]["lost_by_cause"]}
    assert list(first) == ["failure", "rock", "mine"] and list(second) == ["failure", "rock"]
    # failures 3, 4, 5, 4: mean 4, s.d. sqrt(2/3), half-width 3.1824 * 0.8165 / 2 = 1.299
    assert first["failure"]["mean"] == 4.0
    assert first["failure"]["interval"] == pytest.approx([4 - 1.2992, 4 + 1.2992], abs=1e-4)
    # no rock in 4 runs: Garwood's upper limit of a count of 0, chi2(0.975, 2) / 2 = 3.689, over 4
    assert first["rock"]["interval"] == pytest.approx([0.0, 3.689 / 4], abs=1e-3)
    # every run lost 1 to failure: Garwood's limits of a count of 4 (1.090 to 10.242) over 4 runs
    assert second["failure"]["interval"] == pytest.approx([1.090 / 4, 10.242 / 4], abs=1e-3)
    assert (first["mine"]["mean"], first["mine"]["planned"]) == (0.25, 0.3)
    rows = cause_rows({"points": points})
    assert rows[0] == ["cause", "swarm.count = 12: runs", "swarm.count = 12: plan", "swarm.count = 24: runs",
                       "swarm.count = 24: plan"]  # fmt: skip
    by_cause = {r[0]: r[1:] for r in rows[1:]}
    # 6.0 above 2.70 to 5.30: more lost than the runs give; 1.2 inside 0.27 to 2.56
    assert by_cause["failure"] == ["4.00 ± 1.30", "6.00 (conservative)", "1.00 ± 1.56", "1.20 (agrees)"]
    # 2.5 rocks a run where 4 runs lost none (at most 0.92): conservative; 0.5 agrees
    assert by_cause["rock"][1] == "0.50 (agrees)" and by_cause["rock"][3] == "2.50 (conservative)"
    # a point without the cause shows its zeros
    assert by_cause["mine"][2:] == ["0.00", "0.00"]
    one = cause_rows({"points": points[:1]})
    assert one[0] == ["cause", "runs: lost per run", "plan's expectation"]
    # a sweep's point without a plan by cause (hazards off there) leaves the others named
    off = {**points[1], "lost_by_cause": []}
    named = ["cause", "swarm.count = 12: runs", "swarm.count = 12: plan"]
    assert cause_rows({"points": [points[0], off]})[0] == named
    # a table from before the plan's losses by cause: no cause table, no figure
    older = summarize(spec, table.drop([f"planned_lost_{c}" for c in CAUSES]))["points"]
    assert [p["lost_by_cause"] for p in older] == [[], []]
    assert cause_rows({"points": older}) == [] and figs.causes_png({"points": older}) is None
    png = figs.causes_png({"confidence": 0.95, "points": points})
    assert png is not None and Image.open(io.BytesIO(png)).size[0] > 400


def test_the_plan_against_its_runs_is_drawn_only_where_the_plan_says_something() -> None:
    """One panel per quantity the plan expects (mines found with a search, robots lost with
    hazards), none without either; the same summary gives the same bytes."""
    base = {"runs": 8, "successes": 8, "success_rate": 1.0, "wilson_low": 0.7, "wilson_high": 1.0}
    points = [
        {
            **base,
            "index": i,
            "params": {KEY: count},
            "lost_mean": 0.2 * count,
            "lost_interval": [0.2 * count - 1.0, 0.2 * count + 1.0],
            "planned_lost": 0.2 * count + 0.5,
            "detection_mean": 0.9,
            "detection_interval": [0.88, 0.92],
            "planned_detection": 0.93,
        }
        for i, count in enumerate(COUNTS)
    ]
    summary = {"confidence": 0.95, "sweeps": {KEY: list(COUNTS)}, "points": points}
    both = figs.agreement_png(summary)
    assert both is not None and figs.agreement_png(summary) == both
    no_search = [{**p, "detection_mean": None, "planned_detection": None} for p in points]
    losses_only = figs.agreement_png({**summary, "points": no_search})
    assert losses_only is not None
    # two panels are wider than one
    assert Image.open(io.BytesIO(both)).width > 1.5 * Image.open(io.BytesIO(losses_only)).width
    # a table from before the plan's columns, or a mission with nothing to expect: no figure
    bare = [{k: v for k, v in p.items() if not k.startswith("planned")} for p in points]
    assert figs.agreement_png({**summary, "points": bare}) is None


def test_one_point_s_answer_says_whether_its_runs_show_the_target() -> None:
    """mine_clear's 64 runs all succeeded and the report said not met, with no word of why: a
    Wilson lower bound of 0.943 cannot reach 0.95 from 64 runs. The answer says what the runs
    show: reached, not yet shown (with the runs that would show it at the rate seen: n / (n + z^2)
    >= 0.95 first at 73 when every run succeeds), or short with a rate more runs will not lift."""
    from swarm.studies.stats import wilson_interval

    def one(successes: int, runs: int) -> dict:
        lo, hi = wilson_interval(successes, runs)
        point = {"runs": runs, "successes": successes, "success_rate": successes / runs}
        return {
            "mission": "m",
            "target": 0.95,
            "confidence": 0.95,
            "points": [point | {"wilson_low": lo, "wilson_high": hi}],
        }

    assert answer(one(64, 64)).endswith(
        ": not yet shown to reach 0.95 at 95% confidence; about 73 runs would show it at the rate seen"
    )
    z2 = 1.959963984540054**2
    assert 72 / (72 + z2) < 0.95 <= 73 / (73 + z2)  # the closed form of the all-success bound
    assert answer(one(73, 73)).endswith(": reaches 0.95 at 95% confidence")
    assert answer(one(93, 100)).endswith(
        ": short of 0.95 at 95% confidence, and more runs will not lift a rate of 0.930"
    )


def test_the_points_set_the_runs_success_beside_the_plan_s_chance_of_it() -> None:
    """The summary's per-point `planned_success` (the plan's chance that a run meets its criteria)
    against the runs' Wilson interval, in its own column only where some point's plan gives one,
    and the plan's own answer to the study's question beside the runs' answer. 24 successes in 32
    runs: Wilson's 95% interval is (p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n) =
    0.5789 to 0.8675 (z = 1.95996), so a plan of 0.59 agrees and one of 0.90 is optimistic; 31 of 32:
    0.8426 to 0.9945, and a plan of 0.78 is conservative."""
    from swarm.studies.study import StudySpec, summarize
    from swarm.studies.sweep import parse_sweeps

    spec = StudySpec(
        str(ROOT / "missions" / "mine_clear.yaml"),
        32,
        parse_sweeps(["swarm.count=12,18"]),
        seed=1,
        target=0.9,
    )

    def table(chances: tuple[float | None, float | None]) -> pa.Table:
        return pa.table(
            {
                "point": pa.array([0] * 32 + [1] * 32, pa.int32()),
                "run": pa.array(list(range(32)) * 2, pa.int32()),
                "success": [k < 24 for k in range(32)] + [k < 31 for k in range(32)],
                "losses": [[]] * 64,
                "completed_s": [1.0] * 64,
                "planned_success": [chances[0]] * 32 + [chances[1]] * 32,
            }
        )

    summary = summarize(spec, table((0.59, 0.78)))
    points = summary["points"]
    assert [p["planned_success"] for p in points] == [0.59, 0.78]
    assert [p["wilson_low"] for p in points] == pytest.approx([0.5789, 0.8426], abs=1e-4)
    rows = study_rows(summary)
    assert column(rows, "plan's P(success)") == ["0.590 (agrees)", "0.780 (conservative)"]
    assert column(study_rows(summarize(spec, table((0.90, 0.99)))), "plan's P(success)") == [
        "0.900 (optimistic)",
        "0.990 (agrees)",
    ]
    # the plan's answer: no swept size reaches 0.9 by the plan (0.78 at 18)
    assert summary["required"]["planned"] == {"value": None, "chances": [[12, 0.59], [18, 0.78]]}
    said = answer(summary)
    assert said.endswith("; no swept plan expects P(success) >= 0.9 (the best, 18 robots, expects 0.780)")
    reached = summarize(spec, table((0.59, 0.95)))
    assert reached["required"]["planned"]["value"] == 18
    assert answer(reached).endswith("; the plan expects P(success) >= 0.9 from 18 robots")
    # a plan that gives no chance (a mission judged by a criterion it cannot give one for), or a
    # table written before the column: no column, no plan's answer
    none = summarize(spec, table((None, None)))
    assert [p["planned_success"] for p in none["points"]] == [None, None]
    assert "plan's P(success)" not in study_rows(none)[0]
    assert "Wilson interval alike" in points_note(summary) and "Wilson" not in points_note(none)
    assert none["required"]["planned"] is None and "plan" not in answer(none)
    older = summarize(spec, table((0.5, 0.5)).drop(["planned_success"]))
    assert [p["planned_success"] for p in older["points"]] == [None, None]
    # drawn beside the runs' rates: the figure changes with the plan's chances
    assert figs.success_png(summary) != figs.success_png(none)
