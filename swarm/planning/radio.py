"""Radio links between robots a few decimetres above the sand: path loss, link budget, range.

Path loss, as in Rappaport, *Wireless Communications: Principles and Practice*, 2nd ed., 2002:

- free space (Friis, eqs. 4.1 and 4.5), antenna gains kept out of the loss:
  ``L_fs(d) = 20 log10(4 pi d / lambda)`` dB;
- two-ray ground reflection (section 4.6, eq. 4.52: ``PL = 40 log d - (10 log G_t + 10 log G_r +
  20 log h_t + 20 log h_r)``), again without the gains: ``L_2r(d) = 40 log10 d - 20 log10(h_t h_r)``
  dB, valid far beyond the antenna heights, where the direct and ground-reflected rays nearly cancel
  and power falls as d^-4;
- the model used here is Friis below the crossover distance ``d_c = 4 pi h_t h_r / lambda`` and
  two-ray above it. ``d_c`` is where the two asymptotes meet, so the loss is continuous:
  ``40 log10 d_c - 20 log10(h_t h_r) = 20 log10(d_c^2 / (h_t h_r)) = 20 log10(4 pi d_c / lambda)``.
  (Goldsmith, *Wireless Communications*, 2005, section 2.4, calls ``4 h_t h_r / lambda`` the
  critical distance, a factor pi earlier: the last maximum of the exact two-ray curve.)

Link budget (Rappaport eq. 4.5 in dB): ``P_rx = P_tx + G_t + G_r - L(d)``. A link is planned to
close when ``P_rx >= sensitivity + fade margin``: the fade margin is the reserve against
shadowing. ``link_margin_db(d, radio)`` is what is left beyond that reserve: zero at
``comm_range_m(radio)``, positive inside it.

Shadowing (Rappaport section 4.9.2, eq. 4.69a): ``PL(d) = mean PL(d) + X_sigma`` with ``X_sigma``
zero-mean Gaussian in dB (log-normal in power). `shadowing_db` draws it from a passed
`numpy.random.Generator`; `link_closes` decides a link in the simulator; `outage_probability` is
the chance a link at distance d does not close, ``Phi((sensitivity - P_rx(d)) / sigma)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.stats import norm

from swarm.errors import SwarmError

#: Speed of light in vacuum, m/s.
SPEED_OF_LIGHT_MPS = 299_792_458.0


@dataclass(frozen=True)
class RadioParams:
    """One radio type, the same at both ends of a link unless the gains or heights differ.

    Defaults: a 2.4 GHz 802.15.4 module of the XBee-PRO class (18 dBm, -100 dBm sensitivity) with
    2.1 dBi dipoles on 0.5 m masts, a 10 dB fade margin and 6 dB shadowing (an assumption for open,
    flat ground: replace it with a value fitted to measured links on your beach).
    """

    frequency_hz: float = 2.4e9
    tx_power_dbm: float = 18.0
    tx_gain_dbi: float = 2.1
    rx_gain_dbi: float = 2.1
    tx_height_m: float = 0.5
    rx_height_m: float = 0.5
    sensitivity_dbm: float = -100.0
    fade_margin_db: float = 10.0
    shadowing_sigma_db: float = 6.0

    def __post_init__(self) -> None:
        for name in ("frequency_hz", "tx_height_m", "rx_height_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise SwarmError(f"radio: {name} must be a positive number, found {value!r}")
        if not (math.isfinite(self.shadowing_sigma_db) and self.shadowing_sigma_db >= 0):
            raise SwarmError(f"radio: shadowing_sigma_db must be >= 0, found {self.shadowing_sigma_db!r}")

    @property
    def wavelength_m(self) -> float:
        return SPEED_OF_LIGHT_MPS / self.frequency_hz

    @property
    def crossover_m(self) -> float:
        """d_c = 4 pi h_t h_r / lambda: Friis below, two-ray above."""
        return crossover_distance_m(self.tx_height_m, self.rx_height_m, self.frequency_hz)

    @property
    def required_dbm(self) -> float:
        """The received power a planned link must reach: sensitivity plus fade margin."""
        return self.sensitivity_dbm + self.fade_margin_db


def wavelength_m(frequency_hz: float) -> float:
    return SPEED_OF_LIGHT_MPS / frequency_hz


def crossover_distance_m(tx_height_m: float, rx_height_m: float, frequency_hz: float) -> float:
    """Where the Friis and two-ray asymptotes meet: 4 pi h_t h_r / lambda."""
    return 4.0 * math.pi * tx_height_m * rx_height_m / wavelength_m(frequency_hz)


def friis_loss_db(distance_m: np.ndarray | float, frequency_hz: float) -> np.ndarray:
    """Free-space path loss without antenna gains, 20 log10(4 pi d / lambda) dB (Rappaport eq. 4.5)."""
    d = np.asarray(distance_m, dtype=np.float64)
    return 20.0 * np.log10(4.0 * math.pi * d / wavelength_m(frequency_hz))


def two_ray_loss_db(distance_m: np.ndarray | float, tx_height_m: float, rx_height_m: float) -> np.ndarray:
    """Two-ray ground-reflection loss without antenna gains, 40 log10 d - 20 log10(h_t h_r) dB
    (Rappaport eq. 4.52 with the gain terms moved into the link budget)."""
    d = np.asarray(distance_m, dtype=np.float64)
    return 40.0 * np.log10(d) - 20.0 * math.log10(tx_height_m * rx_height_m)


def path_loss_db(distance_m: np.ndarray | float, radio: RadioParams) -> np.ndarray:
    """Friis below the crossover distance, two-ray above it (continuous at d_c)."""
    d = np.asarray(distance_m, dtype=np.float64)
    if np.any(d <= 0):
        raise SwarmError(f"radio: link distances must be > 0 m, found {float(np.min(d))!r}")
    return np.where(
        d <= radio.crossover_m,
        friis_loss_db(d, radio.frequency_hz),
        two_ray_loss_db(d, radio.tx_height_m, radio.rx_height_m),
    )


def received_power_dbm(distance_m: np.ndarray | float, radio: RadioParams) -> np.ndarray:
    """Mean received power, P_tx + G_t + G_r - L(d), dBm."""
    return radio.tx_power_dbm + radio.tx_gain_dbi + radio.rx_gain_dbi - path_loss_db(distance_m, radio)


def link_margin_db(distance_m: np.ndarray | float, radio: RadioParams) -> np.ndarray:
    """P_rx(d) - (sensitivity + fade margin): >= 0 where a link is planned to close."""
    return received_power_dbm(distance_m, radio) - radio.required_dbm


def comm_range_m(radio: RadioParams, *, max_range_m: float = 1e7) -> float:
    """The largest distance whose mean received power still reaches sensitivity + fade margin.

    Path loss grows monotonically with distance, so the link margin has one root; brentq finds
    it to ~1e-12 relative. Raises `SwarmError` if even 1 mm is out of budget.
    """
    lo = 1e-3
    if link_margin_db(lo, radio) < 0:
        raise SwarmError(
            f"radio: the link budget does not close even at {lo} m "
            f"(P_rx {float(received_power_dbm(lo, radio)):.1f} dBm < required {radio.required_dbm:.1f} dBm)"
        )
    hi = max(1.0, radio.crossover_m)
    while link_margin_db(hi, radio) >= 0:
        hi *= 2.0
        if hi > max_range_m:
            raise SwarmError(f"radio: the link budget still closes beyond {max_range_m:g} m")
    return float(brentq(lambda d: float(link_margin_db(d, radio)), lo, hi, xtol=1e-12, rtol=1e-14))


def shadowing_db(
    rng: np.random.Generator, sigma_db: float, size: int | tuple[int, ...] | None = None
) -> np.ndarray:
    """Log-normal shadowing: zero-mean Gaussian dB values with standard deviation `sigma_db`,
    added to the mean path loss (Rappaport eq. 4.69a)."""
    return rng.normal(0.0, sigma_db, size=size)


def link_closes(distance_m: np.ndarray | float, radio: RadioParams, rng: np.random.Generator) -> np.ndarray:
    """For the simulator: does each link close this time? One shadowing draw per link:
    P_rx(d) - X >= sensitivity. (The fade margin is the planner's reserve, not applied here.)"""
    d = np.asarray(distance_m, dtype=np.float64)
    loss = shadowing_db(rng, radio.shadowing_sigma_db, size=d.shape)
    return received_power_dbm(d, radio) - loss >= radio.sensitivity_dbm


def outage_probability(distance_m: np.ndarray | float, radio: RadioParams) -> np.ndarray:
    """Probability that a link at distance d does not close under log-normal shadowing:
    Phi((sensitivity - P_rx(d)) / sigma). At `comm_range_m` it is Phi(-fade margin / sigma)."""
    gap = radio.sensitivity_dbm - received_power_dbm(distance_m, radio)
    if radio.shadowing_sigma_db == 0:
        return (gap > 0).astype(np.float64)
    return norm.cdf(gap / radio.shadowing_sigma_db)
