"""Turning of the `skid` model from pivots to wide arcs, against the skid-steer literature's closed
forms: the pivot's yaw moment balance on the friction ellipsoid (the ICR spread of Mandow et al.,
IROS 2007, for a pivot), the rolling-resistance moment a pivot must overcome (Kozlowski & Pazderski,
AMCS 14(4), 2004), and Steeds' turning-resistance law on firm ground [Wong08, ch. 7]."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from swarm.robot.params import GRAVITY_MPS2, load_robot
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.robot.terrain import TerrainMode, load_library

ROOT = Path(__file__).resolve().parents[2]
ROBOT = load_robot(ROOT / "swarm" / "data" / "robots" / "skid4.yaml")
LIB = load_library()
A, B = ROBOT.track_width_m / 2, ROBOT.wheelbase_m / 2  # contact arms across and along


def steady_states(
    modes: list[TerrainMode], omega: np.ndarray, t_s: float = 8.0, dt: float = 0.002
) -> np.ndarray:
    """States (n, 6) after `t_s` of constant wheel speeds, one robot per mode, from rest."""
    model = SkidModel(ROBOT, regularization_mps=1e-4)
    c = coeffs_for(modes)
    state = np.zeros((len(modes), 6))
    for _ in range(int(t_s / dt)):
        state = model.step(state, omega, c, dt)
    return state


def pivot_efficiency(mu_x: float, mu_y: float, spin_m: float) -> float:
    """Yaw rate over the kinematic W / A in a steady pivot without rolling resistance.

    Every patch slips by the same amount, so whatever the traction-slip law the moments balance
    along the slip directions alone: A mu_x (W - A r) = mu_y (B^2 + rho^2) r, rho = spin_m / mu_y
    (longitudinal drive against the lateral and spin resistance of each patch)."""
    drive = mu_x * A * A
    return drive / (drive + mu_y * B * B + spin_m * spin_m / mu_y)


@pytest.mark.parametrize("shear_slip", [0.01, 0.08, 0.3])
def test_steady_pivot_follows_the_friction_ellipsoid_whatever_the_shear_modulus(shear_slip: float) -> None:
    """Anisotropic friction and spin friction, and traction anywhere from near-Coulomb to far from
    saturated: the pivot's yaw rate is set by the ellipsoid's moment balance alone, and does not
    depend on how fast the wheels turn (the slips are ratios)."""
    cases = [(0.8, 0.5, 0.0), (0.6, 0.7, 0.1), (0.5, 0.3, 0.05)]
    modes = [
        replace(
            LIB["concrete"],
            mu_peak=mx,
            mu_lateral=my,
            turning_resistance_m=tau,
            shear_slip=shear_slip,
            rolling_resistance=0.0,
        )
        for mx, my, tau in cases
    ]
    for wheel in (3.0, 9.0):
        omega = np.tile([-wheel, wheel], (len(modes), 1))
        s = steady_states(modes, omega)
        kinematic = wheel * ROBOT.wheel_radius_m / A
        for (mx, my, tau), got in zip(cases, s, strict=True):
            assert got[5] / kinematic == pytest.approx(pivot_efficiency(mx, my, tau), rel=2e-3)
            assert abs(got[3]) < 1e-9 and abs(got[4]) < 1e-9  # turns in place


def test_rolling_resistance_resists_a_pivot_by_its_moment() -> None:
    """In a pivot each wheel's hub travels along its heading (A r), so rolling resistance c_rr N
    opposes it with the moment A c_rr W. Near Coulomb contacts (every patch fully sliding, force
    mu N along the slip) the balance per unit load is
    A mu_x (W - A r) / |s| - mu_y (B^2 + rho^2) r / |s| = A c_rr,  |s| = |(W - A r, B r, rho r)|,
    solved here for r with a root finder."""
    mx, my, tau, crr = 0.7, 0.6, 0.05, 0.08
    mode = replace(
        LIB["concrete"],
        mu_peak=mx,
        mu_lateral=my,
        turning_resistance_m=tau,
        shear_slip=0.002,
        rolling_resistance=crr,
    )
    wheel = 6.0
    w = wheel * ROBOT.wheel_radius_m
    rho = tau / my

    def balance(r: float) -> float:
        slip = math.sqrt((w - A * r) ** 2 + (B * r) ** 2 + (rho * r) ** 2)
        return (A * mx * (w - A * r) - my * (B * B + rho * rho) * r) / slip - A * crr

    expected = brentq(balance, 0.0, w / A)
    s = steady_states([mode], np.array([[-wheel, wheel]]), dt=0.0005, t_s=3.0)[0]
    assert s[5] == pytest.approx(expected, rel=5e-3)
    without = pivot_efficiency(mx, my, tau) * w / A
    assert s[5] < 0.95 * without  # it is a real share of the resistance, not a rounding


def test_turning_resistance_on_firm_ground_follows_steeds() -> None:
    """On concrete, the lateral forces' resisting moment over the full-sliding value mu_lat W B
    falls with the turn's radius as Steeds' empirical law for skid steering on firm ground does,
    mu_t / mu = 1 / (0.925 + 0.15 R / T) (R to the centre, T the track) [Wong08, ch. 7]: the
    shear-displacement (Janosi-Hanamoto) lateral force is far from saturated in a wide arc and
    saturates toward a pivot."""
    mode = LIB["concrete"]
    ratios = np.array([1.0, 1.5, 2.0, 3.0, 5.0, 8.0, 12.0])
    v = 0.4
    r_cmd = v / (ratios * ROBOT.track_width_m)
    omega = np.stack([v - r_cmd * A, v + r_cmd * A], -1) / ROBOT.wheel_radius_m
    s = steady_states([mode] * len(ratios), omega, t_s=20.0, dt=0.005)
    model = SkidModel(ROBOT, regularization_mps=1e-4)
    moment = -model.turning_resistance_moment(s, omega, coeffs_for([mode] * len(ratios)))
    mu_t = moment / (mode.mu_lateral * ROBOT.mass_kg * GRAVITY_MPS2 * B)
    radius = s[:, 3] / s[:, 5] / ROBOT.track_width_m
    steeds = 1.0 / (0.925 + 0.15 * radius)
    assert np.all(np.diff(mu_t) < 0)  # monotone: wider turns resist less
    np.testing.assert_allclose(mu_t, steeds, atol=0.06)
