"""Every kind of report in headless Chromium (Debian's `chromium`, installed by `.ci/run`): the page loads
with no console errors, every image decodes, and a full-page screenshot is taken at a laptop and a phone
width into reports/screenshots/ (ignored by git) for a person to look at. A deliberately broken page
proves the detector sees what it should. Missing Chromium fails the tests; nothing is skipped."""

from __future__ import annotations

import base64
import io
import json
import shutil
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path

import pytest
import yaml
from chromium_harness import MISSING, Chromium, PageResult
from PIL import Image, ImageStat

from swarm.cli import main

#: End-to-end: real reports, folders and processes (deselect with -m "not slow").
#: One core makes each kind's report once and keeps one Chromium (`scripts/test`'s loadgroup).
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("browser")]


ROOT = Path(__file__).resolve().parents[2]
SHOTS = ROOT / "reports" / "screenshots"
#: name: (CSS px wide, a phone?)
WIDTHS = {"laptop": (1280, False), "phone": (390, True)}
KINDS = ("plan", "simulation", "study", "validation")
DATA = ROOT / "swarm" / "data"


# --- the reports, each generated once -------------------------------------------------------------------
def _yaml(path: Path, mission: dict) -> Path:
    path.write_text(yaml.safe_dump(mission, sort_keys=False))
    return path


def _swarm(*args: object) -> None:
    code = main([str(a) for a in args])
    assert code == 0, f"swarm {' '.join(map(str, args))} exited {code}"


def _tiny_simulation(folder: Path) -> Path:
    """Four robots on maps/test_small, a landing and a search over four mines: a few seconds."""
    return _yaml(
        folder / "tiny.yaml",
        {
            "name": "tiny",
            "map": str(ROOT / "maps" / "test_small.yaml"),
            "planner": str(ROOT / "planners" / "fast.yaml"),
            "swarm": {"count": 4},
            "launch": {
                "platform": "small_craft",
                "points": ["launch_1", "launch_2"],
                "offshore_m": 20,
                "interval_s": 2,
            },
            "phases": {
                "sea_transit": {"time_limit_s": 150},
                "surf_crossing": {"time_limit_s": 60},
                "beach_operations": {"time_limit_s": 60},
                "return_to_sea": {"enabled": False},
            },
            "tasks": [
                {"type": "landing", "zones": ["landing_a"], "robots_per_zone": 2},
                {"type": "search", "area": "search_beach", "sensor": {"sweep_width_m": 6.0}, "robots": 2},
            ],
            "success": {"min_landing_fraction": 1.0, "min_detection_fraction": 0.5},
            "hazards": {"mines": {"count": 4}, "surf": {"wave_height_m": 0.6}},
        },
    )


def _tiny_study(folder: Path) -> Path:
    """Three robots by hand 20 m off maps/test_small, landing on one zone, some failing: a run a second."""
    return _yaml(
        folder / "tinystudy.yaml",
        {
            "name": "tinystudy",
            "map": str(ROOT / "maps" / "test_small.yaml"),
            "planner": str(ROOT / "planners" / "fast.yaml"),
            "swarm": {"count": 3},
            "launch": {"platform": "by_hand", "points": ["launch_1"], "offshore_m": 20, "interval_s": 0},
            "phases": {
                "sea_transit": {"time_limit_s": 300},
                "surf_crossing": {"time_limit_s": 300},
                "beach_operations": {"time_limit_s": 120},
                "return_to_sea": {"enabled": False},
            },
            "tasks": [{"type": "landing", "zones": ["landing_a"], "robots_per_zone": 2}],
            "hazards": {
                "surf": {"damage_h50_m": 10.0},
                "immobilization": {"per_km": 0.0},
                "rocks": {"damage_per_km": 0.0, "collision_damage_probability": 0.0},
                "attrition": {"mtbf_h": 0.05},
            },
        },
    )


def _make_report(kind: str, tmp: Path) -> Path:
    """Run the command that writes `kind`'s report into a fresh folder; the report's HTML file."""
    out = tmp / "out"
    if kind == "plan":
        _swarm("plan", ROOT / "missions" / "landing.yaml", "--out", out)
    elif kind == "simulation":
        _swarm("simulate", _tiny_simulation(tmp), "--out", out)
    elif kind == "study":
        _swarm(
            "study", _tiny_study(tmp), "--runs", 3, "--sweep", "swarm.count=2,3", "--workers", 2, "--out", out
        )
    elif kind == "validation":
        # the thesis's square on concrete, the shipped calibration (skid meets the target), every model
        run = DATA / "robot-runs" / "concrete_square"
        inputs = ["--robot", DATA / "robots" / "skid4.yaml", "--terrain"]
        inputs += [DATA / "terrain" / "skid4-concrete.yaml", "--encoders", f"{run}_encoders.txt"]
        inputs += ["--truth", f"{run}_truth.txt"]
        _swarm("model", "validate", *inputs, "--compare", "--out", out)
    else:
        raise AssertionError(f"no recipe for a {kind} report")
    html = out / "report.html"
    assert html.is_file(), f"swarm wrote no {html.name} for the {kind} report: {sorted(out.iterdir())}"
    return html


@pytest.fixture(scope="module", params=KINDS)
def report(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    return request.param, _make_report(request.param, tmp_path_factory.mktemp(request.param))


@pytest.fixture(scope="module")
def browser() -> Iterator[Chromium]:
    executable = shutil.which("chromium")
    if executable is None:
        pytest.fail(MISSING, pytrace=False)
    with Chromium(executable) as chromium:
        yield chromium


# --- checks ---------------------------------------------------------------------------------------------
class _ImgCounter(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.count = 0

    def handle_starttag(self, tag: str, attrs: list) -> None:
        self.count += tag == "img"


def img_tags(html: Path) -> int:
    counter = _ImgCounter()
    counter.feed(html.read_text(encoding="utf-8"))
    return counter.count


def check_page(page: PageResult, html: Path) -> None:
    """No console errors; as many images as <img> tags, all of them decoded."""
    assert page.console_errors == [], f"{html}: console errors at {page.width} px:\n" + "\n".join(
        page.console_errors
    )
    assert len(page.images) == img_tags(html), (
        f"{html}: the browser has {len(page.images)} images, the file {img_tags(html)} <img> tags"
    )
    broken = [(i["index"], i["alt"], i["src"], i["error"]) for i in page.broken_images]
    assert not broken, f"{html}: images that did not decode at {page.width} px: {broken}"


def check_screenshot(page: PageResult) -> None:
    """A PNG that decodes, as wide as the screen (a phone zooms out to it), and is not one flat colour."""
    png = page.screenshot
    assert png is not None and png.is_file(), f"no screenshot {png}"
    with Image.open(png) as image:
        image.load()
        rgb = image.convert("RGB")
    w, h = rgb.size
    screen_px = round(page.width * page.pixel_ratio)
    if page.mobile:
        assert abs(w - screen_px) <= 2 * page.pixel_ratio, f"{png}: {w} px wide, the phone is {screen_px}"
    else:
        assert w >= screen_px, f"{png}: {w} px wide, the window is {screen_px}"
    assert h >= 300, f"{png}: only {h} px tall"
    assert max(ImageStat.Stat(rgb).stddev) > 5.0, f"{png}: (nearly) a single colour"
    colours = rgb.getcolors(maxcolors=1 << 16)
    assert colours is None or len(colours) > 32, f"{png}: only {len(colours)} colours"


# --- tests ----------------------------------------------------------------------------------------------
def test_chromium_is_installed() -> None:
    assert shutil.which("chromium") is not None, MISSING


def _png_data_uri(size: tuple[int, int] = (40, 30)) -> str:
    buffer = io.BytesIO()
    Image.linear_gradient("L").resize(size).convert("RGB").save(buffer, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()


def test_the_detector_catches_errors_and_broken_images(browser: Chromium, tmp_path: Path) -> None:
    """A page that throws, logs an error, and shows a corrupt and a missing image, beside a clean one."""
    good = _png_data_uri()
    corrupt = good[:60]  # a PNG cut off after its header
    broken = tmp_path / "broken.html"
    broken.write_text(
        "<!doctype html><html><body><h1>broken</h1>"
        f"<img alt='good' src='{good}'><img alt='corrupt' src='{corrupt}'><img alt='missing' src='nope.png'>"
        "<script>console.log('just a log'); console.warn('just a warning');"
        "console.error('deliberate console error');</script>"
        "<script>throw new Error('deliberate uncaught error');</script></body></html>"
    )
    page = browser.load(broken, 800)
    errors = "\n".join(page.console_errors)
    assert "deliberate console error" in errors, errors
    assert "deliberate uncaught error" in errors, errors
    assert "ERR_FILE_NOT_FOUND" in errors and "nope.png" in errors, errors
    assert "just a log" not in errors and "just a warning" not in errors, errors
    assert len(page.console_errors) == 3, errors
    assert len(page.images) == img_tags(broken) == 3
    assert sorted(i["alt"] for i in page.broken_images) == ["corrupt", "missing"], page.images
    with pytest.raises(AssertionError, match="console errors"):
        check_page(page, broken)

    clean = tmp_path / "clean.html"
    clean.write_text(f"<!doctype html><html><body><p>fine</p><img alt='good' src='{good}'></body></html>")
    page = browser.load(clean, 800)
    check_page(page, clean)
    assert page.images[0]["naturalWidth"] == 40


@pytest.mark.parametrize("screen", list(WIDTHS))
def test_report_loads_cleanly_and_is_screenshotted(
    report: tuple[str, Path], screen: str, browser: Chromium
) -> None:
    kind, html = report
    width, mobile = WIDTHS[screen]
    png = SHOTS / f"{kind}-{width}.png"
    png.unlink(missing_ok=True)
    page = browser.load(html, width, mobile=mobile, screenshot=png)
    # what the page looked like, beside the screenshot, for whoever reviews it
    notes = {"report": str(html), "width": width, "mobile": mobile, "pixel_ratio": page.pixel_ratio}
    notes["layout"] = page.layout
    notes["images"] = [{k: v for k, v in i.items() if k != "src"} for i in page.images]
    notes["console_errors"] = page.console_errors
    png.with_suffix(".json").write_text(json.dumps(notes, indent=2) + "\n")
    check_page(page, html)
    assert page.images, f"{html}: a {kind} report with no figure"
    check_screenshot(page)


def test_swarm_report_rewrites_the_html(
    report: tuple[str, Path], browser: Chromium, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """`swarm report FOLDER --format html -o FILE` gives a page as clean as the command's own, with as many
    figures."""
    kind, html = report
    out = tmp_path / f"{kind}.html"
    _swarm("report", html.parent, "--format", "html", "-o", out)
    assert out.is_file(), f"swarm report {html.parent} wrote no {out}: {capsys.readouterr()}"
    page = browser.load(out, WIDTHS["laptop"][0])
    check_page(page, out)
    assert len(page.images) == img_tags(html), f"{out}: not the figures of {html}"
