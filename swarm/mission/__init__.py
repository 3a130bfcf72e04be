"""Missions: the YAML schema (`swarm.mission.schema`), loading with one-line errors and reference
checks (`swarm.mission.load`), and the JSON Schema editors validate mission files against.

```python
from swarm.mission import load_mission, mission_json_schema
mission = load_mission("missions/landing.yaml", {"swarm.count": 20})
mission.tasks[0].zones, mission.beach_map.regions["landing_a"], mission.hazards.attrition.mtbf_h
```
"""

from swarm.inputs import key_path, unit_of
from swarm.mission.load import (
    apply_overrides,
    load_mission,
    mission_from_dict,
    read_mission_yaml,
)
from swarm.mission.schema import (
    PLATFORM_OFFSHORE_M,
    PLATFORMS,
    SENSOR_MODELS,
    TASK_CLASSES,
    TASK_TYPES,
    BeaconTask,
    Hazards,
    LandingTask,
    Launch,
    Mission,
    Phases,
    Radio,
    RelayTask,
    SearchTask,
    Sensor,
    Success,
    SurveillanceTask,
    Task,
    mission_json_schema,
)

__all__ = [
    "PLATFORMS",
    "PLATFORM_OFFSHORE_M",
    "SENSOR_MODELS",
    "TASK_CLASSES",
    "TASK_TYPES",
    "BeaconTask",
    "Hazards",
    "LandingTask",
    "Launch",
    "Mission",
    "Phases",
    "Radio",
    "RelayTask",
    "SearchTask",
    "Sensor",
    "Success",
    "SurveillanceTask",
    "Task",
    "apply_overrides",
    "key_path",
    "load_mission",
    "mission_from_dict",
    "mission_json_schema",
    "read_mission_yaml",
    "unit_of",
]
