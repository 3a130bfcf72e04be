"""The fixed layouts of observations, global state and actions: named fields with their bounds, so
users (and the Box spaces) see what each column means.

Every robot's observation is one float32 vector (`ObservationLayout.names` gives a name per column):

- own state and health: position (m), heading as cos/sin, body velocities u, v (m/s), yaw rate r
  (rad/s), battery state of charge, inverted flag, submersion (buoyancy fraction of its cell),
  longitudinal slip, and its phase as one-hot (`PHASES`);
- a local patch of `patch_size` x `patch_size` samples `patch_spacing_m` apart in the robot's body
  frame (rows forward, columns left): the terrain's speed fraction (mode speed / fastest mode, 0 where
  impassable or no progress) and the elevation relative to the robot (m, clipped to +-`ELEVATION_CLIP_M`);
- its `neighbours` nearest robots on the map as of the last radio update (the table its radio
  keeps; refreshed at once when a robot arrives on the map): present flag (0 for one lost since),
  body-frame offset (m), distance (m), and whether a radio link to it works;
- its links: number of working links, linked to the relay source, hops to it (-1 none), seconds
  since it last had any link;
- its task: role one-hot (`ROLES`), body-frame offset and distance to its current goal, route
  progress, marking flag, and the body-frame offset of the nearest mine it knows of that nobody
  marks (0 if none);
- mission time as a fraction of the time limit, and the time to the synchronized clearance (s, 0
  without one or once it is past).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: Each robot's phase of the concept of operations (thesis 1.2).
PHASES = ("waiting", "sea_transit", "surf_crossing", "beach", "returning", "done")
#: Roles (as in `swarm.mission.plan.ROLES`).
ROLES = ("landing", "search", "relay", "surveillance", "beacon", "spare")
#: Relative elevation in the terrain patch is clipped to this (m).
ELEVATION_CLIP_M = 5.0
#: Per-robot columns of the global state (`state()`), each robot's row in `possible_agents` order.
STATE_FIELDS = (
    "alive",
    "x_m",
    "y_m",
    "cos_heading",
    "sin_heading",
    "u_mps",
    "v_mps",
    "r_radps",
    "battery",
    "inverted",
    "phase",
    "role",
)
#: Mission-wide columns at the end of the global state.
GLOBAL_FIELDS = ("time_fraction", "mines_detected", "mines_marked", "mines_exploded", "score")


@dataclass(frozen=True)
class ObservationLayout:
    """Column names and bounds of the per-robot observation vector."""

    patch_size: int = 5
    patch_spacing_m: float = 1.0
    neighbours: int = 4

    @cached_property
    def names(self) -> tuple[str, ...]:
        own = ["x_m", "y_m", "cos_heading", "sin_heading", "u_mps", "v_mps", "r_radps", "battery",
               "inverted", "submersion", "slip"] + [f"phase_{p}" for p in PHASES]  # fmt: skip
        k = self.patch_size
        patch = [f"speed_{i}_{j}" for i in range(k) for j in range(k)]
        patch += [f"elevation_{i}_{j}_m" for i in range(k) for j in range(k)]
        neigh = []
        for n in range(self.neighbours):
            neigh += [f"n{n}_present", f"n{n}_dx_m", f"n{n}_dy_m", f"n{n}_distance_m", f"n{n}_linked"]
        links = ["links", "source_linked", "source_hops", "isolated_s"]
        task = [f"role_{r}" for r in ROLES] + [
            "goal_dx_m", "goal_dy_m", "goal_distance_m", "route_progress", "marking",
            "mine_dx_m", "mine_dy_m", "time_fraction", "clearance_in_s",
        ]  # fmt: skip
        return tuple(own + patch + neigh + links + task)

    @cached_property
    def size(self) -> int:
        return len(self.names)

    @cached_property
    def slices(self) -> dict[str, slice]:
        """Where each group starts and ends in the vector."""
        k2 = self.patch_size**2
        own = 11 + len(PHASES)
        neigh = 5 * self.neighbours
        bounds = [("own", own), ("patch_speed", k2), ("patch_elevation", k2), ("neighbours", neigh),
                  ("links", 4), ("task", len(ROLES) + 9)]  # fmt: skip
        out, at = {}, 0
        for name, size in bounds:
            out[name] = slice(at, at + size)
            at += size
        return out

    def bounds(self, extent_m: float, time_limit_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Finite low/high per column: positions within the map's extent (+- a margin), speeds
        within physical limits, flags in [0, 1]."""
        unit = {"battery", "inverted", "submersion", "slip", "route_progress", "marking", "time_fraction"}
        low, high = [], []
        for name in self.names:
            flag = name.startswith(("phase_", "role_", "speed_")) or name.endswith(("present", "linked"))
            if flag or name in unit:
                lo, hi = 0.0, 1.0
            elif name.startswith(("cos_", "sin_")):
                lo, hi = -1.0, 1.0
            elif name.startswith("elevation_"):
                lo, hi = -ELEVATION_CLIP_M, ELEVATION_CLIP_M
            elif name in ("u_mps", "v_mps"):
                lo, hi = -20.0, 20.0
            elif name == "r_radps":
                lo, hi = -50.0, 50.0
            elif name in ("links", "source_hops"):
                lo, hi = -1.0, 1e4
            elif name in ("isolated_s", "clearance_in_s"):
                lo, hi = 0.0, 10.0 * time_limit_s
            elif name.endswith("distance_m"):
                lo, hi = 0.0, 4.0 * extent_m
            else:  # positions and offsets
                lo, hi = -4.0 * extent_m, 4.0 * extent_m
            low.append(lo)
            high.append(hi)
        return np.array(low, np.float32), np.array(high, np.float32)


def state_size(n_robots: int) -> int:
    return n_robots * len(STATE_FIELDS) + len(GLOBAL_FIELDS)
