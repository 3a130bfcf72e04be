"""World physics for the whole swarm at once: the `skid` model plus slopes, water, waves and obstacles.

The PettingZoo environment calls `Physics.step` once per env step for all robots. It splits the step
into equal substeps (0.1 s by default; `SkidModel.step` is linearly implicit, stable at that size) and
at each substep re-reads, for every robot, the map cell under it: its terrain mode's coefficients,
its slope, and the water's velocity there. Everything is vectorized over robots; the per-cell terms
that never change (slope force, cos of the slope, surf mask, wave amplitude and direction) are
computed once in `__init__` and gathered by flat cell index. The substeps run in the numba kernels
of `swarm.sim.physics_kernels`, bit for bit the numpy code here (`Physics(fused=False)`), which
stays as their reference and for robots the kernels do not cover.

What is modelled, and where it comes from:

1. Wheels. `wheel_cmd_radps` is (left, right) in the robot's own frame. A robot turned over by a
   breaker still works (thesis 1.2: "works upright or inverted in the surf"). A roll of 180 deg
   about body x keeps the forward axis, puts its left motor on the right and reverses each wheel's
   spin relative to the body, so the physical wheel speeds are -cmd[:, ::-1].
2. Slope. Gravity along an inclined plane, the grade resistance W sin(a) of vehicle dynamics
   [Wong08, ch. 3], with sin(a) = |grad z| / sqrt(1 + |grad z|^2) and cos(a) = 1 / sqrt(1 + |grad z|^2)
   from the map's elevation gradient: world force -(1 - b) m g grad z / sqrt(1 + |grad z|^2), b the
   mode's buoyancy fraction (water carries that part of the weight), and the wheels' normal load
   scaled by cos(a). Both are per cell, from `BeachMap.gradient`.
3. Water. `SkidModel` drags the hull with -c |v| v (c = 0.5 rho Cd A of the mode) on the robot's own
   velocity; in moving water drag acts on the velocity relative to the water, the drag term of the
   Morison equation in relative-velocity form [Morison50, DNV-RP-C205 ch. 6]. The correction wrench
   c (|v| v - |v - w| (v - w)) makes the total -c |v - w| (v - w). Inertia (added-mass, Froude-
   Krylov) terms and wave-induced yaw moments are left out: drag dominates for a blunt 0.6 m hull
   in surf-zone flows (Keulegan-Carpenter number U T / D ~ 1.2 m/s x 8 s / 0.6 m ~ 16
   [DNV-RP-C205 ch. 6]). Water velocity, in surf-zone cells only:
   - the longshore current along +x (`SeaState.longshore_current_mps`; the mission gives it or
     derives it from Longuet-Higgins 1970);
   - the wave orbital velocity along the local shoreward direction, u = (H / 2) sqrt(g / h), the
     shallow-water limit of linear (Airy) theory [Dean & Dalrymple, Water Wave Mechanics for
     Engineers and Scientists, World Scientific, 1991], with the height depth-limited inside the
     surf zone, H = min(H_b, gamma h), gamma = 0.78 [McCowan 1894; saturated surf, height
     proportional to depth: Thornton & Guza 1982, JGR 87(C12)], h = max(0.05, -elevation) the
     still-water depth (sea level is elevation 0; the 5 cm floor keeps the swash finite);
   - time shape s(phi) = (cos phi + r cos 2 phi) / (1 + r), phi = 2 pi (t - wave_phase_s) / T: the
     second-order Stokes form, zero mean, peak 1 shoreward at the crest (phi = 0) and a weaker,
     longer trough (-0.5 at r = 0.5). Its velocity skewness (0.76 at r = 0.5) is in the range
     measured across the surf zone, Sk ~ 0.3-1 [Ruessink et al. 2012, Coastal Eng. 65, 56-63; Elgar
     & Guza 1985, JFM 161]. Quadratic drag of a skewed flow has a shoreward mean, <|s| s> > 0: the
     onshore push of breaking waves, the same mechanism as skewness-driven onshore sediment
     transport [Bailard 1981, JGR 86(C11)]. `SeaState.wave_skew` = 0 gives a symmetric wave and
     no mean push.
   - Jet thrust along body +x (a roll about x keeps it forward), clipped to the rated thrust and
     multiplied by the cell's buoyancy fraction: the intake must be submerged, so 0 on land.
4. Surf zone. Cells of a terrain class named "surf" (when the map has one), and water cells (mode
   `is_water`) shallower than the breaker depth h_b = H_b / gamma [McCowan 1894; Dean 1991, as
   `swarm.world.coastal.breaker_depth`, so the map generator and the physics agree where the surf
   is] and lower than H_b above sea level: the swash runs up about that high (the 2% runup of
   Stockdon et al. 2006, `coastal.stockdon_runup_r2`, is 0.5-1.0 H_b for H_b = 1 m, T = 8 s on
   0.05-0.15 slopes), and the cap keeps run-off channels and rivers inland out of the surf.
   `shoreward` is the unit uphill gradient of the elevation smoothed by a Gaussian of
   `coastal.SHOREWARD_SMOOTHING_CELLS` cells, +y (north) where that vanishes. Breaker crests pass at t =
   wave_phase_s + k T; a robot in the surf at the start of the substep a crest falls in is hit,
   by a breaker of the local height min(H_b, 0.78 h) (`PhysicsStep.wave_height_m`): across the surf
   zone the breakers lose height with the depth, so a robot in the swash takes small ones.
5. Obstacles. A substep that would put a robot's centre in an impassable cell (a mode with
   `passable: false`: boulders, driftwood) other than the one it is in is undone for x, y; the
   body velocities u, v are zeroed and the new heading and yaw rate kept (it can still turn in
   place against the obstacle). Only end points are checked: a robot moves far less than a cell
   in one 0.1 s substep (2 m/s x 0.1 s = 0.2 m against 0.5-1 m cells). Positions off the map are
   allowed and read the nearest edge cell (`BeachMap.cell_of` clips).
6. Power. Wheels: the motors supply the slip traction of each side, so the power is the sum over
   the two sides of max(0, F_traction * wheel surface speed) / `ETA_DRIVE` (braking recovers
   nothing). F_traction is each side's slip traction at the new velocities of the step's last
   substep (`SkidModel.step(..., traction_out=)`), the longitudinal contact force without rolling
   resistance: the total contact force would count rolling resistance as negative work and show
   zero power at steady cruise, where traction exactly balances it. The commands are constant over
   a step and the contact transients settle within it, so the last substep stands for the step.
   Jet: ideal static power of an actuator disk of area
   A (momentum theory, Rankine 1865 / Froude 1889; e.g. Carlton, Marine Propellers and Propulsion,
   2nd ed., 2007): P = T^1.5 / sqrt(2 rho A) / `ETA_JET` on the thrust the jet delivers
   (`jet_power_w`), averaged over the substeps. No hotel load; the environment adds that.
7. Distance: the sum of the horizontal displacements of the substeps. Slip: per substep
   sign(w) (w - u) / max(|w|, |u|) with w the mean wheel surface speed, clipped to [0, 1] (0 when the
   robot outruns its wheels, 1 when it moves against them; the sign makes reversing count like
   driving forward) and 0 below `SLIP_MIN_SPEED_MPS`, averaged over the substeps.

[Wong08] J. Y. Wong, Theory of Ground Vehicles, 4th ed., Wiley, 2008.
[Morison50] J. R. Morison, M. P. O'Brien, J. W. Johnson, S. A. Schaaf, "The force exerted by surface
waves on piles", Petroleum Transactions AIME 189, 149-154, 1950.
[DNV-RP-C205] DNV, Environmental Conditions and Environmental Loads, recommended practice, 2010.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from swarm.robot.params import GRAVITY_MPS2, RobotParams
from swarm.robot.skid import HEADING, SLIP_MIN_SPEED_MPS, SkidModel, U, V, X, Y, mean_wheel_slip
from swarm.robot.terrain import COEFFICIENTS, TerrainLibrary
from swarm.sim import physics_kernels as kernels
from swarm.sim.physics_kernels import (
    BUOY,
    BUOY15,
    CREST_EPS,
    CURRENT_X,
    DRAG,
    LOAD,
    RADIUS_SCALE,
    SLOPE_FX,
    SLOPE_FY,
    SURF,
    WAVE_X,
    WAVE_Y,
)
from swarm.world.beachmap import BeachMap
from swarm.world.coastal import (
    BREAKING_INDEX,
    MIN_DEPTH_M,
    WAVE_SKEW,
    local_breaker_height,
    shoreward_direction,
    surf_zone_mask,
    wave_shape,
)

if TYPE_CHECKING:
    from swarm.mission.schema import Mission

#: Overall efficiency of the wheel drives, electrical to shaft (assumed: a small brushed DC
#: gearmotor with a planetary gearbox, typically 0.6-0.8 overall).
ETA_DRIVE = 0.7
#: Overall efficiency of the water jet, electrical to ideal jet power (assumed: small pump-jets
#: reach 0.4-0.6).
ETA_JET = 0.5
#: Sea water density, kg/m^3 (surface sea water, 35 PSU, ~15 C; the value terrain_modes.yaml uses).
SEAWATER_DENSITY_KGPM3 = 1025.0
#: Jet nozzle area, m^2 (assumed: a ~50 mm nozzle).
JET_NOZZLE_AREA_M2 = 0.002


_JET_W_PER_N15 = 1.0 / math.sqrt(2.0 * SEAWATER_DENSITY_KGPM3 * JET_NOZZLE_AREA_M2) / ETA_JET


def jet_power_w(thrust_n: np.ndarray | float) -> np.ndarray:
    """Electrical power of the jet delivering `thrust_n` (either direction): the ideal static power of
    an actuator disk of the nozzle's area, T^1.5 / sqrt(2 rho A), over `ETA_JET`. Static is the least
    a jet can need for that thrust; the environment also uses it for the sea transit off the map."""
    return np.abs(np.asarray(thrust_n, dtype=np.float64)) ** 1.5 * _JET_W_PER_N15


@dataclass(frozen=True)
class SeaState:
    """Breakers and current over the surf zone."""

    wave_height_m: float  # breaker height H_b
    wave_period_s: float
    longshore_current_mps: float  # along +x, in the surf zone
    #: Second-harmonic ratio of the wave velocity shape; 0 is a symmetric (linear) wave.
    wave_skew: float = WAVE_SKEW

    def __post_init__(self) -> None:
        if not self.wave_height_m >= 0.0 or not self.wave_period_s > 0.0:
            raise ValueError(
                f"sea state needs wave_height_m >= 0 and wave_period_s > 0, got {self.wave_height_m}, "
                f"{self.wave_period_s}"
            )
        if not self.wave_skew >= 0.0:
            raise ValueError(f"wave_skew must be >= 0, got {self.wave_skew}")

    @classmethod
    def from_mission(cls, mission: Mission) -> SeaState:
        surf = mission.hazards.surf
        return cls(float(surf.wave_height_m), float(surf.wave_period_s), float(surf.longshore_current()))

    @property
    def breaker_depth_m(self) -> float:
        """Still-water depth where the waves break, H_b / gamma: the seaward edge of the surf zone."""
        return self.wave_height_m / BREAKING_INDEX

    def wave_shape(self, t_s: float, wave_phase_s: float) -> float:
        """Shoreward wave velocity over its crest value at time t: 1 at a crest, zero mean."""
        return self.shape_at_phase(2.0 * math.pi * (t_s - wave_phase_s) / self.wave_period_s)

    def shape_at_phase(self, phi: float) -> float:
        """`wave_shape` at wave phase `phi` (rad; 0 at a crest)."""
        return wave_shape(phi, self.wave_skew)

    def crests_by(self, t_s: float, wave_phase_s: float) -> int:
        """Crests that have passed by time t (up to a constant): a crest lies in (a, b] iff this grows."""
        return math.floor((t_s - wave_phase_s) / self.wave_period_s + CREST_EPS)


@dataclass
class PhysicsStep:
    """What one env step did to each robot (n rows, in the order of the state given)."""

    state: np.ndarray  # (n, 6) after the step
    power_w: np.ndarray  # (n,) mean electrical power of wheels + jet over the step (no hotel load)
    distance_m: np.ndarray  # (n,) path length travelled over the step
    slip: np.ndarray  # (n,) mean longitudinal slip in [0, 1]
    terrain: np.ndarray  # (n,) int class index of the cell under each robot at the end (-1 inactive)
    submersion: np.ndarray  # (n,) buoyancy_fraction of that cell's mode (0 land .. 1 deep water)
    in_surf: np.ndarray  # (n,) bool: in the surf zone at the end
    wave_height_m: np.ndarray  # (n,) local breaker height of the step's hits, m (0 without one)
    wave_hits: np.ndarray  # (n,) bool: a breaker crest passed over the robot in the surf zone
    obstacle_hit: np.ndarray  # (n,) int class of an impassable cell the robot ran into, -1 none


def _per_robot(a, dtype, n: int) -> np.ndarray:
    """`a` as an (n,) array of `dtype`: as it is when it already is one (the batch's columns),
    else converted and broadcast."""
    if type(a) is np.ndarray and a.dtype == dtype and a.shape == (n,):
        return a
    return np.broadcast_to(np.asarray(a, dtype=dtype), (n,))


_STEP_FIELDS = tuple(f.name for f in fields(PhysicsStep))


class Physics:
    """Vectorized world physics over one beach for one robot type."""

    def __init__(
        self,
        beach: BeachMap,
        library: TerrainLibrary,
        robot: RobotParams,
        sea: SeaState,
        *,
        jet_thrust_max_n: float,
        substep_s: float = 0.1,
        fused: bool = True,
    ) -> None:
        """`fused`: step with the numba kernels of `physics_kernels` when they cover the robot (its
        centre of mass centred); False steps with the numpy path, the kernels' reference."""
        if not substep_s > 0.0:
            raise ValueError(f"substep_s must be > 0, got {substep_s}")
        if not jet_thrust_max_n >= 0.0:
            raise ValueError(f"jet_thrust_max_n must be >= 0, got {jet_thrust_max_n}")
        self.beach, self.library, self.robot, self.sea = beach, library, robot, sea
        self.jet_thrust_max_n = float(jet_thrust_max_n)
        self.substep_s = float(substep_s)
        self.model = SkidModel(robot)
        self._fused = fused and self.model.centred
        self._robot_consts = kernels.Robot.of(self.model)
        self._scratch: tuple[np.ndarray, ...] = ()
        modes = [library[name] for name in beach.terrain_classes]
        table = beach.terrain_table(library)
        #: (class, coefficient): one row per class; gathering rows and transposing is the fast way.
        # (the last column, buoyancy^1.5, scales the jet's power: (b T)^1.5 = b^1.5 T^1.5)
        columns = [table.columns[c] for c in COEFFICIENTS]
        columns.append(table.columns["buoyancy_fraction"] ** 1.5)
        self._class_coef = np.ascontiguousarray(np.stack(columns, axis=1))
        self._impassable = np.array([not m.passable for m in modes], dtype=bool)
        is_water = np.array([m.is_water for m in modes], dtype=bool)
        self._terrain = np.ascontiguousarray(beach.terrain, dtype=np.intp).ravel()
        rows, cols = beach.shape
        self._rows, self._cols = rows, cols
        self._x0, self._y0 = (float(v) for v in beach.origin_m)
        self._inv_cell = 1.0 / beach.cell_m

        elevation = beach.elevation_m.astype(np.float64)
        depth = np.maximum(MIN_DEPTH_M, -elevation)
        surf = surf_zone_mask(elevation, is_water[beach.terrain], sea.wave_height_m, MIN_DEPTH_M)
        if "surf" in beach.terrain_classes:
            surf |= beach.terrain == beach.class_index("surf")
        self.surf_mask: np.ndarray = surf

        self.shoreward: np.ndarray = shoreward_direction(elevation, beach.cell_m)

        d_dx, d_dy = beach.gradient
        cos_slope = 1.0 / np.sqrt(1.0 + d_dx * d_dx + d_dy * d_dy)
        weight = robot.mass_kg * GRAVITY_MPS2
        height = local_breaker_height(elevation, surf, sea.wave_height_m, MIN_DEPTH_M)
        amplitude = np.where(surf, 0.5 * height * np.sqrt(GRAVITY_MPS2 / depth), 0.0)
        props = np.empty((7, rows * cols))  # filled by property, stored by cell
        props[SLOPE_FX] = (-weight * d_dx * cos_slope).ravel()
        props[SLOPE_FY] = (-weight * d_dy * cos_slope).ravel()
        props[LOAD] = cos_slope.ravel()
        props[CURRENT_X] = np.where(surf, sea.longshore_current_mps, 0.0).ravel()
        props[WAVE_X] = (amplitude * self.shoreward[..., 0]).ravel()
        props[WAVE_Y] = (amplitude * self.shoreward[..., 1]).ravel()
        props[SURF] = height.ravel()  # the local breaker height (0: not surf)
        self._props = np.ascontiguousarray(props.T)

    @staticmethod
    def default_jet_thrust_n(library: TerrainLibrary, swim_speed_mps: float) -> float:
        """Thrust that holds 1.5 x the swim speed against deep-water hull drag: margin for currents
        and surges (the mission schema's default for `robot.jet_thrust_n`)."""
        return library.default_jet_thrust_n(swim_speed_mps)

    # --- lookups ---------------------------------------------------------------------------------
    def _cells(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Flat cell index under world points, clipped to the grid as `BeachMap.cell_of` does (a
        truncating cast is a floor for everything the lower clip keeps), several times faster."""
        col = ((x - self._x0) * self._inv_cell).astype(np.intp)
        row = ((y - self._y0) * self._inv_cell).astype(np.intp)
        np.maximum(col, 0, out=col)
        np.minimum(col, self._cols - 1, out=col)
        np.maximum(row, 0, out=row)
        np.minimum(row, self._rows - 1, out=row)
        row *= self._cols
        row += col
        return row

    @staticmethod
    def _gather(table: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Rows `index` of a (key, column) table as contiguous (column, robot) arrays."""
        return np.ascontiguousarray(table.take(index, axis=0).T)

    def water_velocity_mps(self, xy: np.ndarray, t_s: float, wave_phase_s: float) -> np.ndarray:
        """World-frame water velocity (n, 2) at points: longshore current plus wave orbital velocity
        in the surf zone, zero elsewhere."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        p = self._gather(self._props, self._cells(xy[:, 0], xy[:, 1]))
        shape = self.sea.wave_shape(t_s, wave_phase_s)
        return np.stack([p[CURRENT_X] + shape * p[WAVE_X], shape * p[WAVE_Y]], axis=1)

    # --- the step --------------------------------------------------------------------------------
    def step(
        self,
        state: np.ndarray,
        wheel_cmd_radps: np.ndarray,
        jet_cmd_n: np.ndarray,
        inverted: np.ndarray,
        t_s: float,
        dt_s: float,
        wave_phase_s: float,
        active: np.ndarray | None = None,
        run: np.ndarray | None = None,
    ) -> PhysicsStep:
        """Advance every active robot by `dt_s` from time `t_s` in equal substeps of at most
        `substep_s`. Inactive rows come back unchanged and cost nothing: zero power and distance, no
        hits, terrain -1, submersion 0, not in the surf. The input arrays are not modified.

        A batch of runs (`swarm.sim.world`): `run` (n,) gives each row's run, and `t_s` and
        `wave_phase_s` are arrays with an entry per run; each run's waves are its own."""
        if not dt_s > 0.0:
            raise ValueError(f"dt_s must be > 0, got {dt_s}")
        state = np.asarray(state, dtype=np.float64)
        n = state.shape[0]
        cmd = np.asarray(wheel_cmd_radps, dtype=np.float64).reshape(n, 2)
        jet = _per_robot(jet_cmd_n, np.float64, n)
        inv = _per_robot(inverted, bool, n)
        act = None if active is None else _per_robot(active, bool, n)
        n_sub = max(1, math.ceil(dt_s / self.substep_s - 1e-9))
        waves = kernels.wave_table(
            np.ascontiguousarray(t_s, dtype=np.float64),
            np.ascontiguousarray(wave_phase_s, dtype=np.float64),
            self.sea.wave_period_s,
            self.sea.wave_skew,
            dt_s,
            n_sub,
        )
        if self._fused:
            return self._run_fused(state, cmd, jet, inv, act, dt_s, n_sub, waves, run)
        if act is None or act.all():
            return self._run(state, cmd, jet, inv, dt_s, n_sub, waves, run)
        res = PhysicsStep(
            state=state.copy(),
            power_w=np.zeros(n),
            distance_m=np.zeros(n),
            slip=np.zeros(n),
            terrain=np.full(n, -1, dtype=np.intp),
            submersion=np.zeros(n),
            in_surf=np.zeros(n, dtype=bool),
            wave_height_m=np.zeros(n),
            wave_hits=np.zeros(n, dtype=bool),
            obstacle_hit=np.full(n, -1, dtype=np.intp),
        )
        idx = np.flatnonzero(act)
        if idx.size:
            sub = None if run is None else run[idx]
            r = self._run(state[idx], cmd[idx], jet[idx], inv[idx], dt_s, n_sub, waves, sub)
            for name in _STEP_FIELDS:
                getattr(res, name)[idx] = getattr(r, name)
        return res

    def _run(
        self,
        s: np.ndarray,
        cmd: np.ndarray,
        jet: np.ndarray,
        inverted: np.ndarray,
        dt_s: float,
        n_sub: int,
        waves: tuple[np.ndarray, np.ndarray],
        run: np.ndarray | None,
    ) -> PhysicsStep:
        """The substep loop over the active robots only, in numpy (returns fresh arrays). `waves`
        is `physics_kernels.wave_table`'s (substep, run) wave shapes and crest passages."""
        # turned over: sides swapped, each wheel turning the other way relative to the body
        omega = np.where(inverted[:, None], -cmd[:, ::-1], cmd)
        thrust = np.clip(jet, -self.jet_thrust_max_n, self.jet_thrust_max_n)
        m = s.shape[0]
        h = dt_s / n_sub
        model = self.model
        shapes, crests = waves
        jet_power = np.zeros(m)
        distance = np.zeros(m)
        slip = np.zeros(m)
        hits = np.zeros(m, dtype=bool)
        hit_height = np.zeros(m)
        obstacle = np.full(m, -1, dtype=np.intp)
        mean_omega = 0.5 * (omega[:, 0] + omega[:, 1])
        wrench = np.zeros((m, 3))
        traction = np.zeros((m, 2))
        cell = self._cells(s[:, X], s[:, Y])
        cls = self._terrain[cell]
        for k in range(n_sub):
            coef = self._gather(self._class_coef, cls)
            props = self._gather(self._props, cell)
            coeffs = dict(zip(COEFFICIENTS, coef[:BUOY15], strict=True))
            buoy, drag = coef[BUOY], coef[DRAG]
            heading = s[:, HEADING]
            c, sn = np.cos(heading), np.sin(heading)
            # water velocity, world then body frame; drag on the velocity relative to it
            shape = shapes[k, 0] if run is None else shapes[k][run]
            wx = props[CURRENT_X] + shape * props[WAVE_X]
            wy = shape * props[WAVE_Y]
            u, v = s[:, U], s[:, V]
            ru = u - (wx * c + wy * sn)
            rv = v - (wy * c - wx * sn)
            speed = np.sqrt(u * u + v * v)
            rel = np.sqrt(ru * ru + rv * rv)
            # slope force (world), on the weight the water leaves
            support = 1.0 - buoy
            gx, gy = support * props[SLOPE_FX], support * props[SLOPE_FY]
            wrench[:, 0] = drag * (speed * u - rel * ru) + thrust * buoy + (gx * c + gy * sn)
            wrench[:, 1] = drag * (speed * v - rel * rv) + (gy * c - gx * sn)
            load = props[LOAD]
            new = model.step(s, omega, coeffs, h, wrench, load, traction_out=traction)

            new_cell = self._cells(new[:, X], new[:, Y])
            new_cls = self._terrain[new_cell]
            blocked = self._impassable[new_cls]
            blocked &= new_cell != cell
            if blocked.any():
                new[blocked, X] = s[blocked, X]
                new[blocked, Y] = s[blocked, Y]
                new[blocked, U] = 0.0
                new[blocked, V] = 0.0
                obstacle[blocked] = new_cls[blocked]
                new_cell[blocked] = cell[blocked]
                new_cls[blocked] = cls[blocked]

            dx, dy = new[:, X] - s[:, X], new[:, Y] - s[:, Y]
            distance += np.sqrt(dx * dx + dy * dy)
            jet_power += coef[BUOY15]
            # longitudinal slip of the mean wheel, signed along the wheels' drive direction
            w = mean_omega * coef[RADIUS_SCALE]
            w *= self.robot.wheel_radius_m
            slip += mean_wheel_slip(w, new[:, U])

            crest = crests[k, 0] if run is None else crests[k][run]
            hits |= (props[SURF] > 0.0) & crest
            hit_height = np.where(crest, np.maximum(hit_height, props[SURF]), hit_height)
            s, cell, cls = new, new_cell, new_cls

        # wheel power at the end of the step: each side's slip traction (rolling resistance left
        # out) at the new velocities, from the last substep, times that side's wheel surface speed
        surface = omega * (self.robot.wheel_radius_m * coef[RADIUS_SCALE])[:, None]  # (m, 2): left, right
        wheel = np.maximum(traction * surface, 0.0).sum(axis=1)
        return PhysicsStep(
            state=s,
            power_w=wheel * (1.0 / ETA_DRIVE) + jet_power_w(thrust) * jet_power * (1.0 / n_sub),
            distance_m=distance,
            slip=slip / n_sub,
            terrain=cls,
            submersion=coef[BUOY],
            in_surf=props[SURF] > 0.0,
            wave_hits=hits,
            wave_height_m=hit_height,
            obstacle_hit=obstacle,
        )

    def _scratch_for(self, n: int) -> tuple[np.ndarray, ...]:
        """The kernels' scratch arrays for n robots, kept from step to step: fresh ones would cost
        their page faults every step at swarm sizes."""
        if not self._scratch or self._scratch[0].shape[0] != n:
            self._scratch = (
                np.empty((n, 2)),
                np.empty(n, dtype=np.intp),
                np.empty((kernels.WORK_ROWS, n)),
                np.empty((kernels.CONTACT_ROWS, n)),
                np.empty((kernels.SOLVED_ROWS, n)),
            )
        return self._scratch

    def _run_fused(
        self,
        state: np.ndarray,
        cmd: np.ndarray,
        jet: np.ndarray,
        inverted: np.ndarray,
        active: np.ndarray | None,
        dt_s: float,
        n_sub: int,
        waves: tuple[np.ndarray, np.ndarray],
        run: np.ndarray | None,
    ) -> PhysicsStep:
        """`_run` in the kernels of `physics_kernels`, bit for bit, on all rows at once (inactive
        rows skipped): a kernel call per substep, with numpy's expm1 in between."""
        n = state.shape[0]
        h = dt_s / n_sub
        thrust = np.clip(jet, -self.jet_thrust_max_n, self.jet_thrust_max_n)
        act = np.ones(n, dtype=bool) if active is None else np.ascontiguousarray(active)
        run_of = np.zeros(n, dtype=np.intp) if run is None else np.ascontiguousarray(run, dtype=np.intp)
        s = np.array(state, order="C")  # a copy: the input is not modified
        cls = np.empty(n, dtype=np.intp)
        omega, cell, work, contacts, solved = self._scratch_for(n)
        out = np.zeros((kernels.OUT_ROWS, n))
        flags = np.zeros((kernels.FLAG_ROWS, n), dtype=bool)
        obstacle = np.full(n, -1, dtype=np.intp)
        grid = (self._x0, self._y0, self._inv_cell, self._rows, self._cols)
        coef, robot = self._class_coef, self._robot_consts
        cmd, inverted = np.ascontiguousarray(cmd), np.ascontiguousarray(inverted)
        props, shapes = self._props, waves[0]
        kernels.start(
            s,
            cmd,
            inverted,
            act,
            run_of,
            thrust,
            coef,
            props,
            self._terrain,
            grid,
            robot,
            shapes,
            omega,
            cell,
            cls,
            work,
            contacts,
        )
        jet_w = jet_power_w(thrust)
        exponents = contacts[kernels.EXPONENTS]
        for k in range(n_sub):
            np.expm1(exponents, out=exponents)
            kernels.substep(
                k,
                n_sub,
                h,
                s,
                omega,
                thrust,
                act,
                run_of,
                cell,
                cls,
                coef,
                props,
                self._terrain,
                self._impassable,
                grid,
                robot,
                *waves,
                SLIP_MIN_SPEED_MPS,
                jet_w,
                1.0 / ETA_DRIVE,
                work,
                contacts,
                solved,
                out,
                flags,
                obstacle,
            )
        return PhysicsStep(
            state=s,
            power_w=out[kernels.OUT_POWER],
            distance_m=out[kernels.OUT_DISTANCE],
            slip=out[kernels.OUT_SLIP],
            terrain=cls,
            submersion=out[kernels.OUT_SUBMERSION],
            in_surf=flags[kernels.FLAG_SURF],
            wave_hits=flags[kernels.FLAG_HIT],
            wave_height_m=out[kernels.OUT_HIT_HEIGHT],
            obstacle_hit=obstacle,
        )
