"""`swarm report` and the reports behind it: each of the four kinds (plan, simulation, study, model
validation) made by its own command on small inputs, rebuilt from its files on disk, and the key
numbers parsed out of the HTML, the Markdown and the JSON of one report found to agree with each
other and with the files the report was made from."""

from __future__ import annotations

import base64
import contextlib
import io
import json
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
import yaml
from PIL import Image

from swarm.cli import main
from swarm.errors import InputError
from swarm.report import build_report
from swarm.report.document import seconds
from swarm.report.load import detect
from swarm.report.sim_report import format_value

#: End-to-end: real reports, folders and processes (deselect with -m "not slow"); one core builds the
#: module's folders once (`scripts/test`'s loadgroup: split over two cores, each built them all).
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("report_formats")]


REPO = Path(__file__).resolve().parents[2]
RUNS = REPO / "swarm" / "data" / "robot-runs"
DATE = "2025-01-02"
KINDS = ("plan", "simulation", "study", "validation")

#: Landing, relay (a weak radio: relays needed) and search with mines on maps/test_small; robots by
#: hand 20 m offshore, short phases, frequent failures so some robots are lost: seconds to simulate.
MISSION = {
    "name": "mixed",
    "map": str(REPO / "maps" / "test_small.yaml"),
    "planner": str(REPO / "planners" / "fast.yaml"),
    "swarm": {"count": 7},
    "launch": {"platform": "by_hand", "points": ["launch_1", "launch_2"], "offshore_m": 20, "interval_s": 2},
    "phases": {
        "sea_transit": {"time_limit_s": 150},
        "surf_crossing": {"time_limit_s": 60},
        "beach_operations": {"time_limit_s": 90},
        "return_to_sea": {"enabled": False},
    },
    "tasks": [
        {"type": "landing", "zones": ["landing_a"], "robots_per_zone": 1},
        {
            "type": "relay",
            "source": "relay_source",
            "sinks": ["relay_sink"],
            "radio": {"tx_power_dbm": -10.0, "source_antenna_height_m": 0.5},  # relays needed
        },
        {"type": "search", "area": "search_beach", "sensor": {"sweep_width_m": 6.0}, "robots": 2},
    ],
    "success": {"min_landing_fraction": 1.0, "min_detection_fraction": 0.5},
    "hazards": {"mines": {"count": 4}, "attrition": {"mtbf_h": 0.1}},
}
#: One landing zone, three robots: about a second a run (tests/studies/test_study.py).
STUDY_MISSION = {
    **{k: MISSION[k] for k in ("map", "planner", "phases")},
    "name": "tinystudy",
    "swarm": {"count": 3},
    "launch": {"platform": "by_hand", "points": ["launch_1"], "offshore_m": 20, "interval_s": 0},
    "tasks": [{"type": "landing", "zones": ["landing_a"], "robots_per_zone": 2}],
    "hazards": {
        "surf": {"damage_h50_m": 10.0},
        "immobilization": {"per_km": 0.0},
        "rocks": {"damage_per_km": 0.0, "collision_damage_probability": 0.0},
        "attrition": {"mtbf_h": 0.05},
    },
}


def run(*args: object) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def folders(tmp_path_factory) -> dict[str, Path]:
    """One folder of each kind, written by its own command."""
    base = tmp_path_factory.mktemp("reports")
    mission = base / "mixed.yaml"
    mission.write_text(yaml.safe_dump(MISSION, sort_keys=False))
    study = base / "tinystudy.yaml"
    study.write_text(yaml.safe_dump(STUDY_MISSION, sort_keys=False))
    out = {kind: base / kind for kind in KINDS}
    commands = {
        "plan": ["plan", mission, "--seed", 1, "--workers", 1, "--out", out["plan"]],
        "simulation": ["simulate", mission, "--seed", 1, "--workers", 1, "--out", out["simulation"]],
        "study": ["study", study, "--runs", 3, "--sweep", "swarm.count=2,3", "--workers", 2, "--target",
                  0.5, "--out", out["study"]],
        "validation": ["model", "validate", "--robot", REPO / "swarm/data/robots/skid4.yaml", "--encoders",
                       RUNS / "concrete_square_encoders.txt", "--truth", RUNS / "concrete_square_truth.txt",
                       "--terrain", REPO / "swarm/data/terrain/skid4-concrete.yaml", "--compare", "--out",
                       out["validation"]],
    }  # fmt: skip
    for kind, args in commands.items():
        code, _, err = run(*args)
        assert code == 0, (kind, err)
    return out


@pytest.fixture(scope="module")
def reports(folders):
    """Each kind's report rebuilt from its folder, with a fixed date."""
    return {kind: build_report(folders[kind], date=DATE) for kind in KINDS}


# --- parsing the three formats ----------------------------------------------------------------------------
class Page(HTMLParser):
    """Tables by the heading above them, the verdict, images, and what a phone needs of the page."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, list[list[str]]] = {}
        self.verdict = ""
        self.images: list[dict[str, str]] = []
        self.meta: list[dict[str, str]] = []
        self.tags: set[str] = set()
        self.unwrapped_tables = 0
        self._heading: str | None = None
        self._text: list[str] | None = None
        self._in_verdict = False
        self._cell: list[str] | None = None
        self._stack: list[tuple[str, str]] = []

    def handle_starttag(self, tag: str, attrs: list) -> None:
        a = {k: v or "" for k, v in attrs}
        self.tags.add(tag)
        if tag not in ("img", "meta", "br"):
            self._stack.append((tag, a.get("class", "")))
        if tag in ("h1", "h2"):
            self._text = []
        elif tag == "p" and "verdict" in a.get("class", ""):
            self._in_verdict = True
        elif tag == "table":
            if not any(t == "div" and "table-wrap" in c for t, c in self._stack[:-1]):
                self.unwrapped_tables += 1
            self.tables[self._heading or "?"] = []
        elif tag == "tr":
            self.tables[self._heading or "?"].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "img":
            self.images.append(a)
        elif tag == "meta":
            self.meta.append(a)

    def handle_endtag(self, tag: str) -> None:
        while self._stack and self._stack.pop()[0] != tag:
            pass
        if tag in ("h1", "h2") and self._text is not None:
            self._heading = "".join(self._text).strip()
            self._text = None
        elif tag == "p":
            self._in_verdict = False
        elif tag in ("td", "th") and self._cell is not None:
            self.tables[self._heading or "?"][-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._text is not None:
            self._text.append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._in_verdict:
            self.verdict += data


def parse_html(page: str) -> Page:
    p = Page()
    p.feed(page)
    return p


def parse_markdown(text: str) -> tuple[dict[str, list[list[str]]], str]:
    """Tables by the `## heading` above them (Markdown's empty header row of a key-value table
    dropped), and the bold verdict line."""
    tables: dict[str, list[list[str]]] = {}
    heading, verdict = None, ""
    for line in text.splitlines():
        if line.startswith("## "):
            heading = line[3:].strip()
        elif line.startswith("**") and line.endswith("**") and not verdict:
            verdict = line[2:-2]
        elif line.startswith("|") and not line.startswith("|---"):
            cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            rows = tables.setdefault(heading or "?", [])
            if rows or any(cells):
                rows.append(cells)
    return tables, verdict


def column(rows: list[list[str]], name: str) -> list[str]:
    j = rows[0].index(name)
    return [r[j] for r in rows[1:]]


def pairs(rows: list[list[str]]) -> dict[str, str]:
    return {r[0]: r[1] for r in rows}


@pytest.fixture(scope="module")
def parsed(reports):
    """kind: (HTML page, Markdown tables and verdict, JSON) of each report, as a reader would get them."""
    out = {}
    for kind, report in reports.items():
        md_tables, md_verdict = parse_markdown(report.markdown())
        out[kind] = (parse_html(report.html()), md_tables, md_verdict, json.loads(report.json()))
    return out


# --- the kinds and the files -------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", KINDS)
def test_each_kind_is_detected_from_its_folder_or_a_file_in_it(folders, reports, kind):
    folder = folders[kind]
    assert detect(folder) == (kind, folder)
    first = {"plan": "plan.json", "simulation": "outcome.json", "study": "summary.json"}
    name = first.get(kind, "validation.json")
    assert detect(folder / name) == (kind, folder)
    assert reports[kind].kind == kind
    for fmt in ("html", "md", "json"):  # every command writes all three through the same code
        assert (folder / f"report.{fmt}").is_file()
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]  # no temporary files


@pytest.mark.parametrize("kind", KINDS)
def test_the_command_and_swarm_report_write_the_same_report(folders, kind):
    """The command's own report.json is what `build_report` rebuilds from the files on disk."""
    written = json.loads((folders[kind] / "report.json").read_text())
    again = json.loads(build_report(folders[kind], date=written["header"]["date"]).json())
    assert again == written


@pytest.mark.parametrize("kind", KINDS)
def test_html_markdown_and_json_agree(parsed, kind):
    page, md_tables, md_verdict, data = parsed[kind]
    assert page.tables == md_tables  # every table, cell for cell
    assert page.verdict.strip() == md_verdict == data["verdict"]["text"]
    head = pairs(page.tables["Report"])
    assert head["report"] == kind == data["header"]["kind"]
    assert head["date"] == DATE == data["header"]["date"]
    for key in ("mission", "map", "seed"):
        value = data["header"][key]
        assert head[key] == ("-" if value is None else str(value))
    assert head["surf-swarm"] == data["header"]["version"]


def test_plan_numbers(parsed, folders):
    page, md, _, data = parsed["plan"]
    plan = json.loads((folders["plan"] / "plan.json").read_text())
    robots = md["Robots"]
    assert column(robots, "robot") == [r["id"] for r in data["robots"]] == [r["id"] for r in plan["robots"]]
    assert column(robots, "ETA (s)") == [f"{r['eta_s']:.0f}" for r in plan["robots"]]
    assert column(page.tables["Robots"], "role") == [r["role"] for r in plan["robots"]]
    # relay links: the margins plan.json records, one per edge, each closing
    links = md["Relay links"]
    margins = plan["relay"]["link_margins_db"]
    assert len(links) - 1 == len(plan["relay"]["edges"]) == len(margins) >= 2
    assert column(links, "margin (dB)") == [f"{m:.1f}" for m in margins]
    assert [x["margin_db"] for x in data["relay"]["links"]] == [round(m, 1) for m in margins]
    assert min(margins) >= 0
    (search,) = plan["search"]
    assert column(md["Search"], "expected detection") == [f"{search['expected_detection']:.1%}"]
    summary = pairs(page.tables["Plan summary"])
    assert summary["robots"] == str(len(plan["robots"])) == str(data["summary"]["robots"])
    # the verdict: detection after the expected losses against 0.5, and every relay link closing
    checks = {c["criterion"]: c for c in data["verdict"]["checks"]}
    after = plan["budget"]["search"]["search_1"]["expected_detection_after_losses"]
    assert checks["expected detection after losses (search_1)"]["target"] == 0.5
    assert checks["expected detection after losses (search_1)"]["value"] == pytest.approx(after)
    assert checks["least relay link margin (relay_1)"]["value"] == pytest.approx(min(margins), abs=0.05)
    rows = md["Criteria a plan can check"]
    assert column(rows, "met") == ["yes" if c["met"] else "NO" for c in data["verdict"]["checks"]]
    assert data["verdict"]["status"] == ("met" if all(c["met"] for c in checks.values()) else "not met")


def test_simulation_numbers(parsed, folders):
    page, md, md_verdict, data = parsed["simulation"]
    outcome = json.loads((folders["simulation"] / "outcome.json").read_text())
    assert md_verdict.startswith("SUCCESS" if outcome["success"] else "FAILED")
    crit = md["Criteria"]
    for name, c in outcome["criteria"].items():
        row = next(r for r in crit[1:] if r[0] == name)
        assert row[2:] == [
            format_value(name, c["value"]),
            format_value(name, c["target"]),
            "yes" if c["met"] else "NO",
        ]
        assert data["criteria"][name]["value"] == c["value"]
    assert outcome["lost"] > 0  # frequent failures: the loss tables are there
    assert pairs(page.tables["Run"])["robots lost"] == str(outcome["lost"]) == str(data["run"]["lost"])
    losses = md["Losses by cause and phase"]
    assert losses[-1][-1] == str(outcome["lost"])
    for cause, n in outcome["losses_by_cause"].items():
        assert next(r for r in losses if r[0] == cause)[-1] == str(n) == str(data["losses_by_cause"][cause])
    where = md["Where robots were lost"]
    assert len(where) - 1 == outcome["lost"] == len(data["losses"])
    assert sorted(column(where, "robot")) == sorted(x["robot"] for x in data["losses"])
    assert pairs(md["End states"][1:]) == {k: str(v) for k, v in outcome["end_states"].items()}
    mines = pairs(md["Mines"][1:])
    assert mines["in the field"] == str(outcome["mines"]) == str(data["mines"]["in_field"]) == "4"
    assert mines["detected"] == str(outcome["mines_detected"])
    assert mines["marked at the end"] == str(sum(outcome["mines_state"]["marked"]))
    spans = md["Relay connectivity spans"]
    assert len(spans) - 1 == len(data["relay"]["spans"]) >= 1
    phases = md["Mission phases"]
    assert column(phases, "phase")[0] == "sea_transit"
    assert column(phases, "first robot in it at (s)") == [seconds(p["start_s"]) for p in data["phases"]]


def test_study_numbers(parsed, folders):
    page, md, md_verdict, data = parsed["study"]
    summary = json.loads((folders["study"] / "summary.json").read_text())
    points = md["Parameter points"]
    assert points == page.tables["Parameter points"]
    assert column(points, "swarm.count") == ["2", "3"]
    assert column(points, "runs") == [str(p["runs"]) for p in summary["points"]] == ["3", "3"]
    assert column(points, "successes") == [str(p["successes"]) for p in data["points"]]
    assert column(points, "P(success)") == [f"{p['success_rate']:.3f}" for p in summary["points"]]
    lows = [v.split(" to ")[0] for v in column(points, "95% Wilson interval")]
    assert lows == [f"{p['wilson_low']:.3f}" for p in data["points"]]
    assert data["points"] == summary["points"]
    assert data["required"] == summary["required"]
    assert pairs(page.tables["Study"])["runs"].startswith(f"{summary['runs']} (2 points")
    if summary["required"] and summary["required"]["value"] is not None:
        assert f"needs {summary['required']['value']} robots" in md_verdict
        assert data["verdict"]["status"] == "met"
    else:
        assert data["verdict"]["status"] == "not met"


def test_validation_numbers(parsed, folders):
    page, md, md_verdict, data = parsed["validation"]
    saved = json.loads((folders["validation"] / "validation.json").read_text())
    by_model = {saved["model"]: saved, **{c["model"]: c for c in saved["compare"]}}
    scores = md["Scores"]
    assert column(scores, "model") == ["skid", "kinematic", "lagrangian"]
    for row in scores[1:]:
        s = by_model[row[0]]
        assert row[1:3] == [f"{s['path_rmse_m']:.3f}", f"{s['path_rmse_pct']:.2f}"]
        assert row[-1] == ("yes" if s["path_rmse_pct"] < 3.0 else "NO")
    assert [s["path_rmse_pct"] for s in data["scores"]] == [by_model[m]["path_rmse_pct"] for m in by_model]
    skid = by_model["skid"]
    assert skid["path_rmse_pct"] < 3.0  # the calibrated skid model on the concrete square
    assert md_verdict.startswith("MEETS the accuracy target: skid path RMSE")
    assert f"{skid['path_rmse_pct']:.2f}% of the" in md_verdict
    assert pairs(page.tables["Run"])["terrain mode"] == saved["validation"]["terrain"] == "concrete"
    assert data["verdict"]["status"] == "met"


# --- the page: self-contained, readable on a phone ---------------------------------------------------------
@pytest.mark.parametrize("kind", KINDS)
def test_html_is_self_contained_and_fits_a_phone(parsed, reports, kind):
    page, *_ = parsed[kind]
    text = reports[kind].html()
    assert {"name": "viewport", "content": "width=device-width, initial-scale=1"} in page.meta
    assert "script" not in page.tags and "link" not in page.tags and "iframe" not in page.tags
    assert not re.search(r"(src|href)\s*=\s*['\"]?(https?:|//)", text)
    assert "@import" not in text and "url(" not in text
    assert "img{display:block;max-width:100%;height:auto" in text
    assert ".table-wrap{overflow-x:auto" in text
    assert page.unwrapped_tables == 0 and page.tables
    expected = {"plan": 3, "simulation": 4, "study": 4, "validation": 2}[kind]
    assert len(page.images) >= expected
    for img in page.images:
        assert len(img["alt"]) > 20
        assert img["src"].startswith("data:image/png;base64,")
        png = Image.open(io.BytesIO(base64.b64decode(img["src"].split(",", 1)[1], validate=True)))
        png.load()
        assert png.format == "PNG" and (png.width, png.height) == (int(img["width"]), int(img["height"]))
        assert png.width >= 400


# --- swarm report ---------------------------------------------------------------------------------------
def test_swarm_report_writes_each_format(folders, tmp_path):
    import shutil

    folder = tmp_path / "sim"
    shutil.copytree(folders["simulation"], folder)
    for name in ("report.html", "report.md", "report.json"):
        (folder / name).unlink()
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    code, out, err = run("report", folder)
    assert code == 0, err
    assert out.strip() == str(folder / "report.html") and (folder / "report.html").is_file()
    assert not (folder / "report.md").exists()
    code, out, _ = run("report", folder / "events.jsonl", "--format", "md")
    assert code == 0 and out.strip() == str(folder / "report.md")
    assert (folder / "report.md").read_text().startswith("# Mission simulation: mixed on test_small")
    target = out_dir / "elsewhere.json"
    code, out, _ = run("report", folder, "-o", target)  # the format from the suffix
    assert code == 0 and out.strip() == str(target)
    assert json.loads(target.read_text())["header"]["kind"] == "simulation"
    code, out, _ = run("report", folder, "--format", "json", "-o", "-")
    assert code == 0
    assert json.loads(out) == json.loads(target.read_text())  # the whole of stdout is the report
    assert [p.name for p in out_dir.iterdir()] == ["elsewhere.json"]  # nothing else, no temporary file


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["{tmp}/nowhere"], "nothing there"),
        (["{tmp}/junk"], "junk"),
        (["{tmp}/junk/notes.txt"], "notes.txt"),
        (["{plan}", "--format", "pdf"], "--format"),
        (["{plan}", "-o", "{tmp}/missing/report.html"], "existing folder"),
        (["{plan}", "-o", "{tmp}"], "folder"),
        (["{plan}", "--format", "md", "-o", "{tmp}/r.json"], "--format md"),
    ],
)
def test_swarm_report_bad_input_is_one_line_exit_2(folders, tmp_path, args, needle):
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "notes.txt").write_text("hello")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    plan_before = sorted(p.name for p in folders["plan"].iterdir())
    code, out, err = run("report", *(a.format(tmp=tmp_path, plan=folders["plan"]) for a in args))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("swarm: error:") and needle in err, err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before
    assert sorted(p.name for p in folders["plan"].iterdir()) == plan_before


def test_damaged_files_are_input_errors(folders, tmp_path):
    import shutil

    sim = tmp_path / "sim"
    shutil.copytree(folders["simulation"], sim)
    (sim / "events.jsonl").write_text('{"t_s": 0, "kind": "mission_start"}\nnot json\n')
    with pytest.raises(InputError, match=r"events.jsonl: line 2"):
        build_report(sim)
    (sim / "trajectories.npz").unlink()
    with pytest.raises(InputError, match=r"trajectories\.npz"):
        build_report(sim)
    plan = tmp_path / "plan"
    shutil.copytree(folders["plan"], plan)
    (plan / "plan.json").write_text('{"mission": "x", "robots": [{"id": 1}]}')
    code, _, err = run("report", plan)
    assert code == 2 and err.count("\n") == 1 and "plan.json" in err


# --- foreign, cut and half-deleted result folders ---------------------------------------------------------
def _files(folder: Path) -> dict[str, bytes]:
    """Every file under `folder` and its bytes: what a failed report must leave as it found it."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _refused(folder: Path, message: str) -> None:
    """`swarm report` in each format: exit 2, `message` as the one line, the folder untouched."""
    before = _files(folder)
    assert {"report.html", "report.md", "report.json"} <= set(before)  # good reports to keep
    for fmt in ("html", "md", "json"):
        code, out, err = run("report", folder, "--format", fmt)
        assert (code, out, err) == (2, "", f"swarm: error: {message}\n")
    assert _files(folder) == before


@pytest.mark.parametrize("dropped", [None, "point", "success", "completed_s"])
def test_a_foreign_or_cut_results_table_is_one_line(folders, tmp_path, dropped):
    """A results.parquet swarm study did not write (None: a table of one column `a`), or one with a
    column the report needs dropped, is named with the columns found and the ones expected, not a
    KeyError from a figure or a silent report."""
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    study = tmp_path / "study"
    shutil.copytree(folders["study"], study)
    table = pq.read_table(study / "results.parquet")
    if dropped is None:
        table, missing = pa.table({"a": [1, 2]}), "point, success, completed_s, losses"
    else:
        table, missing = table.drop_columns([dropped]), dropped
    pq.write_table(table, study / "results.parquet")
    found = ", ".join(table.column_names[:8]) + (", ..." if table.num_columns > 8 else "")
    expected = f"the columns swarm study writes, including {missing}"
    _refused(study, f"{study / 'results.parquet'}: (columns): found 'columns {found}', expected {expected}")


def test_a_results_column_of_another_type_is_one_line(folders, tmp_path):
    """A needed column of another type than the one swarm study writes it with."""
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    study = tmp_path / "study"
    shutil.copytree(folders["study"], study)
    path = study / "results.parquet"
    table = pq.read_table(path)
    at = table.schema.get_field_index("point")
    pq.write_table(table.set_column(at, "point", table["point"].cast(pa.string())), path)
    _refused(study, f"{path}: column point: found 'string', expected int32, as swarm study writes it")


@pytest.mark.parametrize(("rows", "found"), [(0, "0 rows"), (1, "1 row")])
def test_a_results_table_without_the_summary_s_runs_is_one_line(folders, tmp_path, rows, found):
    """A table cut short (or emptied) while summary.json says runs were made: both numbers."""
    import shutil

    import pyarrow.parquet as pq

    study = tmp_path / "study"
    shutil.copytree(folders["study"], study)
    path = study / "results.parquet"
    table = pq.read_table(path)
    assert json.loads((study / "summary.json").read_text())["runs"] == table.num_rows == 6
    pq.write_table(table.slice(0, rows), path)
    _refused(study, f"{path}: (rows): found {found!r}, expected one per run: the 6 runs summary.json counts")


@pytest.mark.parametrize(
    ("edit", "where", "found", "expected"),
    [
        (lambda s: {}, "mission", "nothing",
         "the required key 'mission': The mission's name, for the report's title"),
        (lambda s: {k: v for k, v in s.items() if k != "runs"}, "runs", "nothing",
         "the required key 'runs': Runs made, one row of results.parquet each"),
        (lambda s: s | {"points": []}, "points", [], "a list of at least 1 item"),
    ],
    ids=["empty", "no runs", "no points"],
)  # fmt: skip
def test_a_summary_without_its_required_keys_is_one_line(folders, tmp_path, edit, where, found, expected):
    """summary.json `{}` (or without runs or points) is not a report of 'unknown on unknown, 0 runs'."""
    import shutil

    study = tmp_path / "study"
    shutil.copytree(folders["study"], study)
    path = study / "summary.json"
    path.write_text(json.dumps(edit(json.loads(path.read_text()))))
    _refused(study, f"{path}: {where}: found {found!r}, expected {expected}")


@pytest.mark.parametrize("kept", [("trajectories.npz", "events.jsonl"), ("events.jsonl",)])
def test_a_simulation_without_outcome_json_is_not_a_plan(folders, tmp_path, kept):
    """A simulation folder whose outcome.json is gone still holds plan.json: it must not be reported
    (and its report.html overwritten) as a plan."""
    import shutil

    sim = tmp_path / "sim"
    shutil.copytree(folders["simulation"], sim)
    for name in ("outcome.json", "trajectories.npz", "events.jsonl"):
        if name not in kept:
            (sim / name).unlink()
    assert (sim / "plan.json").is_file()
    found = f"{', '.join(kept)} without outcome.json"
    message = f"{sim}: (simulation): found {found!r}, expected a whole simulation log"
    with pytest.raises(InputError) as err:
        detect(sim / kept[0])
    assert str(err.value) == message
    _refused(sim, message)


def test_times_print_in_whole_seconds_a_half_rounded_up() -> None:
    """The simulator's clock runs in half seconds: half-to-even printed 1026.5 as 1026 and
    1027.5 as 1028 in the same table."""
    from swarm.report.sim_report import where_lost_table

    assert [seconds(v) for v in (1026.5, 1027.5, 1026.49, 0.0)] == ["1027", "1028", "1026", "0"]
    loss = {"robot": "robot_0", "cause": "failure", "phase": "beach", "x_m": 1.0, "y_m": 2.0}
    rows = where_lost_table({"losses": [{**loss, "t_s": 1026.5}, {**loss, "t_s": 1027.5}]})
    assert [r[3] for r in rows[1:]] == ["1027", "1028"]
