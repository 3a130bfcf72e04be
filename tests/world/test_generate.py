"""The procedural beach: its science (Dean profile, surf zone, run-up), its bands, features,
regions and reproducibility, and the maps shipped in maps/."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from scipy.ndimage import binary_dilation, label

from swarm.errors import InputError
from swarm.robot.terrain import default_library
from swarm.world import coastal
from swarm.world.generate import (
    IMPASSABLE_CLASSES,
    TERRAIN_CLASSES,
    WATER_CLASSES,
    beach_science,
    generate_beach,
)
from swarm.world.io import load_map, save_map

MAPS_DIR = Path(__file__).resolve().parents[2] / "maps"
C = {name: i for i, name in enumerate(TERRAIN_CLASSES)}
SCIENCE_KEYS = ("d50_mm", "breaker_height_m", "wave_period_s", "tide_range_m")

SMALL = dict(length_m=120, width_m=80, d50_mm=0.3, breaker_height_m=0.6)  # maps/test_small's beach
FINE_NO_TIDE = dict(length_m=200, width_m=130, d50_mm=0.2, breaker_height_m=1.0, tide_range_m=0.0)
COARSE_HALF_M = dict(
    length_m=150, width_m=90, d50_mm=1.5, breaker_height_m=1.5, cell_m=0.5, wave_period_s=10.0
)
RIVER_ROCKS = dict(
    length_m=240, width_m=120, d50_mm=1.5, breaker_height_m=1.5, river_mouth=True, rock_outcrops=1.0
)


def science(kwargs: dict):
    return beach_science(**{k: v for k, v in kwargs.items() if k in SCIENCE_KEYS})


def is_in(m, *names: str) -> np.ndarray:
    return np.isin(m.terrain, [C[n] for n in names])


def clean_columns(m, sci) -> np.ndarray:
    """Columns the features leave alone: no channel or river water above the setup level, no rocks
    below 3 m (outcrops, boulders on the beach), and 6 m from any of those."""
    rows = np.arange(m.shape[0])[:, None]
    first_up = np.argmax(m.elevation_m > sci.setup_m + 1e-3, axis=0)
    bad = np.any(is_in(m, *WATER_CLASSES) & (rows >= first_up[None, :]), axis=0)
    bad |= np.any(is_in(m, "rock", "boulder") & (m.elevation_m < 3.0), axis=0)
    return ~binary_dilation(bad, iterations=int(np.ceil(6.0 / m.cell_m)))


def dean_fit(m, col: int) -> tuple[float, float]:
    """(A, shoreline y) of h = A (y0 - y)^(2/3) fitted to a column's water deeper than 0.3 m,
    from the straight line h^(3/2) = A^(3/2) (y0 - y)."""
    _, y = m.center_of(np.arange(m.shape[0]), col)
    z = m.elevation_m[:, col].astype(np.float64)
    sea = z < -0.3
    slope, intercept = np.polyfit(y[sea], (-z[sea]) ** 1.5, 1)
    return (-slope) ** (2.0 / 3.0), -intercept / slope


@pytest.fixture(scope="module")
def small():
    return generate_beach(seed=3, **SMALL)


@pytest.fixture(scope="module")
def fine():
    return generate_beach(seed=5, **FINE_NO_TIDE)


@pytest.fixture(scope="module")
def coarse():
    return generate_beach(seed=2, **COARSE_HALF_M)


@pytest.fixture(scope="module")
def river():
    return generate_beach(seed=1, **RIVER_ROCKS)


# --- reproducibility -------------------------------------------------------------------------------
def test_same_seed_same_map_different_seed_different_map(small):
    again = generate_beach(seed=3, **SMALL)
    assert np.array_equal(small.terrain, again.terrain)
    assert np.array_equal(small.elevation_m, again.elevation_m)
    assert [(r.name, r.kind, r.geometry.wkb) for r in small.regions.values()] == [
        (r.name, r.kind, r.geometry.wkb) for r in again.regions.values()
    ]
    other = generate_beach(seed=4, **SMALL)
    assert not np.array_equal(small.elevation_m, other.elevation_m)
    assert not np.array_equal(small.terrain, other.terrain)


def test_grid_and_classes(small, coarse):
    assert small.shape == (80, 120) and small.cell_m == 1.0 and small.origin_m == (0.0, 0.0)
    assert coarse.shape == (180, 300) and coarse.cell_m == 0.5
    assert small.terrain.dtype == np.int8 and small.elevation_m.dtype == np.float32
    assert small.terrain_classes == TERRAIN_CLASSES
    library = default_library()
    assert all(name in library for name in TERRAIN_CLASSES)
    assert {n for n in TERRAIN_CLASSES if not library[n].passable} == set(IMPASSABLE_CLASSES)
    assert {n for n in TERRAIN_CLASSES if library[n].is_water} == set(WATER_CLASSES)


def test_features_present(small, river):
    for m in (small, river):
        counts = np.bincount(m.terrain.ravel(), minlength=len(TERRAIN_CLASSES))
        for name in ("deep_water", "surf", "shallow_water", "wet_hard_sand", "soft_sand", "vegetation"):
            assert counts[C[name]] > 0, name
        for name in ("boulder", "driftwood", "kelp_wrack", "rock", "dirt"):  # impassable ones too
            assert counts[C[name]] > 0, name
    # the outcrop map has far more rock, and big boulders (several cells each)
    assert np.count_nonzero(is_in(river, "rock")) > 5 * np.count_nonzero(is_in(small, "rock"))
    _, sizes = np.unique(label(is_in(river, "boulder"))[0], return_counts=True)
    assert sizes[1:].max() >= 4


def test_a_wide_map_has_a_coast_road():
    m = generate_beach(seed=0, length_m=150, width_m=220, d50_mm=0.3)
    road = is_in(m, "concrete")
    assert road.any()
    assert m.center_of(np.argwhere(road)[:, 0], 0)[1].min() > m.height_m - 12.0  # along the inland edge


# --- bands -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["small", "fine", "coarse"])
def test_water_seaward_of_sand(name, request):
    m = request.getfixturevalue(name)
    rows = np.arange(m.shape[0])[:, None]
    sea = is_in(m, "deep_water", "surf")
    sand = is_in(m, "wet_hard_sand", "soft_sand")
    last_sea = np.where(sea, rows, -1).max(axis=0)
    first_sand = np.where(sand, rows, m.shape[0]).min(axis=0)
    assert np.all(last_sea < first_sand)
    # deep water, then surf, then the rest, in every column
    first_surf = np.where(is_in(m, "surf"), rows, m.shape[0]).min(axis=0)
    last_deep = np.where(is_in(m, "deep_water"), rows, -1).max(axis=0)
    assert np.all(last_deep < first_surf)
    assert np.all(is_in(m, "deep_water")[0])  # the southern edge is open sea


@pytest.mark.parametrize("name", ["small", "fine", "coarse", "river"])
def test_bands_rise_landward(name, request):
    m = request.getfixturevalue(name)
    z = m.elevation_m
    order = ["deep_water", "surf", "wet_hard_sand", "soft_sand"]
    means = [float(z[is_in(m, n)].mean()) for n in order]
    assert means == sorted(means)
    assert float(z[is_in(m, "deep_water", "surf")].max()) < 0.0 or name == "river"
    # row by row, the typical elevation rises from the sea up the beach face to the berm
    sci = science({"small": SMALL, "fine": FINE_NO_TIDE, "coarse": COARSE_HALF_M, "river": RIVER_ROCKS}[name])
    row_median = np.median(z, axis=1)
    beach_rows = slice(0, int(np.argmax(row_median > sci.berm_crest_m - 0.1)))
    assert row_median[beach_rows.stop] > 0.5
    assert np.all(np.diff(row_median[beach_rows]) > 0)


# --- the science -----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["small", "fine", "coarse"])
def test_offshore_follows_the_dean_profile(name, request):
    m = request.getfixturevalue(name)
    kwargs = {"small": SMALL, "fine": FINE_NO_TIDE, "coarse": COARSE_HALF_M}[name]
    sci = science(kwargs)
    assert sci.dean_a == pytest.approx(coastal.dean_a_from_d50(kwargs["d50_mm"]))
    cols = np.flatnonzero(clean_columns(m, sci))
    assert cols.size > 0.2 * m.shape[1]
    fits = np.array([dean_fit(m, c)[0] for c in cols])
    np.testing.assert_allclose(fits, sci.dean_a, rtol=0.01)


@pytest.mark.parametrize("name", ["small", "fine", "coarse"])
def test_surf_zone_width(name, request):
    m = request.getfixturevalue(name)
    kwargs = {"small": SMALL, "fine": FINE_NO_TIDE, "coarse": COARSE_HALF_M}[name]
    sci = science(kwargs)
    assert sci.surf_zone_width_m == pytest.approx(
        coastal.surf_zone_width(kwargs["breaker_height_m"], coastal.dean_a_from_d50(kwargs["d50_mm"]))
    )
    rows = np.arange(m.shape[0])[:, None]
    breaker_line = (np.where(is_in(m, "deep_water"), rows, -1).max(axis=0) + 1) * m.cell_m
    for c in np.flatnonzero(clean_columns(m, sci)):
        _, shoreline = dean_fit(m, c)
        assert shoreline - breaker_line[c] == pytest.approx(sci.surf_zone_width_m, abs=2 * m.cell_m)


@pytest.mark.parametrize("name", ["small", "fine", "coarse"])
def test_wet_sand_reaches_the_runup(name, request):
    m = request.getfixturevalue(name)
    kwargs = {"small": SMALL, "fine": FINE_NO_TIDE, "coarse": COARSE_HALF_M}[name]
    sci = science(kwargs)
    h0 = coastal.deep_water_height_from_breaker(kwargs["breaker_height_m"], sci.wave_period_s)
    l0 = coastal.deep_water_wavelength(sci.wave_period_s)
    r2 = coastal.stockdon_runup_r2(h0, l0, coastal.foreshore_slope(kwargs["d50_mm"]))
    assert sci.wet_top_m == pytest.approx(sci.tide_range_m / 2 + r2)  # mean high water + R2
    if name == "fine":
        assert sci.tide_range_m == 0 and sci.wet_top_m == pytest.approx(r2)
    cols = np.flatnonzero(clean_columns(m, sci))
    tops = []
    for c in cols:
        wet = is_in(m, "wet_hard_sand")[:, c]
        if wet.any():
            tops.append(float(m.elevation_m[wet, c].max()))
        soft = is_in(m, "soft_sand")[:, c]
        assert m.elevation_m[soft, c].min() > sci.wet_top_m - 1e-3  # dry sand only above the run-up (mm)
    tops = np.array(tops)
    assert tops.max() <= sci.wet_top_m + 1e-3
    # the band reaches the run-up to within a cell's rise of the foreshore (kelp may lie on top)
    assert np.percentile(tops, 90) >= sci.wet_top_m - sci.foreshore_slope * m.cell_m - 0.02


@pytest.mark.parametrize("name", ["small", "fine", "coarse"])
def test_foreshore_slope_and_swash(name, request):
    m = request.getfixturevalue(name)
    kwargs = {"small": SMALL, "fine": FINE_NO_TIDE, "coarse": COARSE_HALF_M}[name]
    sci = science(kwargs)
    _, dz_dy = m.gradient
    cols = clean_columns(m, sci)[None, :]
    face = is_in(m, "wet_hard_sand") & cols & (m.elevation_m > sci.setup_m + 0.1)
    face &= m.elevation_m < sci.wet_top_m - 0.1
    assert float(np.median(dz_dy[face])) == pytest.approx(sci.foreshore_slope, rel=0.1)
    # the swash below the setup is shallow water, on every clean column
    swash = is_in(m, "shallow_water") & (m.elevation_m >= 0) & cols
    assert np.all(m.elevation_m[swash] < sci.setup_m)
    assert np.all(swash.any(axis=0)[cols[0]])


def test_bad_arguments_are_input_errors():
    for kwargs, where in [
        (dict(width_m=40), "width_m"),  # no room for the surf zone and the beach
        (dict(d50_mm=0.0), "d50_mm"),
        (dict(d50_mm=30.0), "d50_mm"),
        (dict(breaker_height_m=-1.0), "breaker_height_m"),
        (dict(cell_m=50.0), "cell_m"),
        (dict(seed=-1), "seed"),
        (dict(seed=True), "seed"),
        (dict(rock_outcrops=-0.5), "rock_outcrops"),
        (dict(name=""), "name"),
    ]:
        with pytest.raises(InputError) as err:
            generate_beach(**kwargs)
        assert err.value.where == where


def test_a_kilometre_at_half_metre_cells_has_its_features():
    """The size `benchmarks/bench_planning.py` plans on (and times): a river reaching the inland
    edge, the rock platforms' keep-out zones (one every 300 m at `rock_outcrops=1`)."""
    m = generate_beach(
        seed=9, length_m=1000, width_m=200, cell_m=0.5, d50_mm=0.2, river_mouth=True, rock_outcrops=1
    )
    assert m.shape == (400, 2000)
    water = np.isin(m.terrain, [C[c] for c in WATER_CLASSES])
    assert water[0].all()  # the sea along the offshore edge
    assert 0 < water[-1].mean() < 0.1  # the river's channel, and only it, at the inland edge
    assert len([r for r in m.regions if r.startswith("keep_out_rocks_")]) == 3


def test_finer_cells_draw_the_same_landforms():
    coarse_map = generate_beach(seed=6, **SMALL)
    fine_map = generate_beach(seed=6, **{**SMALL, "cell_m": 0.5})
    z_half = fine_map.elevation_m.reshape(80, 2, 120, 2).mean(axis=(1, 3))
    assert np.median(np.abs(z_half - coarse_map.elevation_m)) < 0.05


# --- features --------------------------------------------------------------------------------------
def test_river_mouth_joins_the_inland_edge_to_the_sea(river, small):
    water, _ = label(is_in(river, *WATER_CLASSES))
    through = set(water[-1][water[-1] > 0]) & set(water[0][water[0] > 0])
    assert through, "no water from the inland edge to the sea"
    (comp,) = through
    inland = (water == comp) & (np.arange(river.shape[0])[:, None] > river.shape[0] * 0.6)
    assert np.any(inland & is_in(river, "deep_water")) and np.any(inland & is_in(river, "shallow_water"))
    water_small, _ = label(is_in(small, *WATER_CLASSES))
    assert not set(water_small[-1][water_small[-1] > 0])  # no river: dry along the inland edge


# --- regions ---------------------------------------------------------------------------------------
def check_regions(m) -> None:
    kinds = [r.kind for r in m.regions.values()]
    for kind, at_least in [
        ("launch", 2),
        ("landing_zone", 2),
        ("search_area", 1),
        ("keep_out", 1),
        ("rally", 1),
        ("relay_source", 1),
        ("relay_sink", 1),
    ]:
        assert kinds.count(kind) >= at_least, kind
    assert kinds.count("landing_zone") == 2 and kinds.count("launch") <= 3
    library = default_library()
    passable = np.array([library[n].passable for n in TERRAIN_CLASSES])
    frame = shapely.box(*m.bounds_m)
    for region in m.regions.values():
        g = region.geometry
        assert g.is_valid and frame.covers(g), region.name
        if region.kind in ("launch", "relay_source"):
            assert m.terrain_at(g.x, g.y) == C["deep_water"], region.name
        if region.kind in ("rally", "relay_sink", "observation_point"):
            cls = int(m.terrain_at(g.x, g.y))
            assert passable[cls] and TERRAIN_CLASSES[cls] not in WATER_CLASSES, region.name
        if region.kind == "landing_zone":
            x, y = m.center_of(*np.indices(m.shape))
            inside = shapely.contains_xy(g, x, y)
            assert inside.sum() >= 8, region.name
            assert np.all(m.terrain[inside] == C["wet_hard_sand"]), region.name
            for other in m.regions_of_kind("keep_out"):
                assert not g.intersects(other.geometry)
    landing = [r.geometry for r in m.regions_of_kind("landing_zone")]
    assert not landing[0].intersects(landing[1])
    search = m.regions_of_kind("search_area")[0].geometry
    assert all(search.intersects(z) for z in landing)


@pytest.mark.parametrize("seed", range(4))
def test_regions_on_sensible_ground(seed):
    check_regions(generate_beach(seed=seed, **SMALL))
    m = generate_beach(seed=seed, **RIVER_ROCKS)
    check_regions(m)
    # each outcrop is a keep-out zone, and it holds the outcrop's rock
    keep_out = shapely.union_all([r.geometry for r in m.regions_of_kind("keep_out")])
    x, y = m.center_of(*np.nonzero(is_in(m, "rock") & (m.elevation_m < 1.0)))  # the low shelf in the surf
    assert shapely.contains_xy(keep_out, x, y).mean() > 0.8


def test_save_and_load(small, tmp_path):
    save_map(small, tmp_path / "beach.yaml")
    back = load_map(tmp_path / "beach.yaml")
    assert np.array_equal(back.terrain, small.terrain) and np.array_equal(back.elevation_m, small.elevation_m)
    assert back.regions.keys() == small.regions.keys()


# --- the shipped maps ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("stem", "size_m", "cell_m", "features"),
    [
        ("gentle_fine", (1000.0, 200.0), 1.0, ("concrete",)),
        ("steep_coarse_river", (600.0, 250.0), 1.0, ("rock", "boulder")),
        ("test_small", (120.0, 80.0), 1.0, ()),
    ],
)
def test_shipped_maps(stem, size_m, cell_m, features):
    m = load_map(MAPS_DIR / f"{stem}.yaml")
    assert m.name == stem and (m.width_m, m.height_m) == size_m and m.cell_m == cell_m
    assert (MAPS_DIR / f"{stem}.npz").stat().st_size < 1_000_000
    for name in ("deep_water", "surf", "wet_hard_sand", "soft_sand", "vegetation", *features):
        assert np.any(is_in(m, name)), name
    check_regions(m)
    if stem == "steep_coarse_river":
        water, _ = label(is_in(m, *WATER_CLASSES))
        assert set(water[-1][water[-1] > 0]) & set(water[0][water[0] > 0])  # the river reaches the sea
