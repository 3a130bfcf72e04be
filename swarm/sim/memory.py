"""Will a run fit in memory? An estimate from the map's size and the swarm's, made before anything
big is allocated, so a run that cannot fit is refused with the numbers instead of swapping the
machine to a halt or dying half-way (e.g. 10,000 robots on a 20 km beach).

The coefficients are measured (tracemalloc peaks, on this code, `benchmarks/` style):

- planning: about 1240 bytes per map cell (mine_clear on gentle_fine, 200,000 cells: 248 MB peak;
  cost-map layers, clearance and distance transforms, the roadmap);
- simulating: about 250 bytes per map cell (landing on test_small: 2.4 MB for 9,600 cells) and
  about 32 bytes per robot per logged sample (every `RECORD_EVERY_S` of mission time: position,
  heading, alive, phase and role, held in lists and then copied into arrays);

rounded up, plus a fixed amount per robot for its plan, state, route and sensors: 512 kB, from
`benchmarks/bench_scale.py` (beach_swarm on gentle_fine: peak 313 MB with 1,000 robots, 4.4 GB
with 10,000, about 455 kB more per robot).
"""

from __future__ import annotations

import os

from swarm.errors import InputError
from swarm.mission.schema import Mission

PLAN_BYTES_PER_CELL = 1300
SIM_BYTES_PER_CELL = 300
BYTES_PER_ROBOT_SAMPLE = 40
BYTES_PER_ROBOT = 512 * 1024
#: Mission seconds between logged samples (`swarm.sim.run.RECORD_EVERY_S`).
RECORD_EVERY_S = 2.0


def mission_time_s(mission: Mission) -> float:
    """The longest a run can last: every phase's time limit."""
    back = mission.phases.return_to_sea
    return mission.beach_end_s + (back.time_limit_s if back.enabled else 0.0)


def estimate_bytes(
    cells: int, robots: int, time_s: float, *, simulate: bool = True, record_every_s: float = RECORD_EVERY_S
) -> int:
    """Peak bytes of planning (and, with `simulate`, running) a mission on `cells` map cells."""
    need = cells * PLAN_BYTES_PER_CELL + robots * BYTES_PER_ROBOT
    if simulate:
        samples = int(time_s / record_every_s) + 2
        need += cells * SIM_BYTES_PER_CELL + robots * samples * BYTES_PER_ROBOT_SAMPLE
    return need


def available_bytes() -> int | None:
    """Memory the system can give without swapping (Linux MemAvailable), or None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _gb(n: float) -> str:
    return f"{n / 1e9:.3g} GB" if n >= 1e9 else f"{n / 1e6:.3g} MB"


def check_fits(
    mission: Mission,
    *,
    simulate: bool = True,
    at_once: int = 1,
    record_every_s: float = RECORD_EVERY_S,
    source: str | None = None,
    batch: int = 1,
) -> int:
    """Refuse (`InputError` on `swarm.count`, or on the phases' time limits when a run's recorded
    tracks are what does not fit) a mission whose `at_once` runs in parallel would need
    more memory than is available; returns the estimate in bytes for one run (of `batch` runs
    stepped together in one process, `swarm.sim.world`: one map, `batch` times the robots)."""
    bm = mission.beach_map
    cells = int(bm.terrain.size)
    count = mission.swarm.count
    time_s = mission_time_s(mission)
    one = estimate_bytes(cells, count * batch, time_s, simulate=simulate, record_every_s=record_every_s)
    free = available_bytes()
    if free is not None and one * at_once > free:
        rows, cols = bm.terrain.shape
        runs = ""
        if at_once > 1:
            runs = f" x {at_once} runs at once" + (" (fewer --workers would fit)" if one <= free else "")
        size = f"{cols * bm.cell_m:g} x {rows * bm.cell_m:g} m, {cells:,} cells"
        found = f"{count} robots on {bm.name} ({size})"
        key = "swarm.count"
        instant = estimate_bytes(cells, count * batch, 0.0, simulate=simulate, record_every_s=record_every_s)
        if instant * at_once <= free:  # the recorded tracks are what do not fit: the run is too long
            key = "phases (time limits)"
            found = f"{time_s:g} s of mission time for {count} robots (the phase time limits added up)"
        raise InputError(
            source or mission.source or "mission",
            key,
            found,
            f"a run that fits in memory: it needs about {_gb(one)}{runs}, {_gb(free)} is available",
        )
    return one
