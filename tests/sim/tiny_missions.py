"""Small, fast missions on maps/test_small (120 x 80 m) for the simulator tests (a module name of its
own: `conftest` is taken by other test folders)."""

from __future__ import annotations

import copy
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[2]
SMALL_MAP = REPO / "maps" / "test_small.yaml"

#: Six robots by hand 20 m off the small beach: two land, one relays, the rest search; minutes, not hours.
BASE = {
    "name": "tiny",
    "map": str(SMALL_MAP),
    "planner": str(REPO / "planners" / "fast.yaml"),
    "swarm": {"count": 6},
    "launch": {"platform": "by_hand", "points": ["launch_1", "launch_2"], "offshore_m": 20, "interval_s": 2},
    "phases": {
        "sea_transit": {"time_limit_s": 300},
        "surf_crossing": {"time_limit_s": 300},
        "beach_operations": {"time_limit_s": 300},
        "return_to_sea": {"enabled": False},
    },
    "tasks": [{"type": "landing", "zones": ["landing_a", "landing_b"], "robots_per_zone": 1}],
}


def mission_dict(**changes: object) -> dict:
    """BASE with top-level keys replaced (a deep copy)."""
    out = copy.deepcopy(BASE)
    out.update(copy.deepcopy(changes))
    return out


def write_mission(directory: Path, name: str = "tiny", **changes: object) -> Path:
    path = Path(directory) / f"{name}.yaml"
    path.write_text(yaml.safe_dump(mission_dict(name=name, **changes), sort_keys=False))
    return path


#: Four robots on the small beach with a landing and a search (4 mines): a few hundred steps.
TINY = f"""
name: tiny
map: {SMALL_MAP}
planner: {REPO / "planners" / "fast.yaml"}
swarm: {{count: 4}}
launch: {{platform: small_craft, points: [launch_1, launch_2], offshore_m: 20, interval_s: 2}}
phases:
  sea_transit: {{time_limit_s: 150}}
  surf_crossing: {{time_limit_s: 60}}
  beach_operations: {{time_limit_s: 60}}
  return_to_sea: {{enabled: false}}
tasks:
  - {{type: landing, zones: [landing_a], robots_per_zone: 2}}
  - {{type: search, area: search_beach, sensor: {{sweep_width_m: 6.0}}, robots: 2}}
success: {{min_landing_fraction: 1.0, min_detection_fraction: 0.5}}
hazards:
  mines: {{count: 4}}
  surf: {{wave_height_m: 0.6}}
"""
