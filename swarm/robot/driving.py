"""How the swarm's robots are driven: the controller's gains and the route follower's radii.

One home for the numbers the simulator's controller (`swarm.sim.control`) and route follower
(`swarm.sim.routes`) run on and the plan's way in through the surf (`swarm.mission.surf_drive`)
drives by, below both layers, so the plan's drive cannot drift from the simulator's.
"""

from __future__ import annotations

import math

#: Thesis eq. 2.26: the effective track width of the skid-steered robot is d / 0.73.
EFFECTIVE_TRACK_SCALE = 0.73
#: Heading error beyond which the robot turns in place before driving on (rad).
PIVOT_ERROR_RAD = math.radians(60.0)
#: Yaw-rate gain on the heading error (1/s) and the largest commanded yaw rate (rad/s).
YAW_GAIN_PER_S = 1.5
MAX_YAW_RATE_RADPS = 1.2
#: Within this distance of its target a robot stops (m).
ARRIVE_M = 0.25
#: The largest wheel surface speed, as a multiple of the cruise speed (robot.wheel_speed_mps).
MAX_WHEEL_SPEED_FACTOR = 1.5

#: A waypoint counts as reached within this distance (m); the last one of a route, where the
#: robot stops, within `FINAL_CAPTURE_M` (inside the controller's stopping distance).
CAPTURE_M = 1.0
FINAL_CAPTURE_M = 0.3
#: Pure pursuit: the robot steers for the point this far ahead of its projection on the leg it is
#: driving (m). Steering for the far end of a 900 m search track instead lets a cross-slope push
#: carry the robot metres off the track it was planned to sweep; chasing a point on the leg pulls
#: it back. Long enough that the controller does not slow for it (its slowdown starts at 1 m).
LOOKAHEAD_M = 1.5
#: A leg's end counts as passed once the robot is beyond it along the leg and within this distance
#: of the leg's line (m), so a robot pushed wide of a corner does not circle back for it.
PASS_CROSS_TRACK_M = 2.0
