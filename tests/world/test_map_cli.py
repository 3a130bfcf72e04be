"""`swarm map info|show|generate|import-dem`, and the map figure."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import types
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from shapely.geometry import LineString, Point, Polygon, box

matplotlib.use("Agg")

from swarm.cli import main
from swarm.world import BeachMap, Region, load_map, save_map

CLASSES = (
    "deep_water",
    "surf",
    "shallow_water",
    "wet_hard_sand",
    "soft_sand",
    "vegetation",
    "boulder",
    "driftwood",
)


def beach(rows: int = 40, cols: int = 60, cell: float = 1.0, origin=(0.0, 0.0), seed: int = 3) -> BeachMap:
    """A small synthetic beach: sea to the south, dunes to the north, a few obstacles."""
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:rows, 0:cols]
    x = origin[0] + (c + 0.5) * cell
    y = origin[1] + (r + 0.5) * cell
    width, height = cols * cell, rows * cell
    z = -3.0 + 8.0 * (y - origin[1]) / height + 0.5 * np.sin(2 * np.pi * 2 * (x - origin[0]) / width)
    edges = np.array([-2.0, -0.3, 0.0, 1.5, 3.0])
    terrain = np.searchsorted(edges, z, side="right").astype(np.int8)
    on_sand = terrain >= 3
    terrain[on_sand & (rng.random(terrain.shape) < 0.02)] = 6
    terrain[on_sand & (rng.random(terrain.shape) < 0.01)] = 7
    x0, y0 = origin
    regions = [
        Region("launch_1", "launch", Point(x0 + 0.2 * width, y0 + 0.05 * height)),
        Region(
            "landing_a",
            "landing_zone",
            box(x0 + 0.15 * width, y0 + 0.45 * height, x0 + 0.3 * width, y0 + 0.6 * height),
        ),
        Region(
            "search",
            "search_area",
            box(x0 + 0.35 * width, y0 + 0.5 * height, x0 + 0.8 * width, y0 + 0.85 * height),
            {"sensor": "metal"},
        ),
        Region(
            "mines",
            "keep_out",
            Polygon(
                [
                    (x0 + 0.5 * width, y0 + 0.55 * height),
                    (x0 + 0.6 * width, y0 + 0.55 * height),
                    (x0 + 0.55 * width, y0 + 0.7 * height),
                ]
            ),
        ),
        Region(
            "fence",
            "keep_out",
            LineString([(x0 + 0.05 * width, y0 + 0.95 * height), (x0 + 0.3 * width, y0 + 0.9 * height)]),
        ),
        Region("rally", "rally", Point(x0 + 0.9 * width, y0 + 0.9 * height)),
    ]
    return BeachMap(
        "cli_beach", cell, origin, CLASSES, terrain, z.astype(np.float32), {r.name: r for r in regions}
    )


@pytest.fixture()
def map_file(tmp_path) -> Path:
    path = tmp_path / "cli_beach.yaml"
    save_map(beach(), path)
    return path


def swarm(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = os.environ | {"MPLBACKEND": "Agg"}
    command = [sys.executable, "-m", "swarm.cli", *(str(a) for a in args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


# --- info ----------------------------------------------------------------------------------------------


def test_info_json_matches_the_arrays(map_file, capsys):
    assert main(["map", "info", str(map_file), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    with np.load(map_file.with_suffix(".npz")) as npz:
        terrain, z = npz["terrain"], npz["elevation_m"].astype(np.float64)
    rows, cols = terrain.shape
    assert (info["rows"], info["cols"]) == (rows, cols) == (40, 60)
    assert info["cell_m"] == 1.0
    assert info["origin_m"] == [0.0, 0.0]
    assert (info["width_m"], info["height_m"]) == (60.0, 40.0)
    assert info["bounds_m"] == [0.0, 0.0, 60.0, 40.0]
    assert info["terrain_classes"] == list(CLASSES)
    for i, name in enumerate(CLASSES):
        assert info["terrain_cells"][name] == int((terrain == i).sum())
        assert info["terrain_fractions"][name] == pytest.approx((terrain == i).mean(), abs=1e-12)
    assert sum(info["terrain_fractions"].values()) == pytest.approx(1.0)
    assert info["impassable_fraction"] == pytest.approx(np.isin(terrain, [6, 7]).mean(), abs=1e-12)
    assert info["impassable_fraction"] > 0
    assert info["elevation_min_m"] == pytest.approx(z.min(), abs=1e-6)
    assert info["elevation_max_m"] == pytest.approx(z.max(), abs=1e-6)
    d_dy, d_dx = np.gradient(z, 1.0)
    assert info["max_slope_deg"] == pytest.approx(
        math.degrees(math.atan(np.hypot(d_dx, d_dy).max())), rel=1e-9
    )
    regions = {r["name"]: r for r in info["regions"]}
    assert list(regions) == ["launch_1", "landing_a", "search", "mines", "fence", "rally"]
    assert regions["landing_a"]["kind"] == "landing_zone"
    assert regions["landing_a"]["area_m2"] == pytest.approx(9.0 * 6.0)
    assert regions["landing_a"]["position_m"] == pytest.approx([13.5, 21.0])
    assert regions["mines"]["area_m2"] == pytest.approx(0.5 * 6.0 * 6.0)
    assert regions["launch_1"] == {
        "name": "launch_1",
        "kind": "launch",
        "geometry": "Point",
        "area_m2": 0.0,
        "length_m": 0.0,
        "position_m": [12.0, 2.0],
    }
    assert regions["fence"]["length_m"] == pytest.approx(math.hypot(15.0, 2.0))
    assert info["file"] == str(map_file)


def test_info_table(map_file, capsys):
    assert main(["map", "info", str(map_file)]) == 0
    out = capsys.readouterr().out
    assert "map cli_beach" in out
    assert "60 x 40 cells" in out
    for name in CLASSES:
        assert name in out
    for name in ("launch_1", "landing_a", "landing_zone", "search_area", "rally"):
        assert name in out


# --- show and the figure ---------------------------------------------------------------------------------


@pytest.mark.slow
def test_show_writes_a_png_and_no_temp_files(map_file):
    import matplotlib.image as mpimg

    fig = map_file.parent / "FIG.png"
    result = swarm("map", "show", map_file, "-o", fig)
    assert result.returncode == 0, result.stderr
    assert str(fig) in result.stdout
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = mpimg.imread(fig)
    assert image.shape[1] > 800 and image.shape[0] > 500
    assert np.ptp(image[..., :3]) > 0
    assert sorted(p.name for p in map_file.parent.iterdir()) == ["FIG.png", "cli_beach.npz", "cli_beach.yaml"]


def test_long_thin_beach_figure_stays_wide_and_readable(tmp_path):
    import matplotlib.image as mpimg

    from swarm.report.map_figure import MAX_WIDTH_IN, figure_size, plot_map

    long_map = beach(rows=40, cols=200, cell=5.0, origin=(300.0, 50.0))  # 1 km x 200 m
    w, h = figure_size(long_map.width_m, long_map.height_m, legend_rows=2)
    assert w == MAX_WIDTH_IN
    assert 3.0 < h < 6.0  # the 200 m side still gets a few inches
    tall_w, tall_h = figure_size(200.0, 1000.0, legend_rows=2)
    assert tall_w < tall_h <= 12.0
    out = tmp_path / "long.png"
    plot_map(long_map, out, routes=[("r1", np.array([[400.0, 60.0], [700.0, 200.0], [1000.0, 220.0]]))])
    image = mpimg.imread(out)
    assert image.shape[1] > 3 * image.shape[0]
    assert image.shape[1] <= MAX_WIDTH_IN * 130 + 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.png"]


def test_plot_map_into_given_axes_with_routes():
    import matplotlib.pyplot as plt

    from swarm.report.map_figure import plot_map
    from swarm.report.style import ROUTE_COLOURS, TERRAIN_COLOURS

    b = beach()
    fig, ax = plt.subplots()
    route = np.array([[12.0, 2.0], [20.0, 20.0], [30.0, 30.0]])
    assert plot_map(b, None, ax=ax, routes=[("robot 0", route)]) is ax
    lines = [ln for ln in ax.get_lines() if ln.get_label() == "robot 0"]
    assert len(lines) == 1
    assert np.array_equal(lines[0].get_xydata(), route)
    assert matplotlib.colors.same_color(lines[0].get_color(), ROUTE_COLOURS[0])
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "robot 0" in labels and "landing zone" in labels
    assert any(t.startswith("soft sand ") for t in labels)
    assert ax.get_aspect() == 1.0
    assert ax.get_xlim() == (0.0, 60.0) and ax.get_ylim() == (0.0, 40.0)
    image = ax.get_images()[0]
    assert matplotlib.colors.same_color(image.cmap.colors[CLASSES.index("surf")], TERRAIN_COLOURS["surf"])
    plt.close(fig)


def test_terrain_palette_covers_every_bundled_mode_and_separates_neighbours_by_lightness():
    from matplotlib.colors import to_rgb

    from swarm.report.style import TERRAIN_COLOURS
    from swarm.robot.terrain import load_library

    assert set(load_library()) <= set(TERRAIN_COLOURS)

    def lightness(colour: str) -> float:
        rgb = np.array(to_rgb(colour))
        lin = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        return 116 * float(lin @ [0.2126, 0.7152, 0.0722]) ** (1 / 3) - 16

    # classes that touch on a beach differ by at least 10 in CIELAB lightness
    for a, b in [
        ("deep_water", "surf"),
        ("surf", "shallow_water"),
        ("shallow_water", "wet_hard_sand"),
        ("wet_hard_sand", "soft_sand"),
        ("soft_sand", "vegetation"),
        ("wet_hard_sand", "kelp_wrack"),
        ("soft_sand", "driftwood"),
        ("soft_sand", "boulder"),
        ("wet_hard_sand", "boulder"),
        ("vegetation", "driftwood"),
    ]:
        assert abs(lightness(TERRAIN_COLOURS[a]) - lightness(TERRAIN_COLOURS[b])) >= 10, (a, b)


# --- generate (wiring; the generator itself is tested with it) ----------------------------------------------


def test_generate_passes_options_and_saves(tmp_path, monkeypatch, capsys):
    calls = []

    def fake_generate_beach(**kwargs):
        calls.append(kwargs)
        b = beach(seed=kwargs.get("seed", 0))
        return BeachMap(
            kwargs["name"], b.cell_m, b.origin_m, b.terrain_classes, b.terrain, b.elevation_m, b.regions
        )

    fake = types.ModuleType("swarm.world.generate")
    fake.generate_beach = fake_generate_beach
    monkeypatch.setitem(sys.modules, "swarm.world.generate", fake)
    out = tmp_path / "gen.yaml"
    args = ["map", "generate", "--seed", "5", "--length-m", "300", "--width-m", "120", "--d50-mm", "0.3"]
    args += ["--breaker-height-m", "1.2", "--cell-m", "2", "-o", str(out)]
    assert main(args) == 0
    assert calls == [
        {
            "seed": 5,
            "length_m": 300.0,
            "width_m": 120.0,
            "d50_mm": 0.3,
            "breaker_height_m": 1.2,
            "cell_m": 2.0,
            "name": "gen",
        }
    ]
    stdout = capsys.readouterr().out
    assert str(out) in stdout and str(out.with_suffix(".npz")) in stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gen.npz", "gen.yaml"]
    loaded = load_map(out)
    assert loaded.name == "gen"
    assert np.array_equal(loaded.terrain, beach(seed=5).terrain)
    # options not given are left to the generator's defaults; --name wins over the file stem
    assert main(["map", "generate", "--name", "other", "-o", str(tmp_path / "g2.yaml")]) == 0
    assert calls[-1] == {"name": "other"}


@pytest.mark.slow
def test_generate_with_the_real_generator(tmp_path):
    args = ["map", "generate", "--seed", "4", "--length-m", "120", "--width-m", "150", "--cell-m", "2"]
    first = swarm(*args, "-o", tmp_path / "a.yaml")
    assert first.returncode == 0, first.stderr
    assert str(tmp_path / "a.yaml") in first.stdout and str(tmp_path / "a.npz") in first.stdout
    second = swarm(*args, "-o", tmp_path / "b.yaml")
    assert second.returncode == 0, second.stderr
    a, b = load_map(tmp_path / "a.yaml"), load_map(tmp_path / "b.yaml")
    assert (a.name, b.name) == ("a", "b")
    assert a.cell_m == 2.0
    assert (a.width_m, a.height_m) in ((120.0, 150.0), (150.0, 120.0))
    assert np.array_equal(a.terrain, b.terrain) and np.array_equal(a.elevation_m, b.elevation_m)  # same seed
    assert [r.geometry.wkb for r in a.regions.values()] == [r.geometry.wkb for r in b.regions.values()]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npz", "a.yaml", "b.npz", "b.yaml"]
    too_narrow = swarm("map", "generate", "--width-m", "31", "-o", tmp_path / "c.yaml")
    assert too_narrow.returncode == 2
    assert len(too_narrow.stderr.strip().splitlines()) == 1 and "command line: --width-m" in too_narrow.stderr
    assert not (tmp_path / "c.yaml").exists() and not (tmp_path / "c.npz").exists()


# --- import-dem ---------------------------------------------------------------------------------------------


def test_import_dem(tmp_path, capsys):
    dem = tmp_path / "site.asc"
    z = np.linspace(-4.0, 5.0, 12)[:, None] + np.zeros((1, 8))  # rising to the north
    body = "\n".join(" ".join(f"{v:.3f}" for v in row) for row in z[::-1])  # north row first
    dem.write_text(
        f"ncols 8\nnrows 12\nxllcenter 1001\nyllcenter 2001\ncellsize 2\nNODATA_value -9999\n{body}\n"
    )
    out = tmp_path / "site.yaml"
    assert main(["map", "import-dem", str(dem), "-o", str(out)]) == 0
    assert str(out) in capsys.readouterr().out
    m = load_map(out)
    assert m.name == "site"
    assert m.origin_m == (1000.0, 2000.0)
    assert m.shape == (12, 8)
    np.testing.assert_allclose(m.elevation_m[:, 0], z[:, 0], atol=6e-4)  # written with 3 decimals
    assert m.terrain_classes[m.terrain[0, 0]] == "deep_water"
    assert m.terrain_classes[m.terrain[-1, 0]] == "vegetation"


@pytest.mark.parametrize(
    ("value", "line", "expected"),
    [
        ("inf", 8, "a finite elevation (m), or NODATA_value -9999 for a cell without data"),
        ("nan", 8, "a finite elevation (m), or NODATA_value -9999 for a cell without data"),
        ("1e9", 8, "an elevation on Earth, within +-12000 m"),
    ],
)
def test_a_bad_dem_value_is_named_by_its_line(tmp_path, capsys, value, line, expected):
    """An inf in the data was reported as a NODATA gap (and --fill offered to hide it), and 1e9 m
    against the map YAML about to be written, not the DEM that held it."""
    rows = ["1 2 3", "4 5 6", f"7 {value} 9"]
    dem = tmp_path / "d.asc"
    dem.write_text("ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 1\n" + "\n".join(rows) + "\n")
    assert main(["map", "import-dem", str(dem), "-o", str(tmp_path / "d.yaml")]) == 2
    assert (
        capsys.readouterr().err
        == f"swarm: error: {dem}: line {line}: found {float(value)}, expected {expected}\n"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.asc"]
    # the gap filler is held to the same range
    assert main(["map", "import-dem", str(dem), "--fill", "1e9", "-o", str(tmp_path / "d.yaml")]) == 2
    assert capsys.readouterr().err.startswith("swarm: error: command line: --fill: found 1000000000.0")


# --- bad input: one line on stderr, exit 2, no traceback, nothing written -------------------------------


def _negative_cell(tmp_path: Path, map_file: Path) -> list[object]:
    map_file.write_text(map_file.read_text().replace("cell_m: 1.0", "cell_m: -1.0"))
    return ["map", "info", map_file]


def _unknown_class(tmp_path: Path, map_file: Path) -> list[object]:
    map_file.write_text(map_file.read_text().replace("soft_sand", "lava"))
    return ["map", "show", map_file, "-o", tmp_path / "f.png"]


def _nodata_dem(tmp_path: Path, map_file: Path) -> list[object]:
    (tmp_path / "d.asc").write_text(
        "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -9\n1 -9\n2 3\n"
    )
    return ["map", "import-dem", tmp_path / "d.asc", "-o", tmp_path / "d.yaml"]


BAD = {
    "missing-map": (lambda t, m: ["map", "info", t / "nope.yaml"], "nope.yaml"),
    "negative-cell": (_negative_cell, "cell_m"),
    "unknown-class": (_unknown_class, "lava"),
    "show-suffix": (lambda t, m: ["map", "show", m, "-o", t / "fig.jpg"], "--out"),
    "show-folder": (lambda t, m: ["map", "show", m, "-o", t / "no" / "fig.png"], "--out"),
    "generate-length": (
        lambda t, m: ["map", "generate", "--length-m", "-5", "-o", t / "g.yaml"],
        "--length-m",
    ),
    "generate-suffix": (lambda t, m: ["map", "generate", "-o", t / "g.npz"], "--out"),
    "dem-nodata": (_nodata_dem, "NODATA_value"),
    "missing-out": (lambda t, m: ["map", "show", m], "-o"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_is_one_line_and_exit_2(tmp_path, map_file, case):
    make, needle = BAD[case]
    args = make(tmp_path, map_file)
    before = sorted(p.name for p in tmp_path.iterdir())
    result = swarm(*args)
    assert result.returncode == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr  # argparse's errors too: no usage block
    assert lines[0].startswith(("swarm: error: ", "swarm map show: error: ")), result.stderr
    assert "Traceback" not in result.stderr
    assert needle in result.stderr
    assert result.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_generate_cli_reproduces_the_shipped_river_map(tmp_path):
    """Every shipped map comes from `swarm map generate`: the river map's flags give its grid
    bit for bit (the recipe in maps/README.md)."""
    args = ["map", "generate", "--seed", "7", "--length-m", "600", "--width-m", "250", "--cell-m", "1"]
    args += ["--d50-mm", "1.5", "--breaker-height-m", "1.5", "--wave-period-s", "10", "--river-mouth"]
    args += ["--rock-outcrops", "1.0", "--name", "steep_coarse_river", "-o", str(tmp_path / "s.yaml")]
    assert main(args) == 0
    repo = Path(__file__).resolve().parents[2]
    made, shipped = load_map(tmp_path / "s.yaml"), load_map(repo / "maps" / "steep_coarse_river.yaml")
    assert np.array_equal(made.terrain, shipped.terrain)
    assert np.array_equal(made.elevation_m, shipped.elevation_m)
    assert main(["map", "generate", "--rock-outcrops", "-1", "-o", str(tmp_path / "t.yaml")]) == 2


def test_an_area_s_name_is_not_drawn_inside_another_area():
    """gentle_fine's search area starts inside the dunes' keep-out, where its name, at its top-left
    corner, read as the keep-out's; it moves to the top-right corner. Every area's name is anchored
    at a corner of its own, where no other area is but one that holds it (the landing zones lie in
    the search area)."""
    import matplotlib.pyplot as plt

    from swarm.report.map_figure import plot_map

    beach_map = load_map(Path(__file__).resolve().parents[2] / "maps" / "gentle_fine.yaml")
    fig, ax = plt.subplots()
    plot_map(beach_map, None, ax=ax)
    areas = {r.name: r.geometry for r in beach_map.regions.values() if r.geometry.geom_type == "Polygon"}
    assert {"search_beach", "keep_out_dunes"} <= set(areas)
    anchors = {t.get_text(): Point(t.xy) for t in ax.texts if t.get_text() in areas}
    assert set(anchors) == set(areas)
    for name, at in anchors.items():
        x0, _, x1, y1 = areas[name].bounds
        assert at.y == y1 and at.x in (x0, x1), name
        others = [o for o, g in areas.items() if o != name and g.covers(at) and not g.covers(areas[name])]
        assert not others, (name, others)
    assert anchors["search_beach"].x == areas["search_beach"].bounds[2]
    plt.close(fig)
