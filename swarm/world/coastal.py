"""Coastal science for the beach generator: small pure functions, each with its source.

Units: metres, seconds, grain size in millimetres where the name says `_mm`. Depths are positive
down, distances positive away from the shoreline. Every function takes floats or numpy arrays.

References
  [Dean77]   R. G. Dean, "Equilibrium beach profiles: U.S. Atlantic and Gulf coasts", Ocean Eng.
             Rep. 12, Univ. of Delaware, 1977: h = A x^(2/3).
  [Dean87]   R. G. Dean, "Coastal sediment processes: toward engineering solutions", Coastal
             Sediments '87, ASCE, 1987: A = 0.067 w^0.44 (w fall velocity in cm/s).
  [Dean91]   R. G. Dean, "Equilibrium beach profiles: characteristics and applications", J. Coastal
             Res. 7(1), 53-84, 1991: A(D) after Moore's data; breaking index kappa = 0.78.
  [Moore82]  B. D. Moore, "Beach profile evolution in response to changes in water level and wave
             height", M.S. thesis, Univ. of Delaware, 1982: A against grain size D, fitted as
             A = 0.21 D^0.48 (D in mm, A in m^(1/3)).
  [DD02]     R. G. Dean, R. A. Dalrymple, Coastal Processes with Engineering Applications, Cambridge,
             2002, ch. 7, Table 7.2: recommended A per grain size (0.20 mm -> 0.100, 0.30 mm ->
             0.125, 0.50 mm -> ~0.15, 1.0 mm -> ~0.2 m^(1/3), as best recalled; see the tests).
  [FC04]     R. I. Ferguson, M. Church, "A simple universal equation for grain settling velocity",
             J. Sediment. Res. 74(6), 933-937, 2004: w = R g D^2 / (C1 nu + sqrt(0.75 C2 R g D^3)),
             C1 = 18, C2 = 1.0 for natural sand.
  [McCowan]  J. McCowan, "On the highest wave of permanent type", Phil. Mag. 38, 1894: H_b / h_b =
             0.78 for a solitary wave; the usual depth-limited breaking index.
  [Wiegel65] R. L. Wiegel, Oceanographical Engineering, Prentice-Hall, 1965 (after Bascom 1951 and
             Shepard 1963): average beach-face slope per Wentworth class: very fine sand 1 deg, fine
             3, medium 5, coarse 7, very coarse 9, granules 11, pebbles 17, cobbles 24 deg.
  [Bascom51] W. N. Bascom, "The relationship between sand size and beach-face slope", Trans. AGU
             32(6), 866-874, 1951.
  [KG73]     P. D. Komar, M. K. Gaughan, "Airy wave theory and breaker height prediction", Proc.
             13th ICCE, 1973: H_b = 0.39 g^(1/5) (T H0^2)^(2/5).
  [Stock06]  H. F. Stockdon, R. A. Holman, P. A. Howd, A. H. Sallenger, "Empirical parameterization
             of setup, swash, and runup", Coastal Eng. 53, 573-588, 2006: eqs. 10, 11, 19.
  [TS82]     I. Takeda, T. Sunamura, "Formation and height of berms", Trans. Japanese Geomorph.
             Union 3, 145-157, 1982: berm height 0.125 H_b^(5/8) (g T^2)^(3/8).
  [GI75]     R. T. Guza, D. L. Inman, "Edge waves and beach cusps", J. Geophys. Res. 80(21),
             2997-3012, 1975: cusp spacing from subharmonic edge waves, (g T^2 / pi) tan(beta).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import gaussian_filter

#: Gravitational acceleration, m/s^2.
G_MPS2 = 9.81
#: Second-harmonic ratio r of the wave velocity shape (cos phi + r cos 2 phi) / (1 + r): velocity
#: skewness 0.76, within surf-zone observations [Ruessink et al. 2012, Coastal Eng. 65, 56-63].
WAVE_SKEW = 0.5
#: Shallowest still-water depth used for wave velocities, m: keeps u = (H/2) sqrt(g/h) finite.
MIN_DEPTH_M = 0.05
#: Gaussian smoothing of the elevation for the shoreward direction, cells: follows the beach's
#: trend rather than single-cell bumps.
SHOREWARD_SMOOTHING_CELLS = 3.0
#: Smoothed gradient below which a cell has no shoreward direction of its own (falls back to +y).
_FLAT_GRADIENT = 1e-6

#: Depth-limited breaking index H_b / h_b for a solitary wave [McCowan], used by [Dean91].
BREAKING_INDEX = 0.78

# [Wiegel65] classes: geometric mid-point of each Wentworth class (mm) -> average slope (deg).
_SLOPE_CLASS_D_MM = np.array(
    [
        np.sqrt(0.0625 * 0.125),  # very fine sand
        np.sqrt(0.125 * 0.25),  # fine sand
        np.sqrt(0.25 * 0.5),  # medium sand
        np.sqrt(0.5 * 1.0),  # coarse sand
        np.sqrt(1.0 * 2.0),  # very coarse sand
        np.sqrt(2.0 * 4.0),  # granules
        np.sqrt(4.0 * 64.0),  # pebbles
        np.sqrt(64.0 * 256.0),  # cobbles
    ]
)
_SLOPE_CLASS_DEG = np.array([1.0, 3.0, 5.0, 7.0, 9.0, 11.0, 17.0, 24.0])


def _positive(name: str, value: np.ndarray | float) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    return arr


def _out(value: np.ndarray) -> np.ndarray | float:
    return float(value) if np.ndim(value) == 0 else value


# --- sediment and the equilibrium profile -------------------------------------------------------
def dean_a_from_d50(d50_mm: np.ndarray | float) -> np.ndarray | float:
    """Dean's profile scale parameter A (m^(1/3)) from the median grain size.

    A = 0.21 D^0.48 with D in mm: the power-law fit to Moore's (1982) A-against-D curve used by
    Dean (1987, 1991) [Moore82, Dean91]. Gives 0.097 for 0.2 mm, 0.118 for 0.3 mm, 0.21 for
    1 mm; Dean & Dalrymple's Table 7.2 [DD02] lists about 0.100, 0.125 and 0.2 there (our best
    recollection of the table). The fall-velocity form (`dean_a_from_fall_velocity` of
    `fall_velocity`) agrees within 6% between 0.15 and 1 mm, within 15% at 0.1 and 2 mm.
    """
    d = _positive("d50_mm", d50_mm)
    return _out(0.21 * d**0.48)


def fall_velocity(
    d50_mm: np.ndarray | float,
    *,
    submerged_specific_gravity: float = 1.65,
    kinematic_viscosity_m2ps: float = 1.0e-6,
) -> np.ndarray | float:
    """Settling velocity (m/s) of natural sand grains [FC04], quartz in water at ~20 C by default.

    w = R g D^2 / (C1 nu + sqrt(0.75 C2 R g D^3)), C1 = 18, C2 = 1.0 (natural, angular grains).
    About 0.023 m/s for 0.2 mm, 0.040 for 0.3 mm, 0.126 for 1 mm.
    """
    d = _positive("d50_mm", d50_mm) * 1e-3
    r = submerged_specific_gravity
    w = r * G_MPS2 * d**2 / (18.0 * kinematic_viscosity_m2ps + np.sqrt(0.75 * 1.0 * r * G_MPS2 * d**3))
    return _out(w)


def dean_a_from_fall_velocity(w_mps: np.ndarray | float) -> np.ndarray | float:
    """Dean's A (m^(1/3)) from the sediment fall velocity: A = 0.067 w^0.44, w in cm/s [Dean87]."""
    w = _positive("fall velocity", w_mps)
    return _out(0.067 * (w * 100.0) ** 0.44)


def dean_depth(x_m: np.ndarray | float, a: float) -> np.ndarray | float:
    """Equilibrium water depth h = A x^(2/3) at distance x seaward of the shoreline [Dean77].

    Zero at and landward of the shoreline (x <= 0).
    """
    x = np.maximum(np.asarray(x_m, dtype=np.float64), 0.0)
    return _out(a * x ** (2.0 / 3.0))


def dean_distance(h_m: np.ndarray | float, a: float) -> np.ndarray | float:
    """Inverse of `dean_depth`: the distance from the shoreline where the depth is h, (h/A)^(3/2)."""
    h = np.maximum(np.asarray(h_m, dtype=np.float64), 0.0)
    return _out((h / a) ** 1.5)


# --- waves ----------------------------------------------------------------------------------------
def breaker_depth(breaker_height_m: np.ndarray | float, gamma: float = BREAKING_INDEX) -> np.ndarray | float:
    """Water depth where waves of height H_b break: h_b = H_b / gamma [McCowan, Dean91]."""
    hb = _positive("breaker_height_m", breaker_height_m)
    return _out(hb / gamma)


def surf_zone_mask(
    elevation_m: np.ndarray, water: np.ndarray, breaker_height_m: float, min_depth_m: float = 0.05
) -> np.ndarray:
    """Cells in the surf zone: water (`water`, a boolean grid) shallower than the breaker depth
    H_b / gamma and lower than the breaker crest (still water level 0, depths below `min_depth_m`
    count as that)."""
    depth = np.maximum(min_depth_m, -np.asarray(elevation_m, dtype=np.float64))
    hb = float(breaker_height_m)
    return np.asarray(water, bool) & (depth < hb / BREAKING_INDEX) & (np.asarray(elevation_m) < hb)


def local_breaker_height(
    elevation_m: np.ndarray, surf: np.ndarray, breaker_height_m: float, min_depth_m: float = 0.05
) -> np.ndarray:
    """The height of the breakers over each cell of the surf zone `surf` (0 elsewhere): the
    offshore breaker height, or the depth-limited gamma x depth where the water is shallower
    [McCowan, Dean91] (depths below `min_depth_m` count as that). A breaker's damage and its push
    on a robot depend on this, not on the offshore height."""
    depth = np.maximum(min_depth_m, -np.asarray(elevation_m, dtype=np.float64))
    return np.where(surf, np.minimum(breaker_height_m, BREAKING_INDEX * depth), 0.0)


def wave_shape(phi: float, skew: float = WAVE_SKEW) -> float:
    """Shoreward wave orbital velocity over its crest value at wave phase `phi` (rad, 0 at a crest):
    (cos phi + r cos 2 phi) / (1 + r), the second-order Stokes form; zero mean, 1 at the crest and a
    weaker, longer trough (-0.5 at r = 0.5)."""
    return (math.cos(phi) + skew * math.cos(2.0 * phi)) / (1.0 + skew)


def shoreward_direction(elevation_m: np.ndarray, cell_m: float) -> np.ndarray:
    """(rows, cols, 2) the unit uphill direction of the elevation smoothed over
    `SHOREWARD_SMOOTHING_CELLS` cells: where the breakers run; +y (north) where it is flat."""
    elevation = np.asarray(elevation_m, dtype=np.float64)
    smooth = gaussian_filter(elevation, SHOREWARD_SMOOTHING_CELLS, mode="nearest")
    s_dy, s_dx = np.gradient(smooth, cell_m)
    norm = np.hypot(s_dx, s_dy)
    flat = norm < _FLAT_GRADIENT
    safe = np.where(flat, 1.0, norm)
    return np.stack([np.where(flat, 0.0, s_dx / safe), np.where(flat, 1.0, s_dy / safe)], axis=-1)


def surf_zone_width(
    breaker_height_m: np.ndarray | float, a: float, gamma: float = BREAKING_INDEX
) -> np.ndarray | float:
    """Distance from the shoreline to the breaker line on a Dean profile: x_b = (H_b / (gamma A))^(3/2).

    1 m breakers on 0.2 mm sand (A = 0.097): h_b = 1.28 m, x_b = 48 m.
    """
    return dean_distance(breaker_depth(breaker_height_m, gamma), a)


def deep_water_wavelength(period_s: np.ndarray | float) -> np.ndarray | float:
    """Deep-water wavelength L0 = g T^2 / (2 pi) (linear wave theory). 99.9 m for T = 8 s."""
    t = _positive("wave period", period_s)
    return _out(G_MPS2 * t**2 / (2.0 * np.pi))


def deep_water_height_from_breaker(
    breaker_height_m: np.ndarray | float, period_s: np.ndarray | float
) -> np.ndarray | float:
    """Deep-water wave height H0 that breaks at H_b, inverting Komar & Gaughan (1973) [KG73].

    H_b = 0.39 g^(1/5) (T H0^2)^(2/5)  =>  H0 = (H_b / (0.39 g^(1/5) T^(2/5)))^(5/4).
    H_b = 1 m, T = 8 s gives H0 = 0.65 m (long swell shoals to a higher breaker).
    """
    hb = _positive("breaker_height_m", breaker_height_m)
    t = _positive("wave period", period_s)
    return _out((hb / (0.39 * G_MPS2**0.2 * t**0.4)) ** 1.25)


def iribarren(beta_f: np.ndarray | float, h0_m: np.ndarray | float, l0_m: np.ndarray | float):
    """Iribarren number xi = beta_f / sqrt(H0 / L0): below ~0.3 dissipative, above ~1.25 reflective."""
    return _out(np.asarray(beta_f) / np.sqrt(np.asarray(h0_m) / np.asarray(l0_m)))


def stockdon_setup(h0_m, l0_m, beta_f) -> np.ndarray | float:
    """Time-mean wave setup at the shoreline, <eta> = 0.35 beta_f sqrt(H0 L0) [Stock06 eq. 10]."""
    return _out(0.35 * np.asarray(beta_f) * np.sqrt(np.asarray(h0_m) * np.asarray(l0_m)))


def stockdon_swash(h0_m, l0_m, beta_f) -> np.ndarray | float:
    """Significant swash height (incident and infragravity), S = sqrt(H0 L0 (0.563 beta_f^2 + 0.004))
    [Stock06 eqs. 11, 12]."""
    b = np.asarray(beta_f)
    return _out(np.sqrt(np.asarray(h0_m) * np.asarray(l0_m) * (0.563 * b**2 + 0.004)))


def stockdon_runup_r2(h0_m, l0_m, beta_f) -> np.ndarray | float:
    """2% exceedance run-up elevation above the still water level [Stock06 eq. 19]:

    R2 = 1.1 (0.35 beta_f sqrt(H0 L0) + sqrt(H0 L0 (0.563 beta_f^2 + 0.004)) / 2)

    H0 deep-water significant wave height, L0 deep-water wavelength, beta_f foreshore slope
    (tan). H0 = 0.65 m, L0 = 99.9 m, beta_f = 0.0585 gives R2 = 0.52 m.
    """
    h0 = np.asarray(h0_m, dtype=np.float64)
    l0 = np.asarray(l0_m, dtype=np.float64)
    return _out(
        1.1 * (np.asarray(stockdon_setup(h0, l0, beta_f)) + np.asarray(stockdon_swash(h0, l0, beta_f)) / 2.0)
    )


# --- the beach face -------------------------------------------------------------------------------
def foreshore_slope(d50_mm: np.ndarray | float) -> np.ndarray | float:
    """Beach-face (foreshore) slope tan(beta) from the median grain size [Wiegel65, Bascom51].

    Wiegel's table of average beach-face slope per Wentworth size class (very fine sand 1 deg ...
    cobbles 24 deg), interpolated linearly in degrees against log grain size between the classes'
    geometric mid-points and held at the end values outside them. 0.2 mm -> 3.4 deg (tan 0.059),
    0.3 mm -> 4.5 deg (0.079), 1 mm -> 8 deg (0.14), 1.5 mm -> 9.2 deg (0.16). Exposed, high-energy
    beaches are flatter than this average for the same sand, sheltered ones steeper [Bascom51].
    """
    d = _positive("d50_mm", d50_mm)
    deg = np.interp(np.log(d), np.log(_SLOPE_CLASS_D_MM), _SLOPE_CLASS_DEG)
    return _out(np.tan(np.radians(deg)))


def berm_height(breaker_height_m: np.ndarray | float, period_s: np.ndarray | float) -> np.ndarray | float:
    """Berm crest height above the (high-tide) still water level, 0.125 H_b^(5/8) (g T^2)^(3/8) [TS82].

    1 m breakers with 8 s swell build a berm 1.4 m high.
    """
    hb = _positive("breaker_height_m", breaker_height_m)
    t = _positive("wave period", period_s)
    return _out(0.125 * hb**0.625 * (G_MPS2 * t**2) ** 0.375)


def cusp_spacing(period_s: np.ndarray | float, beta_f: np.ndarray | float) -> np.ndarray | float:
    """Beach-cusp spacing from subharmonic zero-mode edge waves, (g T^2 / pi) tan(beta) [GI75].

    An 8 s swell on a 0.0586 beach face: 11.7 m.
    """
    t = _positive("wave period", period_s)
    return _out(G_MPS2 * t**2 / np.pi * np.asarray(beta_f))
