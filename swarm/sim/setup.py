"""`MissionSetup`: what every run of one mission and plan shares, built once.

The physics tables, drive limits, radio parameters, the plan's per-robot facts (release and
arrival times, launch and entry points, roles), the initial routes (stitched around blocked
ground), the terrain-speed grid, dry ground for mustering and the cells hidden rocks can lie in.
A batch of runs (`swarm.sim.world.World`) holds one; nothing here changes while runs go on, so a
study worker keeps it per point and hands it to batch after batch.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from swarm.errors import SwarmError
from swarm.mission.exposure import WayOut
from swarm.mission.plan import MissionPlan, pickup_points, place_xy, radio_params
from swarm.mission.schema import Mission, Radio
from swarm.planning.router import Router
from swarm.robot.driving import MAX_WHEEL_SPEED_FACTOR, DriveLimits
from swarm.sim import physics
from swarm.sim.layout import ROLES

#: Spares wait on dry ground at least this far from water (m).
MUSTER_FROM_WATER_M = 5.0


class MissionSetup:
    """The static world of one mission and plan (module docstring); `dt_s`, `substep_s` from the
    simulation settings."""

    def __init__(self, mission: Mission, plan: MissionPlan, *, dt_s: float, substep_s: float) -> None:
        m = mission
        self.mission = m
        self.plan = plan
        self.beach = m.beach_map
        self.library = m.terrain_library
        self.robot = m.robot_params
        n = m.swarm.count
        if len(plan.robots) != n:
            raise SwarmError(f"sim: the plan has {len(plan.robots)} robots, the mission {n}")
        self.n = n
        self.dt_s = float(dt_s)
        self.time_limit_s = m.beach_end_s + (
            m.phases.return_to_sea.time_limit_s if m.phases.return_to_sea.enabled else 0.0
        )
        self.steps_to_limit = math.ceil(self.time_limit_s / dt_s - 1e-9)

        self.sea = physics.SeaState.from_mission(m)
        swim = m.robot.swim_speed_mps
        jet = m.robot.jet_thrust_n or physics.Physics.default_jet_thrust_n(self.library, swim)
        self.physics = physics.Physics(
            self.beach, self.library, self.robot, self.sea, jet_thrust_max_n=jet, substep_s=substep_s
        )
        self.limits = DriveLimits(
            wheel_radius_m=self.robot.wheel_radius_m,
            track_width_m=self.robot.track_width_m,
            cruise_speed_mps=m.robot.wheel_speed_mps,
            max_wheel_speed_mps=MAX_WHEEL_SPEED_FACTOR * m.robot.wheel_speed_mps,
            jet_thrust_max_n=jet,
        )
        relay_tasks = m.tasks_of("relay")
        self.relay_task = relay_tasks[0] if relay_tasks else None
        radio = self.relay_task.radio if self.relay_task is not None else Radio()
        self.radio = radio_params(radio, m.hazards.comms.shadowing_sigma_db)
        fixed = None
        if self.relay_task is not None:
            pts = [place_xy(self.beach, self.relay_task.source)]
            pts += [place_xy(self.beach, s) for s in self.relay_task.sinks]
            fixed = np.array(pts)
        self.fixed_m = fixed
        self.fixed_height_m = radio.source_antenna_height_m
        searches = m.tasks_of("search")
        self.search_task = searches[0] if searches else None
        self.clearance = self.search_task.clearance if self.search_task is not None else None
        self.clutter = (
            self.beach.regions[self.search_task.area].geometry if self.search_task is not None else None
        )

        plan_robots = plan.robots
        self.release_s = np.array([r.release_s for r in plan_robots])
        self.arrive_s = self.release_s + m.launch.release_offshore_m / swim
        self.launch_m = np.array([r.launch_m for r in plan_robots])
        self.entry_m = np.array([r.sea_leg_m[-1] for r in plan_robots])
        self.plan_role = np.array([ROLES.index(r.role) for r in plan_robots], dtype=np.int64)
        self.on_beach_launch = m.launch.platform == "beach"
        # jet power for the sea leg offshore, at the thrust that holds swim speed in deep water
        drag = self.library["deep_water"].drag_n_s2_per_m2
        self.swim_power_w = float(physics.jet_power_w(drag * swim * swim))
        self.hotel_power_w = m.hazards.battery.hotel_power_w
        self.capacity_wh = m.hazards.battery.capacity_wh
        self.pickup_m = pickup_points(m, self.launch_m)

        self.speed_grid = self._speed_fraction_grid()
        self.router = Router(plan.costmap, seed=m.seed)
        self.initial_routes = [self._initial_route(rp) for rp in plan_robots]
        self.way_out = WayOut(m, plan.costmap, self.pickup_m)
        #: pick-up points on dry ground (a beach launch's): a robot is picked up on reaching one
        self.dry_pickups_m = self.pickup_m[self.way_out.on_land]
        self.router.calls = 0

    def _speed_fraction_grid(self) -> np.ndarray:
        """Per cell: the mode's steady speed over the fastest mode's (0: impassable or no progress)."""
        speeds = self.plan.costmap.speeds
        table = speeds.as_dict() if hasattr(speeds, "as_dict") else {}
        per_class = []
        for name in self.beach.terrain_classes:
            mode = self.library[name]
            entry = table.get(name, {})
            v = entry.get("speed_mps") if isinstance(entry, dict) else None
            ref = max((e.get("speed_mps") or 0.0) for e in table.values()) if table else 1.0
            frac = 0.0 if (not mode.passable or not v) else float(v) / max(ref, 1e-9)
            per_class.append(frac)
        return np.asarray(per_class, np.float32)[self.beach.terrain.astype(np.intp)]

    def _initial_route(self, rp) -> tuple[np.ndarray, int | None]:
        """A robot's planned waypoints (and where its search track starts: the first lane's start,
        where its ground route ends; the plan's `track_m` begins at that lane's end); spares go on
        from their entry to wait on dry ground, out of the surf."""
        wp = rp.waypoints_m
        if rp.role == "spare":
            wp = np.vstack([wp, self.router.route(wp[-1], self.muster_point(wp[-1]))])
        track_from = len(wp) - len(rp.track_m) - 1 if len(rp.track_m) else None
        ground = len(rp.sea_leg_m) - 1  # the sea leg is open water: nothing to route around
        land, where = self.router.stitch(wp[ground:])
        wp = np.vstack([wp[:ground], land])
        if track_from is not None:
            track_from = ground + int(where[track_from - ground])
        return wp, track_from

    @functools.cached_property
    def patch_grid(self) -> np.ndarray:
        """(cells, 2) float32: speed fraction and elevation of every cell, row-major (the terrain
        patch of the observation samples it; one copy for every run and adapter)."""
        return np.column_stack([self.speed_grid.ravel(), self.beach.elevation_m.ravel()]).astype(np.float32)

    @functools.cached_property
    def dry_ground(self) -> np.ndarray:
        """(rows, cols) bool: free cells at least `MUSTER_FROM_WATER_M` from any water, where robots
        wait out of the surf (a robot waiting in the breakers is rolled over again and again)."""
        water = np.array([self.library[c].is_water for c in self.beach.terrain_classes])
        wet = water[self.beach.terrain.astype(np.intp)]
        far = ndimage.distance_transform_edt(~wet) * self.beach.cell_m >= MUSTER_FROM_WATER_M
        return far & ~self.plan.costmap.blocked

    @functools.cached_property
    def _muster_cells(self) -> tuple[cKDTree, np.ndarray]:
        """Free cells on dry ground (`dry_ground`), or any free cells on a map without."""
        cm = self.plan.costmap
        rows, cols = np.nonzero(self.dry_ground)
        if not len(rows):
            rows, cols = np.nonzero(~cm.blocked)
        pts = np.column_stack(cm.center_of(rows, cols))
        return cKDTree(pts), pts

    @functools.cached_property
    def dry_cells(self) -> np.ndarray:
        """Centres of the passable land cells (no water): where hidden rocks can lie."""
        ok = np.array(
            [self.library[c].passable and not self.library[c].is_water for c in self.beach.terrain_classes]
        )
        rows, cols = np.nonzero(ok[self.beach.terrain.astype(np.intp)])
        return np.column_stack(self.beach.center_of(rows, cols))

    def muster_point(self, xy: np.ndarray) -> np.ndarray:
        """Where a spare waits: the nearest free, dry cell clear of the water."""
        tree, pts = self._muster_cells
        return pts[int(tree.query(xy)[1])]
