"""The sensors of a batch of runs stepped together (`swarm.sim.sensor_batch.SensorBatch`): every
run finds what its own `MineSensor.update` finds alone, report for report, and its generator ends
where it would, for the continuous inverse-cube law, a sensor that draws once per pass, false
alarms, robots that jump, robots that stop sensing, runs without mines and runs not stepped."""

from __future__ import annotations

import numpy as np
import pytest

from swarm.mission.schema import Sensor
from swarm.sim.mines import MineField
from swarm.sim.sensing import MineSensor
from swarm.sim.sensor_batch import SensorBatch

RUNS, ROBOTS = 6, 12
SENSORS = {
    "inverse cube, false alarms": Sensor(model="inverse_cube", sweep_width_m=3.0, false_alarms_per_km=20.0),
    "inverse cube": Sensor(model="inverse_cube", sweep_width_m=3.0),
    "cookie cutter, false alarms": Sensor(model="cookie_cutter", sweep_width_m=4.0, false_alarms_per_km=20.0),
}


@pytest.mark.parametrize("sensor", list(SENSORS.values()), ids=list(SENSORS))
def test_a_batch_of_sensors_reports_what_each_reports_alone(sensor: Sensor) -> None:
    rng = np.random.default_rng(11)
    fields = [rng.uniform(0.0, 300.0, (0 if b == 2 else 30, 2)) for b in range(RUNS)]  # run 2: none
    last = np.full((RUNS * ROBOTS, 2), np.nan)  # the batch's sensors keep their last positions here
    batched = []
    for b, mines in enumerate(fields):
        s = MineSensor(sensor, MineField(mines.copy()), ROBOTS)
        s._last_xy = last[b * ROBOTS : (b + 1) * ROBOTS]
        batched.append(s)
    alone = [MineSensor(sensor, MineField(mines.copy()), ROBOTS) for mines in fields]
    batch = SensorBatch(batched, ROBOTS)
    gens = [np.random.default_rng(100 + b) for b in range(RUNS)]
    ref = [np.random.default_rng(100 + b) for b in range(RUNS)]
    xy = rng.uniform(0.0, 300.0, (RUNS * ROBOTS, 2))
    found = 0
    for k in range(400):
        step = rng.normal(0.0, 0.7, xy.shape)
        step[rng.random(len(xy)) < 0.03] *= 60.0  # a jump past the screen's margin
        xy = xy + step
        sensing = rng.random(len(xy)) < 0.9
        alive = sensing | (rng.random(len(xy)) < 0.5)
        distance = np.hypot(step[:, 0], step[:, 1])
        runs = list(range(RUNS)) if k % 7 else [0, 3, 4]  # some steps leave runs out
        t = np.full(RUNS, float(k))
        out = batch.step(xy, last, sensing, alive, distance, runs, t, gens)
        for b in runs:
            rows = slice(b * ROBOTS, (b + 1) * ROBOTS)
            want = alone[b].update(
                xy[rows], sensing[rows], distance[rows], float(k), ref[b], alive=alive[rows]
            )
            assert out.get(b, []) == want, (k, b)
            if want:
                batch.dirty(b)
                found += len(want)
    assert found > 20  # mines and false alarms were reported
    for g, r in zip(gens, ref, strict=True):
        assert g.bit_generator.state == r.bit_generator.state
