"""Procedural beaches grounded in coastal science (`swarm map generate`).

Frame: the shoreline runs along x (east-west); y increases inland (north); the sea is to the
south, in the rows near 0. The cross-shore coordinate s is the distance inland of the still-water
shoreline (mean sea level, elevation 0), negative offshore. The shoreline wanders a few metres
alongshore and every band follows it, so the bands run parallel to the shore.

Cross-shore, from the south (see `swarm.world.coastal` for the sources and `BeachScience` for the
numbers):

  band                          elevation                                         class
  offshore, s < -x_b            Dean profile h = A (-s)^(2/3), A from grain size  deep_water
  surf zone, -x_b <= s < -x_sh  Dean; x_b where h = H_b / 0.78 (breaker line)     surf
  inner surf, -x_sh <= s < 0    Dean, shallower than 0.3 m                        shallow_water
  swash, up to the setup        foreshore slope from grain size, beach cusps      shallow_water
  intertidal, up to the run-up  foreshore, up to mean high water + Stockdon R2    wet_hard_sand
  upper beach face and berm     foreshore up to the berm crest (Takeda-Sunamura)  soft_sand
  dry beach                     rising 1%, small hummocks                         soft_sand
  dunes                         smooth random crests and hummocks                 vegetation, soft_sand
  behind the dunes              small hills and ravines                           dirt, vegetation
  coast road (if room)          smoothed along the shore                          concrete

So deep_water is the water beyond the breakers, deeper than H_b / 0.78 (1.28 m for 1 m breakers):
the robot swims there; in surf and shallow_water its wheels reach the bed between waves.

Features: meandering run-off channels cut from the dunes to the sea (shallow_water thalweg, damp
wet_hard_sand banks); rocks in clusters with a power-law size distribution (rocks 1 m across and
larger are impassable `boulder`s, smaller ones roughen a cell to `rock`); kelp wrack along the
high-tide wrack line and patches on the intertidal band; driftwood logs (impassable) on the wrack
line and the upper beach; optional rock outcrops (rock platforms from the dunes into the surf,
ringed by boulders); an optional river mouth (a channel of water from the inland edge into the sea,
deep_water in its middle, shallow_water at its margins). Regions: launch points and a relay source
offshore in deep water, two landing zones on the wet hard sand (where its band is a cell wide or
more; obstacles in them are cleared), a search area over the beach, a
keep-out zone around each outcrop (or a dune area), a rally point and a relay sink inland and an
observation point on a dune crest.

All randomness comes from `numpy.random.default_rng(seed)`, drawn in a fixed order: the same
arguments give identical arrays. Smooth noise is white noise on a coarse lattice (spacing half the
smoothing length), Gaussian-filtered and interpolated to the cells, so a finer `cell_m` draws the
same landforms at a higher resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import numpy as np
import shapely
from pydantic import Field, StringConstraints
from scipy import sparse
from scipy.ndimage import binary_erosion, gaussian_filter, gaussian_filter1d
from shapely.geometry import Point, Polygon

from swarm.errors import InputError
from swarm.inputs import InputModel, validate
from swarm.world import coastal
from swarm.world.beachmap import BeachMap, Region

#: The class order of every generated map: the terrain modes of swarm/data/terrain_modes.yaml.
TERRAIN_CLASSES = (
    "deep_water",
    "surf",
    "shallow_water",
    "wet_hard_sand",
    "soft_sand",
    "dirt",
    "rock",
    "vegetation",
    "kelp_wrack",
    "boulder",
    "driftwood",
    "concrete",
)
_C = {name: i for i, name in enumerate(TERRAIN_CLASSES)}
WATER_CLASSES = ("deep_water", "surf", "shallow_water")
IMPASSABLE_CLASSES = ("boulder", "driftwood")

#: Water shallower than this is `shallow_water`: in the inner surf the bores are then lower than
#: the robot's hull (H = 0.78 h < 0.25 m) and the wheels keep the bed.
SHALLOW_DEPTH_M = 0.3
#: River water deeper than this is `deep_water` (the robot swims), shallower `shallow_water`.
RIVER_DEEP_M = 1.0
#: Rocks this wide or wider are impassable boulders: about half buried, they stand ~0.5 m high,
#: more than the wheel radius of a small robot (terrain_modes.yaml, boulder).
BOULDER_MIN_DIAMETER_M = 1.0
#: Exponent of the rock-size distribution N(>D) ~ D^-2.5, the fragmentation fractal dimension
#: of many natural rock and boulder populations (D. L. Turcotte, "Fractals and fragmentation",
#: J. Geophys. Res. 91(B2), 1921-1926, 1986).
ROCK_SIZE_EXPONENT = 2.5
#: Largest cell count accepted (about 20 million cells: ~0.5 GB of working arrays).
MAX_CELLS = 20_000_000

_SOURCE = "generate_beach"


# --- the science of one beach ----------------------------------------------------------------------
@dataclass(frozen=True)
class BeachScience:
    """Every number the generator derives from sand, waves and tide (metres unless named)."""

    d50_mm: float
    breaker_height_m: float
    wave_period_s: float
    tide_range_m: float
    dean_a: float  #: m^(1/3), [Moore82, Dean91]
    breaker_depth_m: float  #: h_b = H_b / 0.78
    surf_zone_width_m: float  #: x_b, shoreline to breaker line on the Dean profile
    shallow_width_m: float  #: shoreline to where the Dean depth reaches SHALLOW_DEPTH_M
    foreshore_slope: float  #: tan(beta) [Wiegel65]
    deep_water_height_m: float  #: H0 [KG73]
    deep_water_wavelength_m: float  #: L0
    iribarren: float
    setup_m: float  #: <eta> [Stock06]
    runup_r2_m: float  #: R2 above the still water level [Stock06 eq. 19]
    wet_top_m: float  #: top of the wet hard sand: mean high water + R2
    berm_crest_m: float  #: berm crest elevation above mean sea level [TS82]
    cusp_spacing_m: float  #: [GI75]
    cusp_relief_m: float  #: amplitude of the cusp horns (0.15 R2, at most 0.25 m)

    @property
    def setup_distance_m(self) -> float:
        """Distance inland of the shoreline where the beach face reaches the setup."""
        return self.setup_m / self.foreshore_slope

    @property
    def runup_distance_m(self) -> float:
        """Distance inland of the shoreline where the beach face reaches the wet top (wrack line)."""
        return self.wet_top_m / self.foreshore_slope

    @property
    def berm_distance_m(self) -> float:
        return self.berm_crest_m / self.foreshore_slope


def beach_science(
    *,
    d50_mm: float = 0.3,
    breaker_height_m: float = 1.0,
    wave_period_s: float = 8.0,
    tide_range_m: float = 1.0,
    gamma: float = coastal.BREAKING_INDEX,
) -> BeachScience:
    """The profile numbers for a sand, a breaker height, a swell period and a tidal range.

    The snapshot is at mean sea level (mid tide); the wet hard sand reaches the high-tide run-up,
    tide/2 + R2, where the wrack line is; the berm crest is the Takeda-Sunamura berm height above
    mean high water (at least 0.3 m above the wet top).
    """
    a = float(coastal.dean_a_from_d50(d50_mm))
    h_b = float(coastal.breaker_depth(breaker_height_m, gamma))
    x_b = float(coastal.surf_zone_width(breaker_height_m, a, gamma))
    x_sh = min(float(coastal.dean_distance(SHALLOW_DEPTH_M, a)), 0.5 * x_b)
    beta = float(coastal.foreshore_slope(d50_mm))
    h0 = float(coastal.deep_water_height_from_breaker(breaker_height_m, wave_period_s))
    l0 = float(coastal.deep_water_wavelength(wave_period_s))
    r2 = float(coastal.stockdon_runup_r2(h0, l0, beta))
    wet_top = tide_range_m / 2.0 + r2
    berm = max(
        tide_range_m / 2.0 + float(coastal.berm_height(breaker_height_m, wave_period_s)), wet_top + 0.3
    )
    return BeachScience(
        d50_mm=float(d50_mm),
        breaker_height_m=float(breaker_height_m),
        wave_period_s=float(wave_period_s),
        tide_range_m=float(tide_range_m),
        dean_a=a,
        breaker_depth_m=h_b,
        surf_zone_width_m=x_b,
        shallow_width_m=x_sh,
        foreshore_slope=beta,
        deep_water_height_m=h0,
        deep_water_wavelength_m=l0,
        iribarren=float(coastal.iribarren(beta, h0, l0)),
        setup_m=float(coastal.stockdon_setup(h0, l0, beta)),
        runup_r2_m=r2,
        wet_top_m=wet_top,
        berm_crest_m=berm,
        cusp_spacing_m=float(coastal.cusp_spacing(wave_period_s, beta)),
        cusp_relief_m=min(0.25, 0.15 * r2),
    )


@dataclass(frozen=True)
class _Layout:
    """Where the bands are, cross-shore (s, metres inland of the shoreline) and alongshore."""

    shoreline_y: np.ndarray  # (cols,) y of the still-water shoreline per column
    deep_margin_m: float  # deep water beyond the breaker line at the narrowest
    dune_toe_s: np.ndarray  # (cols,)
    dune_width_m: float
    dune_height_m: np.ndarray  # (cols,)
    dune_crest_frac: float
    back_level_frac: float
    dry_width_m: float
    back_width_m: float


# --- smooth noise ----------------------------------------------------------------------------------
def _catmull_rom(positions: np.ndarray, first_node: float, step: float, n_nodes: int) -> sparse.csr_matrix:
    """Sparse (len(positions), n_nodes) matrix interpolating node values at positions (C1 cubic)."""
    t = (positions - first_node) / step
    j = np.floor(t).astype(np.intp)
    f = t - j
    f2, f3 = f * f, f * f * f
    w = np.stack(
        [
            (-f3 + 2 * f2 - f) / 2,
            (3 * f3 - 5 * f2 + 2) / 2,
            (-3 * f3 + 4 * f2 + f) / 2,
            (f3 - f2) / 2,
        ],
        axis=1,
    )
    cols = np.clip(j[:, None] + np.arange(-1, 3)[None, :], 0, n_nodes - 1)
    rows = np.repeat(np.arange(len(positions)), 4)
    return sparse.csr_matrix((w.ravel(), (rows, cols.ravel())), shape=(len(positions), n_nodes))


class _Noise:
    """Smooth unit-variance random fields over the map, from one Generator, resolution-independent."""

    PAD = 8  # lattice nodes beyond each edge (4 smoothing lengths)

    def __init__(self, rng: np.random.Generator, x: np.ndarray, y: np.ndarray, cell_m: float) -> None:
        self.rng, self.x, self.y = rng, x, y
        self.length_m, self.width_m = len(x) * cell_m, len(y) * cell_m

    def _lattice(self, extent_m: float, sigma_m: float) -> tuple[float, float, int]:
        """Lattice nodes over [0, extent]: the same for every cell size on the same extent."""
        step = sigma_m / 2.0
        first = -self.PAD * step
        n = math.ceil(round(extent_m / step, 6)) + 2 * self.PAD + 2
        return first, step, n

    def field(self, sigma_x_m: float, sigma_y_m: float | None = None) -> np.ndarray:
        """(rows, cols) Gaussian-smoothed noise, standard deviation ~1, correlation lengths in metres."""
        sigma_y_m = sigma_x_m if sigma_y_m is None else sigma_y_m
        fx, sx, nx = self._lattice(self.length_m, sigma_x_m)
        fy, sy, ny = self._lattice(self.width_m, sigma_y_m)
        white = self.rng.standard_normal((ny, nx))
        smooth = gaussian_filter(white, sigma=2.0, mode="wrap") * (2.0 * 2.0 * math.sqrt(math.pi))
        wx = _catmull_rom(self.x, fx, sx, nx)
        wy = _catmull_rom(self.y, fy, sy, ny)
        return np.asarray((wx @ (wy @ smooth).T).T)

    def along(self, sigma_m: float) -> np.ndarray:
        """(cols,) smooth noise along the shore (x), standard deviation ~1."""
        return self._line(self.x, self.length_m, sigma_m)

    def across(self, sigma_m: float) -> np.ndarray:
        """(rows,) smooth noise across the shore (y), standard deviation ~1."""
        return self._line(self.y, self.width_m, sigma_m)

    def _line(self, coords: np.ndarray, extent: float, sigma_m: float) -> np.ndarray:
        first, step, n = self._lattice(extent, sigma_m)
        white = self.rng.standard_normal(n)
        smooth = gaussian_filter1d(white, sigma=2.0, mode="wrap") / math.sqrt(
            1.0 / (2.0 * 2.0 * math.sqrt(math.pi))
        )
        return _catmull_rom(coords, first, step, n) @ smooth


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


# --- arguments ------------------------------------------------------------------------------------
class GeneratorParams(InputModel):
    """What `generate_beach` takes, with the ranges the beach science holds over."""

    seed: int = Field(0, ge=0)
    length_m: float = Field(400.0, ge=30.0, le=50_000.0, description="Shore length.")
    width_m: float = Field(200.0, ge=30.0, le=5_000.0, description="Map width from the sea inland.")
    d50_mm: float = Field(0.3, ge=0.06, le=4.0, description="Median grain size, sand to granules.")
    breaker_height_m: float = Field(1.0, ge=0.05, le=8.0)
    cell_m: float = Field(1.0, gt=0.0, le=10.0)
    wave_period_s: float = Field(8.0, ge=2.0, le=25.0)
    name: Annotated[str, StringConstraints(strip_whitespace=True, min_length=1)] = "beach"
    river_mouth: bool = False
    rock_outcrops: float = Field(0.0, ge=0.0, le=5.0, description="About 1: a rock platform every 300 m.")
    tide_range_m: float = Field(1.0, ge=0.0, le=12.0, description="Spring tidal range.")


# --- the generator ---------------------------------------------------------------------------------
def generate_beach(
    *,
    seed: int = 0,
    length_m: float = 400,
    width_m: float = 200,
    d50_mm: float = 0.3,
    breaker_height_m: float = 1.0,
    cell_m: float = 1.0,
    wave_period_s: float = 8.0,
    name: str = "beach",
    river_mouth: bool = False,
    rock_outcrops: float = 0.0,
    tide_range_m: float = 1.0,
) -> BeachMap:
    """A procedural beach `length_m` along the shore by `width_m` from the sea inland.

    `d50_mm` median grain size; `breaker_height_m` and `wave_period_s` the breaking swell;
    `tide_range_m` the spring tidal range (the map is at mid tide); `rock_outcrops` 0 for none,
    about 1 for one rock platform every 300 m of shore (size grows with it); `river_mouth` cuts a
    river through the beach. Same arguments, same map. See the module docstring for the bands.
    """
    p = validate(
        GeneratorParams,
        {
            "seed": int(seed) if isinstance(seed, np.integer) else seed,
            "length_m": length_m,
            "width_m": width_m,
            "d50_mm": d50_mm,
            "breaker_height_m": breaker_height_m,
            "cell_m": cell_m,
            "wave_period_s": wave_period_s,
            "name": name,
            "river_mouth": river_mouth,
            "rock_outcrops": rock_outcrops,
            "tide_range_m": tide_range_m,
        },
        _SOURCE,
    )
    seed, length_m, width_m, cell_m, name = p.seed, p.length_m, p.width_m, p.cell_m, p.name
    d50_mm, breaker_height_m, wave_period_s = p.d50_mm, p.breaker_height_m, p.wave_period_s
    river_mouth, rock_outcrops, tide_range_m = p.river_mouth, p.rock_outcrops, p.tide_range_m
    cols, rows = round(length_m / cell_m), round(width_m / cell_m)
    if min(rows, cols) < 20:
        raise InputError(
            _SOURCE, "cell_m", cell_m, f"a cell small enough for 20 cells across ({rows} x {cols})"
        )
    if rows * cols > MAX_CELLS:
        raise InputError(_SOURCE, "cell_m", cell_m, f"a grid of at most {MAX_CELLS} cells, not {rows * cols}")

    sci = beach_science(
        d50_mm=d50_mm,
        breaker_height_m=breaker_height_m,
        wave_period_s=wave_period_s,
        tide_range_m=tide_range_m,
    )
    rng = np.random.default_rng(int(seed))
    x = (np.arange(cols) + 0.5) * cell_m
    y = (np.arange(rows) + 0.5) * cell_m
    noise = _Noise(rng, x, y, cell_m)
    length_m, width_m = cols * cell_m, rows * cell_m

    layout = _layout(sci, noise, rng, length_m, width_m)
    s = y[:, None] - layout.shoreline_y[None, :]  # (rows, cols) metres inland of the shoreline
    z, terrain = _profile(sci, layout, noise, rng, x, s)
    g = _Grid(x, y, s, z, terrain, cell_m, length_m, width_m, sci, layout)

    river = _river(g, noise, rng) if river_mouth else None
    outcrops = _outcrops(g, noise, rng, rock_outcrops, river)
    _channels(g, noise, rng, river, outcrops)
    _scattered_rocks(g, rng, rock_outcrops, river)
    _kelp(g, noise)
    _driftwood(g, rng)
    _road(g, noise)
    regions = _regions(g, river, outcrops)

    return BeachMap(
        name=name,
        cell_m=float(cell_m),
        origin_m=(0.0, 0.0),
        terrain_classes=TERRAIN_CLASSES,
        terrain=g.terrain.astype(np.int8),
        elevation_m=np.round(g.z, 3).astype(np.float32),  # millimetres: plenty, and compresses
        regions=regions,
    )


@dataclass
class _Grid:
    x: np.ndarray
    y: np.ndarray
    s: np.ndarray
    z: np.ndarray
    terrain: np.ndarray
    cell: float
    length: float
    width: float
    sci: BeachScience
    layout: _Layout

    def col_of(self, xm: float) -> int:
        return int(np.clip(xm // self.cell, 0, len(self.x) - 1))

    def row_of(self, ym: float) -> int:
        return int(np.clip(ym // self.cell, 0, len(self.y) - 1))

    def window(self, xm: float, ym: float, radius_m: float) -> tuple[slice, slice]:
        r = math.ceil(radius_m / self.cell) + 1
        c, rr = self.col_of(xm), self.row_of(ym)
        return slice(max(rr - r, 0), rr + r + 1), slice(max(c - r, 0), c + r + 1)


def _layout(
    sci: BeachScience, noise: _Noise, rng: np.random.Generator, length: float, width: float
) -> _Layout:
    wander = min(3.0, 0.01 * length)  # shoreline wander, m
    margin = max(15.0, 0.12 * width)  # deep water kept beyond the breakers
    offshore = sci.surf_zone_width_m + margin + 2.5 * wander
    inland = width - offshore
    need_beach = sci.berm_distance_m
    rest = inland - need_beach
    if rest < 25.0:
        need = offshore + need_beach + 25.0
        raise InputError(
            _SOURCE,
            "width_m",
            width,
            f"at least {math.ceil(need)} m for this sand and these waves: {sci.surf_zone_width_m:.0f} m of "
            f"surf zone, {margin:.0f} m of deep water, {need_beach:.0f} m of beach face, 25 m of dunes",
        )
    shore = offshore + wander * np.clip(noise.along(float(np.clip(0.1 * length, 30.0, 150.0))), -2.5, 2.5)
    dune_w = min(0.4 * rest, 45.0)
    dry = min(0.3 * rest, 40.0)
    back = rest - dune_w - dry
    toe = need_beach + dry + min(0.2 * dry, 6.0) * np.clip(noise.along(40.0), -2.0, 2.0)
    h0 = float(np.clip(0.12 * dune_w, 1.2, 6.0)) * rng.uniform(0.8, 1.2)
    height = h0 * (1.0 + 0.25 * np.clip(noise.along(50.0), -2.5, 2.5))
    return _Layout(
        shoreline_y=shore,
        deep_margin_m=margin,
        dune_toe_s=toe,
        dune_width_m=dune_w,
        dune_height_m=np.maximum(height, 0.4 * h0),
        dune_crest_frac=float(rng.uniform(0.35, 0.45)),
        back_level_frac=float(rng.uniform(0.35, 0.55)),
        dry_width_m=dry,
        back_width_m=back,
    )


def _profile(
    sci: BeachScience, lay: _Layout, noise: _Noise, rng: np.random.Generator, x: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Elevation and terrain of the bare beach: Dean offshore, foreshore, berm, dunes, back."""
    beta = sci.foreshore_slope
    s_berm = sci.berm_distance_m
    # sea: Dean's equilibrium profile
    z = np.where(s < 0.0, -sci.dean_a * np.abs(np.minimum(s, 0.0)) ** (2.0 / 3.0), 0.0)
    # beach face at the foreshore slope, with cusps on it
    phase = rng.uniform(0.0, 2.0 * math.pi)
    spacing = sci.cusp_spacing_m * (1.0 + 0.08 * noise.along(3.0 * sci.cusp_spacing_m))
    cell = float(x[1] - x[0])
    cusps = np.cos(2.0 * math.pi * np.cumsum(cell / spacing) + phase)
    envelope = np.sin(np.pi * np.clip(s / s_berm, 0.0, 1.0))
    face = beta * s + sci.cusp_relief_m * envelope * cusps[None, :]
    # landward of the berm crest: dry beach rising at 1%, dunes, back
    toe = lay.dune_toe_s[None, :]
    u = (s - toe) / lay.dune_width_m
    uc, back = lay.dune_crest_frac, lay.back_level_frac
    shape = np.where(
        u < uc,
        _smoothstep(u / uc),
        1.0 - (1.0 - back) * _smoothstep((u - uc) / (1.0 - uc)),
    )
    dune = lay.dune_height_m[None, :] * shape
    land = sci.berm_crest_m + 0.01 * (s - s_berm) + dune
    hummocks = noise.field(4.0)
    dune_bumps = noise.field(7.0)
    hills = noise.field(14.0)
    ravine_lines = noise.field(22.0)
    ravine_mask = noise.field(40.0)
    veg_noise = noise.field(5.0)
    h_ref = float(np.mean(lay.dune_height_m))
    r_dry = _smoothstep((s - s_berm) / 5.0)
    r_dune = _smoothstep(u / 0.3)
    r_back = _smoothstep((u - uc) / (1.0 - uc))
    land = land + 0.12 * r_dry * hummocks + 0.12 * h_ref * r_dune * dune_bumps + 0.25 * h_ref * r_back * hills
    ravine_depth = min(1.5, 0.3 * h_ref + 0.3)
    ravines = ravine_depth * np.exp(-((ravine_lines / 0.1) ** 2)) * _smoothstep(ravine_mask / 0.3 + 0.5)
    land = land - ravines * _smoothstep((u - 1.0) / 0.3)
    land = np.maximum(land, 0.5 * sci.berm_crest_m)
    z = np.where(s < 0.0, z, np.where(s < s_berm, face, land))

    terrain = np.empty(s.shape, dtype=np.int8)
    terrain[:] = _C["soft_sand"]
    terrain[s < -sci.shallow_width_m] = _C["surf"]
    terrain[s < -sci.surf_zone_width_m] = _C["deep_water"]
    beach_face = (s >= 0.0) & (s < s_berm)
    terrain[(s >= -sci.shallow_width_m) & (s < 0.0)] = _C["shallow_water"]
    terrain[beach_face & (z < sci.setup_m)] = _C["shallow_water"]
    terrain[beach_face & (z >= sci.setup_m) & (z <= sci.wet_top_m)] = _C["wet_hard_sand"]
    # dunes: grass on the crest and the lee, pioneer patches on the seaward face
    lee = u >= uc - 0.15 + 0.25 * veg_noise
    pioneer = (u >= 0.05) & (veg_noise > 0.55)
    terrain[(u >= 0.0) & (u < 1.0) & (lee | pioneer)] = _C["vegetation"]
    # behind the dunes: dirt with scrub
    behind = u >= 1.0
    terrain[behind] = _C["dirt"]
    terrain[behind & (veg_noise + 0.6 * (1.0 - _smoothstep((u - 1.0) / 0.5)) > 0.25)] = _C["vegetation"]
    return z, terrain


# --- features --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _River:
    path_x: np.ndarray  # (rows,) centre-line x per row
    half_width: np.ndarray  # (rows,)
    depth_m: float

    def near(self, xm: float, margin_m: float) -> bool:
        return bool(np.any(np.abs(self.path_x - xm) < self.half_width + margin_m))


@dataclass(frozen=True)
class _Outcrop:
    x: float
    s: float
    a: float  # alongshore semi-axis
    b: float  # cross-shore semi-axis


def _river(g: _Grid, noise: _Noise, rng: np.random.Generator) -> _River:
    """A river channel from the inland edge into the sea, through a gap in the dunes."""
    x0 = rng.uniform(0.3, 0.7) * g.length
    hw0 = float(np.clip(0.02 * g.length, 5.0, 14.0)) * rng.uniform(0.8, 1.2)
    depth = rng.uniform(1.4, 2.0)
    amp = float(np.clip(0.04 * g.length, 4.0, 25.0))
    meander = noise.across(float(np.clip(0.15 * g.width, 15.0, 60.0)))
    col = g.col_of(x0)
    s_col = g.y - g.layout.shoreline_y[col]
    # straight where it crosses the beach face and flares into the sea
    calm = _smoothstep((s_col - g.sci.berm_distance_m) / 20.0)
    path = x0 + amp * np.clip(meander, -2.5, 2.5) * calm
    hw = hw0 * (1.0 + 0.8 * np.exp(-np.maximum(s_col, 0.0) / 12.0))
    dx = g.x[None, :] - path[:, None]
    a = np.abs(dx) / hw[:, None]
    bed = np.where(a < 1.0, -depth * (1.0 - a * a), (np.abs(dx) - hw[:, None]) * 0.1)
    cut = bed < g.z
    g.z = np.where(cut, bed, g.z)
    land = g.s >= 0.0
    water = cut & land & (g.z < 0.0)
    g.terrain[water] = _C["shallow_water"]
    g.terrain[water & (g.z < -RIVER_DEEP_M)] = _C["deep_water"]
    bank = cut & land & (g.z >= 0.0) & (g.z < 0.4)
    g.terrain[bank] = _C["wet_hard_sand"]
    riparian = (
        land & ~water & ~bank & (np.abs(dx) < hw[:, None] + 10.0) & (g.s > g.layout.dune_toe_s[None, :])
    )
    g.terrain[riparian] = _C["vegetation"]
    return _River(path_x=path, half_width=hw, depth_m=depth)


def _pareto_diameters(rng: np.random.Generator, n: int, d_min: float, d_max: float) -> np.ndarray:
    """Rock diameters with N(>D) ~ D^-2.5 between d_min and d_max (inverse-CDF sampling)."""
    return np.minimum(d_min * (1.0 - rng.random(n)) ** (-1.0 / ROCK_SIZE_EXPONENT), d_max)


def _place_rocks(
    g: _Grid, xs: np.ndarray, ys: np.ndarray, diameters: np.ndarray, allowed: np.ndarray
) -> None:
    """Raster rocks: boulders (>= 1 m) as raised impassable discs, smaller rocks as rough rock cells."""
    inside = (xs >= 0) & (xs < g.length) & (ys >= 0) & (ys < g.width)
    xs, ys, diameters = xs[inside], ys[inside], diameters[inside]
    rows = np.minimum((ys // g.cell).astype(np.intp), len(g.y) - 1)
    cols = np.minimum((xs // g.cell).astype(np.intp), len(g.x) - 1)
    small = diameters < BOULDER_MIN_DIAMETER_M
    ok = allowed[g.terrain[rows, cols]] & small
    g.terrain[rows[ok], cols[ok]] = _C["rock"]
    for xm, ym, d in zip(xs[~small], ys[~small], diameters[~small], strict=True):
        rs, cs = g.window(xm, ym, d / 2.0)
        dist = np.hypot(g.x[cs][None, :] - xm, g.y[rs][:, None] - ym)
        r = d / 2.0
        disc = dist <= max(r, 0.5 * g.cell)
        disc &= allowed[g.terrain[rs, cs]]
        if not disc.any():
            continue
        bump = 0.5 * d * np.sqrt(np.clip(1.0 - (dist / max(r, g.cell)) ** 2, 0.0, 1.0))
        g.z[rs, cs] = np.where(disc, g.z[rs, cs] + bump, g.z[rs, cs])
        g.terrain[rs, cs] = np.where(disc, _C["boulder"], g.terrain[rs, cs])


def _allowed(*names: str) -> np.ndarray:
    mask = np.zeros(len(TERRAIN_CLASSES), dtype=bool)
    mask[[_C[n] for n in names]] = True
    return mask


_LAND = ("wet_hard_sand", "soft_sand", "dirt", "vegetation", "rock", "kelp_wrack")


def _outcrops(
    g: _Grid, noise: _Noise, rng: np.random.Generator, intensity: float, river: _River | None
) -> list[_Outcrop]:
    """Rock platforms from the dune toe into the surf, ringed and strewn with boulders."""
    if intensity <= 0.0:
        return []
    n = max(1, round(intensity * g.length / 300.0))
    lay, sci = g.layout, g.sci
    s_lo = -0.6 * sci.surf_zone_width_m
    s_hi = sci.berm_distance_m + 0.3 * lay.dry_width_m
    b = (s_hi - s_lo) / 2.0
    s_c = (s_hi + s_lo) / 2.0
    rough = noise.field(4.0)
    out: list[_Outcrop] = []
    for _ in range(n):
        a = rng.uniform(12.0, 28.0) * (0.6 + 0.4 * min(intensity, 2.0))
        a = min(a, 0.2 * g.length)
        height = rng.uniform(1.0, 2.5)
        for _try in range(30):
            xc = rng.uniform(a + 5.0, g.length - a - 5.0) if g.length > 2 * a + 10 else g.length / 2
            clear = river is None or not river.near(xc, a + 25.0)
            if clear and all(abs(xc - o.x) > a + o.a + 20.0 for o in out):
                break
        else:
            continue
        out.append(_Outcrop(x=float(xc), s=float(s_c), a=float(a), b=float(b)))
        rs, cs = g.window(
            xc,
            float(np.mean(lay.shoreline_y)) + s_c,
            max(a, b) + 2.5 * abs(float(np.ptp(lay.shoreline_y))) + 5,
        )
        r = np.hypot((g.x[cs][None, :] - xc) / a, (g.s[rs, cs] - s_c) / b) + 0.2 * rough[rs, cs]
        mask = r < 1.0
        shelf = np.maximum(g.z[rs, cs], 0.0) + 0.3 + height * (1.0 - np.clip(r, 0.0, 1.0)) ** 0.7
        shelf = shelf + 0.25 * rough[rs, cs] * (1.0 - np.clip(r, 0.0, 1.0))
        g.z[rs, cs] = np.where(mask, np.maximum(g.z[rs, cs], shelf), g.z[rs, cs])
        g.terrain[rs, cs] = np.where(mask, _C["rock"], g.terrain[rs, cs])
        # boulders: a ring at the edge of the platform and some on it
        k = int(rng.poisson(1.5 * (a + b)))
        t = rng.uniform(0.0, 2.0 * math.pi, k)
        rad = np.clip(1.0 + rng.normal(0.0, 0.18, k), 0.3, 1.5)
        bx = xc + a * rad * np.cos(t)
        bs = s_c + b * rad * np.sin(t)
        by = np.interp(bx, g.x, lay.shoreline_y) + bs
        d = _pareto_diameters(rng, k, 0.8, 5.0)
        _place_rocks(g, bx, by, d, _allowed("surf", "shallow_water", *_LAND))
    return out


def _channels(
    g: _Grid, noise: _Noise, rng: np.random.Generator, river: _River | None, outcrops: list[_Outcrop]
) -> None:
    """Meandering run-off channels from the dune face to the sea."""
    lay = g.layout
    n = 1 + int(rng.poisson(g.length / 200.0))
    placed: list[float] = []
    for _ in range(n):
        d0 = rng.uniform(0.35, 0.9)
        w0 = rng.uniform(0.8, 1.8)
        amp = rng.uniform(1.5, 4.0)
        sigma = rng.uniform(5.0, 10.0)
        head = rng.uniform(0.0, 0.3)
        meander = noise.across(sigma)
        for _try in range(30):
            x0 = rng.uniform(0.05, 0.95) * g.length
            clear = river is None or not river.near(x0, 25.0)
            clear &= all(abs(x0 - o.x) > o.a + 15.0 for o in outcrops)
            if clear and all(abs(x0 - p) > 25.0 for p in placed):
                break
        else:
            continue
        placed.append(x0)
        col = g.col_of(x0)
        s_start = float(lay.dune_toe_s[col]) + head * lay.dune_width_m
        s_end = -1.5
        s_col = g.y - lay.shoreline_y[col]
        t = np.clip((s_col - s_end) / (s_start - s_end), 0.0, 1.0)  # 0 at the sea, 1 at the head
        rows = (s_col >= s_end) & (s_col <= s_start)
        fade = _smoothstep((s_col - s_end) / -s_end)  # the cut dies out just offshore
        depth = d0 * (0.35 + 0.65 * t) * _smoothstep((1.0 - t) / 0.12) * fade
        width = w0 * (1.0 + 1.0 * (1.0 - t))
        path = x0 + amp * np.clip(meander, -2.5, 2.5)
        reach = math.ceil((3.0 * amp + 4.0 * w0 * 2.5) / g.cell)
        c0, c1 = max(col - reach, 0), min(col + reach + 1, len(g.x))
        rs = np.flatnonzero(rows)
        if rs.size == 0:
            continue
        sub = np.s_[rs[0] : rs[-1] + 1, c0:c1]
        dx = g.x[None, c0:c1] - path[rs[0] : rs[-1] + 1, None]
        wd = width[rs[0] : rs[-1] + 1, None]
        cut = depth[rs[0] : rs[-1] + 1, None] * np.exp(-((dx / wd) ** 2))
        g.z[sub] = g.z[sub] - cut
        on_land = g.s[sub] >= 0.0
        ter = g.terrain[sub]
        soft = np.isin(ter, [_C["soft_sand"], _C["vegetation"], _C["dirt"], _C["wet_hard_sand"]])
        core = on_land & (np.abs(dx) < 0.5 * wd) & (depth[rs[0] : rs[-1] + 1, None] > 0.12) & soft
        banks = on_land & (np.abs(dx) < 1.6 * wd) & (cut > 0.05) & soft & ~core
        ter[banks] = _C["wet_hard_sand"]
        ter[core] = _C["shallow_water"]


def _scattered_rocks(g: _Grid, rng: np.random.Generator, intensity: float, river: _River | None) -> None:
    """Clusters of rocks of many sizes over the land, and a few lone boulders."""
    lay = g.layout
    inland = g.width - float(np.mean(lay.shoreline_y))
    area = g.length * inland
    n_clusters = int(rng.poisson(area / 2000.0 * (1.0 + 2.0 * intensity)))
    cx = rng.uniform(0.0, g.length, n_clusters)
    cs = rng.uniform(0.0, inland, n_clusters)
    spread = rng.uniform(1.0, 5.0, n_clusters)
    counts = np.minimum(1 + np.floor(2.0 * (1.0 - rng.random(n_clusters)) ** (-1.0 / 1.2)), 60).astype(int)
    total = int(counts.sum())
    which = np.repeat(np.arange(n_clusters), counts)
    xs = cx[which] + rng.normal(0.0, 1.0, total) * spread[which]
    ss = cs[which] + rng.normal(0.0, 1.0, total) * spread[which]
    d = _pareto_diameters(rng, total, 0.25, 4.0)
    n_lone = int(rng.poisson(g.length / 60.0))
    xs = np.concatenate([xs, rng.uniform(0.0, g.length, n_lone)])
    ss = np.concatenate([ss, rng.uniform(0.0, inland, n_lone)])
    d = np.concatenate([d, _pareto_diameters(rng, n_lone, 1.0, 3.0)])
    ys = np.interp(xs, g.x, lay.shoreline_y) + ss
    _place_rocks(g, xs, ys, d, _allowed("wet_hard_sand", "soft_sand", "dirt", "vegetation"))


def _kelp(g: _Grid, noise: _Noise) -> None:
    """Kelp wrack along the high-tide wrack line, patches lower on the intertidal band."""
    sci = g.sci
    streaks = noise.field(5.0, 1.2)
    s_wrack = sci.runup_distance_m
    near_line = np.exp(-(((g.s - s_wrack) / 2.0) ** 2))
    lower = np.exp(-(((g.s - 0.5 * (s_wrack + sci.setup_distance_m)) / 3.0) ** 2))
    kelp = streaks > 2.4 - 1.4 * near_line - 0.5 * lower
    kelp &= (g.s > sci.setup_distance_m) & (g.s < sci.berm_distance_m + 3.0)
    kelp &= np.isin(g.terrain, [_C["wet_hard_sand"], _C["soft_sand"]])
    g.terrain[kelp] = _C["kelp_wrack"]


def _driftwood(g: _Grid, rng: np.random.Generator) -> None:
    """Logs on the wrack line and the upper beach, mostly lying alongshore (impassable)."""
    sci, lay = g.sci, g.layout
    n = int(rng.poisson(g.length / 30.0))
    on_line = rng.random(n) < 0.6
    s_lo, s_hi = sci.runup_distance_m, float(np.min(lay.dune_toe_s))
    ss = np.where(on_line, s_lo + rng.normal(0.0, 1.5, n), rng.uniform(s_lo, max(s_hi, s_lo + 1.0), n))
    xs = rng.uniform(0.0, g.length, n)
    lengths = np.clip(rng.lognormal(math.log(4.0), 0.5, n), 1.5, 14.0)
    diam = rng.uniform(0.2, 0.8, n)
    aligned = rng.random(n) < 0.7
    angle = np.where(aligned, rng.normal(0.0, math.radians(25.0), n), rng.uniform(0.0, math.pi, n))
    ys = np.interp(xs, g.x, lay.shoreline_y) + ss
    allowed = _allowed("wet_hard_sand", "soft_sand", "kelp_wrack")
    for xm, ym, ln, dm, th in zip(xs, ys, lengths, diam, angle, strict=True):
        t = np.linspace(-ln / 2.0, ln / 2.0, max(2, int(ln / (g.cell / 3.0)) + 1))
        px, py = xm + t * math.cos(th), ym + t * math.sin(th)
        inside = (px >= 0) & (px < g.length) & (py >= 0) & (py < g.width)
        r = np.minimum((py[inside] // g.cell).astype(np.intp), len(g.y) - 1)
        c = np.minimum((px[inside] // g.cell).astype(np.intp), len(g.x) - 1)
        if r.size == 0:
            continue
        if dm > g.cell:  # thick log at a fine resolution: widen by one cell across
            r = np.concatenate([r, np.clip(r + 1, 0, len(g.y) - 1)])
            c = np.concatenate([c, c])
        ok = allowed[g.terrain[r, c]]
        if not ok.all():
            continue  # logs lie on sand, whole
        g.terrain[r, c] = _C["driftwood"]
        g.z[r, c] += dm


def _road(g: _Grid, noise: _Noise) -> None:
    """A coast road along the inland edge when there is room behind the dunes."""
    lay = g.layout
    if lay.back_width_m < 25.0:
        return
    y1 = g.width - 3.0
    y0 = y1 - 6.0
    rows = (g.y >= y0) & (g.y < y1)
    if not rows.any() or np.any(lay.shoreline_y + lay.dune_toe_s + lay.dune_width_m > y0 - 5.0):
        return
    level = gaussian_filter1d(g.z[rows].mean(axis=0), sigma=25.0 / g.cell, mode="nearest")
    # the road bed, and 5 m embankments blending it into the ground on either side
    dist = np.maximum(np.maximum(y0 - g.y, g.y - y1), 0.0)
    blend = (1.0 - _smoothstep(dist / 5.0))[:, None]
    water = np.isin(g.terrain, [_C["deep_water"], _C["shallow_water"], _C["wet_hard_sand"]])
    near = (blend > 0) & ~water
    g.z = np.where(near, blend * level[None, :] + (1.0 - blend) * g.z, g.z)
    g.terrain[rows] = np.where(water[rows], g.terrain[rows], _C["concrete"])


# --- regions ---------------------------------------------------------------------------------------
def _nearest(
    g: _Grid, xm: float, ym: float, classes: tuple[str, ...], clear_m: float = 0.0
) -> tuple[float, float]:
    """Centre of the nearest cell of one of `classes` (with `clear_m` of such cells around it)."""
    ok = np.isin(g.terrain, [_C[c] for c in classes])
    if clear_m > 0:
        k = max(1, round(clear_m / g.cell))
        ok = binary_erosion(ok, structure=np.ones((2 * k + 1, 2 * k + 1), bool), border_value=0)
    cand = np.argwhere(ok)
    if cand.size == 0:
        cand = np.argwhere(np.isin(g.terrain, [_C[c] for c in classes]))
    if cand.size == 0:
        raise RuntimeError(f"no {classes} on the generated map")
    d2 = (g.x[cand[:, 1]] - xm) ** 2 + (g.y[cand[:, 0]] - ym) ** 2
    r, c = cand[int(np.argmin(d2))]
    return float(g.x[c]), float(g.y[r])


def _band_polygon(g: _Grid, x0: float, x1: float, s0: float | np.ndarray, s1: float | np.ndarray) -> Polygon:
    """Polygon between s0 and s1 inland of the shoreline, from x0 to x1, following the shore."""
    xs = np.linspace(x0, x1, max(2, int((x1 - x0) / max(5.0, (x1 - x0) / 60.0)) + 1))
    shore = np.interp(xs, g.x, g.layout.shoreline_y)
    lo = np.clip(shore + s0, 0.0, g.width)
    hi = np.clip(shore + s1, 0.0, g.width)
    return Polygon(list(zip(xs, lo, strict=True)) + list(zip(xs[::-1], hi[::-1], strict=True)))


def _landing_zone(
    g: _Grid, lo_frac: float, hi_frac: float, avoid: list[tuple[float, float]]
) -> Polygon | None:
    """The clearest rectangle of wet hard sand between lo_frac and hi_frac of the shore, one cell
    inside the band if it is wide enough, else the band itself, shorter if need be; obstacles left
    in it are cleared (a landing lane is chosen free of them)."""
    sci = g.sci
    face = (g.s >= sci.setup_distance_m - 1.0) & (g.s <= sci.runup_distance_m + 2.0 * g.cell)
    wet = (g.terrain == _C["wet_hard_sand"]) & face
    rows_idx = np.arange(len(g.y))[:, None]
    lo = np.where(wet, rows_idx, len(g.y) + 1).min(axis=0)  # lowest wet row per column
    hi = np.where(wet, rows_idx, -1).max(axis=0)
    target = 0.5 * (lo_frac + hi_frac) * g.length
    length = float(np.clip(0.06 * g.length, 8.0, 40.0))
    for inset, shorten, min_rows in ((1, 1.0, max(2, math.ceil(2.0 / g.cell))), (0, 1.0, 1), (0, 0.5, 1)):
        ncol = max(3, round(shorten * length / g.cell))
        best, best_score = None, math.inf
        for c0 in range(int(lo_frac * len(g.x)), int(hi_frac * len(g.x)) - ncol, max(1, ncol // 4)):
            cs = slice(c0, c0 + ncol)
            xm = float(g.x[c0 + ncol // 2])
            if any(abs(xm - ax) < r + 0.5 * ncol * g.cell for ax, r in avoid):
                continue
            r0, r1 = int(lo[cs].max()) + inset, int(hi[cs].min()) - inset
            if r1 - r0 + 1 < min_rows:
                continue
            dirty = int(np.count_nonzero(g.terrain[r0 : r1 + 1, cs] != _C["wet_hard_sand"]))
            score = 10.0 * dirty - (r1 - r0 + 1) + 0.01 * abs(xm - target) / g.cell
            if score < best_score:
                best, best_score = (c0, r0, r1), score
        if best is not None:
            c0, r0, r1 = best
            g.terrain[r0 : r1 + 1, c0 : c0 + ncol] = _C["wet_hard_sand"]
            return Polygon.from_bounds(c0 * g.cell, r0 * g.cell, (c0 + ncol) * g.cell, (r1 + 1) * g.cell)
    return None


def _ellipse(g: _Grid, o: _Outcrop, grow: float, pad: float) -> Polygon:
    t = np.linspace(0.0, 2.0 * math.pi, 49)[:-1]
    xs = np.clip(o.x + (o.a * grow + pad) * np.cos(t), 0.0, g.length)
    ss = o.s + (o.b * grow + pad) * np.sin(t)
    ys = np.clip(np.interp(xs, g.x, g.layout.shoreline_y) + ss, 0.0, g.width)
    return Polygon(list(zip(xs, ys, strict=True))).buffer(0)


def _regions(g: _Grid, river: _River | None, outcrops: list[_Outcrop]) -> dict[str, Region]:
    sci, lay = g.sci, g.layout
    L = g.length
    regions: list[Region] = []
    shore_at = lambda xm: float(np.interp(xm, g.x, lay.shoreline_y))  # noqa: E731

    # two landing zones, one in each half of the shore if they fit there, clear of rocks and river
    avoid = [(o.x, o.a + 10.0) for o in outcrops]
    if river is not None:
        mouth = float(river.path_x[g.row_of(shore_at(L / 2))])
        avoid.append((mouth, float(river.half_width.max()) + 15.0))
    taken: list[tuple[float, float]] = []
    for name, span in (("landing_a", (0.1, 0.5)), ("landing_b", (0.5, 0.9))):
        for lo, hi, scale in ((*span, 1.0), (0.02, 0.98, 1.0), (0.02, 0.98, 0.5)):
            keep = [(x, r * scale) for x, r in avoid] + taken
            poly = _landing_zone(g, lo, hi, keep)
            if poly is not None:
                break
        if poly is None:
            continue
        regions.append(Region(name, "landing_zone", poly, {"terrain": "wet_hard_sand"}))
        x0, _, x1, _ = poly.bounds
        taken.append((0.5 * (x0 + x1), 0.5 * (x1 - x0) + 10.0))

    deep_s = -(sci.surf_zone_width_m + 0.5 * lay.deep_margin_m)
    fracs = (0.2, 0.5, 0.8) if L >= 150.0 else (0.3, 0.7)
    for i, f in enumerate(fracs):
        xm = f * L
        p = _nearest(g, xm, shore_at(xm) + deep_s, ("deep_water",), clear_m=2.0)
        regions.append(
            Region(
                f"launch_{i + 1}",
                "launch",
                Point(p),
                {"depth_m": round(-float(g.z[g.row_of(p[1]), g.col_of(p[0])]), 2)},
            )
        )
    xm = 0.4 * L
    p = _nearest(
        g, xm, shore_at(xm) - (sci.surf_zone_width_m + 0.7 * lay.deep_margin_m), ("deep_water",), 2.0
    )
    regions.append(Region("relay_source", "relay_source", Point(p)))

    top = float(np.min(lay.dune_toe_s)) + 0.5 * lay.dune_width_m
    top = min(top, 100.0)
    search = _band_polygon(g, 0.05 * L, 0.95 * L, 0.0, top)
    regions.append(Region("search_beach", "search_area", search))

    for i, o in enumerate(outcrops):
        regions.append(
            Region(
                f"keep_out_rocks_{i + 1}", "keep_out", _ellipse(g, o, 1.1, 4.0), {"reason": "rock outcrop"}
            )
        )
    if not outcrops:
        taken = [
            (r.geometry.centroid.x, 0.5 * (r.geometry.bounds[2] - r.geometry.bounds[0]) + 20.0)
            for r in regions
            if r.kind == "landing_zone"
        ]
        xs = [f * L for f in (0.08, 0.3, 0.5, 0.7, 0.92)]
        xc = max(xs, key=lambda v: min([abs(v - t) - r for t, r in taken], default=0.0))
        half = min(0.06 * L, 40.0)
        x0, x1 = max(xc - half, 0.0), min(xc + half, L)
        toe = float(np.min(lay.dune_toe_s))
        poly = _band_polygon(g, x0, x1, toe - 2.0, toe + lay.dune_width_m)
        regions.append(Region("keep_out_dunes", "keep_out", poly, {"reason": "protected dune vegetation"}))

    passable = ("dirt", "vegetation", "soft_sand", "concrete")
    s_back = float(np.max(lay.dune_toe_s)) + lay.dune_width_m + 0.5 * lay.back_width_m
    xm = 0.5 * L
    if river is not None and river.near(xm, 20.0):
        xm = (
            0.25 * L
            if abs(river.path_x.mean() - 0.25 * L) > abs(river.path_x.mean() - 0.75 * L)
            else 0.75 * L
        )
    p = _nearest(g, xm, min(shore_at(xm) + s_back, g.width - 1.0), passable, clear_m=2.0)
    regions.append(Region("rally", "rally", Point(p)))
    xm2 = min(xm + 0.15 * L, 0.95 * L)
    p = _nearest(g, xm2, g.width - 0.15 * lay.back_width_m - 2.0, passable, clear_m=1.0)
    regions.append(Region("relay_sink", "relay_sink", Point(p)))

    # the highest dune crest near the middle: an observation point
    c0, c1 = int(0.3 * len(g.x)), int(0.7 * len(g.x))
    toe = lay.dune_toe_s[None, c0:c1]
    in_dunes = (g.s[:, c0:c1] >= toe) & (g.s[:, c0:c1] <= toe + lay.dune_width_m)
    crest_ok = in_dunes & np.isin(g.terrain[:, c0:c1], [_C["vegetation"], _C["soft_sand"]])
    zc = np.where(crest_ok, g.z[:, c0:c1], -np.inf)
    r, c = np.unravel_index(int(np.argmax(zc)), zc.shape)
    regions.append(
        Region(
            "dune_lookout",
            "observation_point",
            Point(float(g.x[c0 + c]), float(g.y[r])),
            {"elevation_m": round(float(g.z[r, c0 + c]), 2)},
        )
    )
    # centimetre coordinates: plenty for a map, and short files
    return {
        r.name: Region(r.name, r.kind, shapely.set_precision(r.geometry, 0.01), r.properties) for r in regions
    }
