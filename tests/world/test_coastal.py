"""The coastal-science functions against numbers worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swarm.world import coastal


def test_dean_a_from_grain_size():
    # 0.21 D^0.48: ln 0.2 = -1.60944, x 0.48 = -0.77253, e^ = 0.46184, x 0.21 = 0.096986
    assert coastal.dean_a_from_d50(0.2) == pytest.approx(0.096986, rel=1e-4)
    assert coastal.dean_a_from_d50(1.0) == pytest.approx(0.21)
    assert coastal.dean_a_from_d50(0.3) == pytest.approx(0.21 * 0.3**0.48)
    np.testing.assert_allclose(coastal.dean_a_from_d50(np.array([0.2, 1.0])), [0.096986, 0.21], rtol=1e-4)
    with pytest.raises(ValueError):
        coastal.dean_a_from_d50(0.0)


@pytest.mark.parametrize(
    ("d50_mm", "a_table"),
    # Dean & Dalrymple (2002) Table 7.2, as best recalled: 0.2 mm -> 0.100, 0.3 mm -> 0.125 m^(1/3)
    [(0.2, 0.100), (0.3, 0.125)],
)
def test_dean_a_near_the_tabulated_values(d50_mm, a_table):
    assert coastal.dean_a_from_d50(d50_mm) == pytest.approx(a_table, rel=0.07)
    w = coastal.fall_velocity(d50_mm)
    assert coastal.dean_a_from_fall_velocity(w) == pytest.approx(a_table, rel=0.04)


def test_fall_velocity_ferguson_church():
    # 0.2 mm: 1.65 * 9.81 * (2e-4)^2 = 6.4746e-7 over 18e-6 + sqrt(0.75 * 1.65 * 9.81 * 8e-12) = 27.853e-6
    assert coastal.fall_velocity(0.2) == pytest.approx(6.4746e-7 / 27.853e-6, rel=1e-3)  # 0.02325 m/s
    assert coastal.dean_a_from_fall_velocity(0.01) == pytest.approx(0.067)  # 1 cm/s
    # the two A(D) forms agree within 6% over medium sands, 15% at the ends
    d = np.array([0.15, 0.2, 0.3, 0.5, 0.7, 1.0])
    ratio = coastal.dean_a_from_fall_velocity(coastal.fall_velocity(d)) / coastal.dean_a_from_d50(d)
    assert np.all(np.abs(ratio - 1.0) < 0.06)


def test_dean_depth_and_its_inverse():
    assert coastal.dean_depth(100.0, 0.1) == pytest.approx(0.1 * 100.0 ** (2 / 3))  # 2.1544 m
    assert coastal.dean_depth(100.0, 0.1) == pytest.approx(2.15443, rel=1e-5)
    assert coastal.dean_depth(-5.0, 0.1) == 0.0
    assert coastal.dean_distance(2.15443469, 0.1) == pytest.approx(100.0, rel=1e-6)
    x = np.linspace(0.0, 300.0, 7)
    np.testing.assert_allclose(coastal.dean_distance(coastal.dean_depth(x, 0.12), 0.12), x, atol=1e-9)


def test_breaker_depth_and_surf_zone_width():
    assert coastal.breaker_depth(1.0) == pytest.approx(1.0 / 0.78)  # 1.28205 m
    assert coastal.breaker_depth(1.0, gamma=0.5) == pytest.approx(2.0)
    # (1.28205 / 0.1)^1.5 = 12.8205^1.5 = 45.905 m
    assert coastal.surf_zone_width(1.0, 0.1) == pytest.approx(45.905, rel=1e-4)
    # and the Dean depth there is the breaker depth
    xb = coastal.surf_zone_width(1.5, 0.2)
    assert coastal.dean_depth(xb, 0.2) == pytest.approx(1.5 / 0.78)


def test_foreshore_slope_from_wiegel_table():
    fine_mid = math.sqrt(0.125 * 0.25)  # 0.1768 mm, fine sand: 3 deg
    medium_mid = math.sqrt(0.25 * 0.5)  # 0.3536 mm, medium sand: 5 deg
    assert coastal.foreshore_slope(fine_mid) == pytest.approx(math.tan(math.radians(3.0)))  # 0.05241
    assert coastal.foreshore_slope(medium_mid) == pytest.approx(math.tan(math.radians(5.0)))  # 0.08749
    # half way (in log size) between them: 4 deg
    assert coastal.foreshore_slope(math.sqrt(fine_mid * medium_mid)) == pytest.approx(
        math.tan(math.radians(4.0))
    )
    # held at the ends of the table: very fine sand 1 deg, cobbles 24 deg
    assert coastal.foreshore_slope(0.01) == pytest.approx(math.tan(math.radians(1.0)))
    assert coastal.foreshore_slope(1000.0) == pytest.approx(math.tan(math.radians(24.0)))
    d = np.geomspace(0.06, 300.0, 50)
    assert np.all(np.diff(coastal.foreshore_slope(d)) >= 0)  # coarser is steeper


def test_deep_water_wave():
    assert coastal.deep_water_wavelength(8.0) == pytest.approx(9.81 * 64 / (2 * math.pi))  # 99.924 m
    assert coastal.deep_water_wavelength(8.0) == pytest.approx(99.924, rel=1e-4)
    # Komar & Gaughan: H_b = 0.39 g^(1/5) (T H0^2)^(2/5); the inverse gives H0 back
    h0 = coastal.deep_water_height_from_breaker(1.0, 8.0)
    assert 0.39 * 9.81**0.2 * (8.0 * h0**2) ** 0.4 == pytest.approx(1.0)
    assert h0 == pytest.approx(0.6482, rel=1e-3)


def test_stockdon_runup_by_hand():
    # H0 = 1 m, L0 = 100 m, beta = 0.1: sqrt(H0 L0) = 10
    # setup 0.35 * 0.1 * 10 = 0.35; swash sqrt(100 * (0.563 * 0.01 + 0.004)) = sqrt(0.963) = 0.98133
    # R2 = 1.1 * (0.35 + 0.98133 / 2) = 0.92473
    assert coastal.stockdon_setup(1.0, 100.0, 0.1) == pytest.approx(0.35)
    assert coastal.stockdon_swash(1.0, 100.0, 0.1) == pytest.approx(0.98133, rel=1e-5)
    assert coastal.stockdon_runup_r2(1.0, 100.0, 0.1) == pytest.approx(0.92473, rel=1e-5)
    # the dissipative limit: no slope, R2 = 1.1 * sqrt(H0 L0 0.004) / 2
    assert coastal.stockdon_runup_r2(1.0, 100.0, 0.0) == pytest.approx(1.1 * math.sqrt(0.4) / 2)
    assert coastal.iribarren(0.1, 1.0, 100.0) == pytest.approx(1.0)
    np.testing.assert_allclose(
        coastal.stockdon_runup_r2(np.array([1.0, 1.0]), 100.0, np.array([0.1, 0.1])),
        [0.92473, 0.92473],
        rtol=1e-5,
    )


def test_berm_height_and_cusp_spacing():
    # 0.125 * 1^(5/8) * (9.81 * 64)^(3/8) = 0.125 * 627.84^0.375 = 0.125 * 11.199 = 1.3999 m
    assert coastal.berm_height(1.0, 8.0) == pytest.approx(1.3999, rel=1e-4)
    # g T^2 tan(beta) / pi = 9.81 * 64 * 0.1 / pi = 19.985 m
    assert coastal.cusp_spacing(8.0, 0.1) == pytest.approx(19.985, rel=1e-4)


def test_local_breaker_height_is_depth_limited_inside_the_surf_zone_only():
    """H = min(H_b, gamma h) on surf cells [McCowan; Dean91], depths below the floor counted as the
    floor, and 0 off the surf zone: 1 m breakers over 0.5 m of water are 0.39 m high."""
    elevation = np.array([[-3.0, -1.0, -0.5, -0.01, 0.2]])
    surf = np.array([[False, True, True, True, False]])
    h = coastal.local_breaker_height(elevation, surf, 1.0, min_depth_m=0.05)
    assert h[0].tolist() == pytest.approx([0.0, 0.78, 0.39, 0.78 * 0.05, 0.0])
    # never above the offshore height, however deep
    assert coastal.local_breaker_height(np.array([-10.0]), np.array([True]), 1.0)[0] == 1.0
