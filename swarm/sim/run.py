"""One mission run with the built-in policy, and the mission log it leaves.

```python
log = simulate(load_mission("missions/mine_clear.yaml"), seed=3)
write_log(log, "reports/mine_clear-sim")   # trajectories.npz, events.jsonl, outcome.json
log = read_log("reports/mine_clear-sim")    # the same log back (without its plan unless given)
```

The log holds the trajectories as arrays sampled every `record_every_s` (time, x, y, heading,
alive, phase per robot), every event the environment and the policy logged (launches, phase
changes, detections, marks, losses with cause, relay breaks and repairs, takeovers, the
clearance, recoveries), the outcome against the success criteria, and the losses by cause and
phase. Files are written atomically; the same mission and seed give the same bytes.
"""

from __future__ import annotations

import io
import json
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from swarm.errors import InputError
from swarm.files import parse_json, read_npz, read_text, write_bytes_atomic, write_text_atomic
from swarm.inputs import expected, validate
from swarm.mission.plan import MissionPlan, plan_mission
from swarm.mission.schema import Mission
from swarm.sim.env import SimConfig, SwarmEnv
from swarm.sim.layout import PHASES, ROLES
from swarm.sim.memory import RECORD_EVERY_S, check_fits
from swarm.sim.policy import BatchPolicy, ScriptedPolicy
from swarm.sim.runview import RunView
from swarm.sim.setup import MissionSetup
from swarm.sim.world import World

#: The log's format version, written into outcome.json.
LOG_VERSION = 1
#: How often `simulate_batch` tells its `working` callback how far its runs have got (wall s).
WORKING_EVERY_S = 0.5


class _Criterion(BaseModel):
    model_config = ConfigDict(extra="ignore", strict=True, frozen=True)

    value: float
    target: float
    met: bool


class OutcomeFile(BaseModel):
    """outcome.json (`MissionLog.summary` plus the mines' states) as `read_log` reads it back."""

    model_config = ConfigDict(extra="ignore", strict=True, frozen=True)

    mission: str
    map: str
    seed: int
    success: bool
    criteria: dict[str, _Criterion]
    completed_s: float | None = None
    mines_state: dict[Literal["detected", "marked", "exploded", "cleared"], list[bool]] = Field(
        default_factory=dict
    )


class LogEvent(BaseModel):
    """One line of events.jsonl as `read_log` reads it back: the keys every kind shares, typed
    (each kind's own data rides along unchecked); a loss names its robot, cause, phase and place."""

    model_config = ConfigDict(extra="allow", strict=True, frozen=True)

    kind: str
    t_s: float = Field(allow_inf_nan=False)
    robot: str | None = None
    phase: str | None = None
    cause: str | None = None
    x_m: float | None = None
    y_m: float | None = None

    @model_validator(mode="after")
    def _complete(self) -> LogEvent:
        need = {"loss": ("robot", "cause", "phase", "x_m", "y_m"), "phase": ("phase",)}.get(self.kind, ())
        for key in need:
            if getattr(self, key) is None:
                raise expected(f"a {self.kind} event with its {key}", found=None, key=key)
        return self


Progress = Callable[[float, float], None]


@dataclass
class MissionLog:
    """A finished run: what happened, when and where."""

    mission: str
    map: str
    seed: int
    robots: list[str]
    times_s: np.ndarray  # (k,)
    xy_m: np.ndarray  # (k, n, 2) float32, NaN where the robot is not on the map
    heading_rad: np.ndarray  # (k, n) float32
    alive: np.ndarray  # (k, n) bool
    phase: np.ndarray  # (k, n) int8 index into PHASES
    events: list[dict]
    outcome: dict
    losses: list[dict]  # one per lost robot: robot, cause, phase, t_s, x_m, y_m
    mines_m: np.ndarray  # (m, 2) the truth
    mines_state: dict[str, list[bool]]  # detected, marked, exploded, cleared per mine
    objects_m: np.ndarray  # (k, 2) detections and false alarms
    object_mine: np.ndarray  # (k,) mine index or -1 for a false alarm
    plan: MissionPlan | None = field(default=None, repr=False)
    end_reasons: list[str | None] = field(default_factory=list)
    role: np.ndarray | None = None  # (k, n) int8 index into ROLES: takeovers change it
    completed_s: float | None = None  # mission time when every criterion was first met

    def losses_by_cause(self) -> dict[str, int]:
        return dict(sorted(Counter(x["cause"] for x in self.losses).items()))

    def losses_by_phase(self) -> dict[str, dict[str, int]]:
        out: dict[str, dict[str, int]] = {}
        for x in self.losses:
            out.setdefault(x["phase"], {}).setdefault(x["cause"], 0)
            out[x["phase"]][x["cause"]] += 1
        return out

    def summary(self) -> dict:
        """The JSON outcome: success, each criterion, losses, end states."""
        ends = Counter(r or "active" for r in self.end_reasons)
        return {
            "version": LOG_VERSION,
            "mission": self.mission,
            "map": self.map,
            "seed": self.seed,
            "robots": len(self.robots),
            "duration_s": float(self.times_s[-1]) if len(self.times_s) else 0.0,
            "completed_s": self.completed_s,
            "success": self.outcome["success"],
            "criteria": self.outcome["criteria"],
            "lost": len(self.losses),
            "losses_by_cause": self.losses_by_cause(),
            "losses_by_phase": self.losses_by_phase(),
            "end_states": dict(sorted(ends.items())),
            "mines": len(self.mines_m),
            "mines_detected": int(np.sum(self.mines_state["detected"])) if len(self.mines_m) else 0,
            "mines_cleared": int(np.sum(self.mines_state["cleared"])) if len(self.mines_m) else 0,
            "false_alarms": int(np.sum(self.object_mine < 0)),
        }


def simulate(
    mission: Mission,
    seed: int = 0,
    *,
    plan: MissionPlan | None = None,
    config: SimConfig | None = None,
    record_every_s: float = RECORD_EVERY_S,
    progress: Progress | None = None,
    on_step: Callable[[SwarmEnv], None] | None = None,
) -> MissionLog:
    """Run the mission once with the scripted policy, through the PettingZoo adapter. `progress(t_s,
    time_limit_s)` is called as simulated time passes; `on_step(env)` after every step (animation
    frames). A run that would not fit in memory is refused before anything is allocated
    (`swarm.sim.memory`). `simulate_batch` gives the same log for the same seed."""
    check_fits(mission, record_every_s=record_every_s)
    env = SwarmEnv(mission, action_mode="command", config=config, plan=plan)
    policy = ScriptedPolicy(env)
    env.reset(seed=seed)
    rec = _Recorder(env.run)
    next_record = record_every_s
    completed_s: float | None = None
    while env.agents:
        if env.fast_forward():  # nobody on the map yet: one stride through the sea transit
            next_record = max(next_record, env.t_s)
        policy.update()
        env.advance({})
        if completed_s is None and env.score.success():
            completed_s = env.t_s
        if on_step is not None:
            on_step(env)
        if env.t_s + 1e-9 >= next_record or not env.agents:
            rec.record()
            next_record += record_every_s
        if progress is not None:
            progress(env.t_s, env.time_limit_s)
    return _log(env.run, mission, seed, rec, completed_s)


def simulate_batch(
    mission: Mission,
    seeds: Sequence[int],
    *,
    plan: MissionPlan | None = None,
    config: SimConfig | None = None,
    record_every_s: float = RECORD_EVERY_S,
    setup: MissionSetup | None = None,
    progress: Callable[[int, int], None] | None = None,
    working: Callable[[float], None] | None = None,
) -> list[MissionLog]:
    """Run the mission once per seed with the scripted policy, all the runs stepped together on the
    batched world core (`swarm.sim.world`): the same logs as `simulate` with each seed, bit for bit.
    `setup` (a `MissionSetup` of this mission and plan, from an earlier batch) saves building it
    again; `progress(runs_done, runs)` is called as runs finish. `working(runs_worth)` is called
    about every `WORKING_EVERY_S` of wall time with the work done so far in runs: a finished run
    counts 1, one still going its share of the time limit. The runs of a batch advance together
    and finish together, so a bar moved by `progress` alone would sit at 0 until the end."""
    seeds = [int(s) for s in seeds]
    if not seeds:
        return []
    check_fits(mission, record_every_s=record_every_s, batch=len(seeds))
    config = config or SimConfig()
    if setup is None:
        plan = plan if plan is not None else plan_mission(mission, seed=mission.seed, workers=1)
        setup = MissionSetup(mission, plan, dt_s=config.dt_s, substep_s=config.substep_s)
    world = World(setup, len(seeds), comms_period_s=config.comms_period_s)
    world.score_every_step = False  # only the outcome is wanted
    world.reset(seeds)
    runs = world.runs
    policies = BatchPolicy(runs)
    recs = [_Recorder(run) for run in runs]
    next_record = [record_every_s] * len(runs)
    completed: list[float | None] = [None] * len(runs)
    live = list(range(len(runs)))
    said_at = time.monotonic()
    while live:
        if working is not None and time.monotonic() >= said_at + WORKING_EVERY_S:
            said_at = time.monotonic()
            going = np.minimum(world.steps[live] / world.max_steps, 1.0)
            working(float(len(runs) - len(live) + going.sum()))
        for b in world.off_map(live):  # the only runs `fast_forward` can skip ahead
            if world.fast_forward(b):
                next_record[b] = max(next_record[b], runs[b].t_s)
        policies.update(live)
        wheels, jet = world.controller_commands()
        ended, time_up, _ = world.advance(wheels, jet)
        world.finish(ended, time_up)
        still = []
        times, running = world.t_s.tolist(), world.in_agents.any(axis=1).tolist()
        scored = world.scored.tolist()  # success can have changed only where the score was looked at
        for b in live:
            t, going = times[b], running[b]
            if completed[b] is None and scored[b] and runs[b].score.success():
                completed[b] = t
            if t + 1e-9 >= next_record[b] or not going:
                recs[b].record()
                next_record[b] += record_every_s
            if going:
                still.append(b)
        if progress is not None and len(still) < len(live):
            progress(len(runs) - len(still), len(runs))
        live = still
    return [
        _log(run, mission, seed, rec, c)
        for run, seed, rec, c in zip(runs, seeds, recs, completed, strict=True)
    ]


class _Recorder:
    """Trajectory samples of one run (time, position, heading, liveness, phase, role)."""

    def __init__(self, run: RunView) -> None:
        self.run = run
        self.times: list[float] = []
        self.xy: list[np.ndarray] = []
        self.heading: list[np.ndarray] = []
        self.alive: list[np.ndarray] = []
        self.phase: list[np.ndarray] = []
        self.role: list[np.ndarray] = []
        self.record()

    def record(self) -> None:
        run = self.run
        on = run.alive & run.on_map
        self.times.append(run.t_s)
        self.xy.append(np.where(on[:, None], run.robot_state[:, :2], np.nan).astype(np.float32))
        self.heading.append(run.robot_state[:, 2].astype(np.float32))
        self.alive.append(run.alive.copy())
        self.phase.append(run.phase.astype(np.int8))
        self.role.append(run.role.astype(np.int8))


#: What the log records of each loss (`MissionLog.losses`), from its "loss" event.
LOSS_FIELDS = ("robot", "cause", "phase", "t_s", "x_m", "y_m")


def losses_of(events: list[dict]) -> list[dict]:
    """The log's losses: one record per "loss" event, `LOSS_FIELDS` (the one place they are made,
    for a run just simulated and for a log read back)."""
    return [{key: ev[key] for key in LOSS_FIELDS} for ev in events if ev.get("kind") == "loss"]


def _log(run: RunView, mission: Mission, seed: int, rec: _Recorder, completed_s: float | None) -> MissionLog:
    """The finished run's log: its samples, events, outcome and losses."""
    n, k = run.n, len(rec.times)
    losses = losses_of(run.events)
    mf = run.minefield
    return MissionLog(
        mission=mission.name or "mission",
        map=run.beach.name,
        seed=seed,
        robots=list(run.possible_agents),
        times_s=np.array(rec.times),
        xy_m=np.array(rec.xy).reshape(k, n, 2),
        heading_rad=np.array(rec.heading).reshape(k, n),
        alive=np.array(rec.alive).reshape(k, n),
        phase=np.array(rec.phase).reshape(k, n),
        role=np.array(rec.role).reshape(k, n),
        events=list(run.events),
        outcome=run.outcome(),
        losses=losses,
        mines_m=mf.positions_m.copy(),
        mines_state={key: getattr(mf, key).tolist() for key in ("detected", "marked", "exploded", "cleared")},
        objects_m=run.objects_m.copy(),
        object_mine=run.object_mine.copy(),
        plan=run.plan,
        end_reasons=list(run.end_reason),
        completed_s=completed_s,
    )


def write_log(log: MissionLog, out_dir: str | Path) -> dict[str, Path]:
    """trajectories.npz, events.jsonl and outcome.json in `out_dir` (created), each atomically."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {name: out / name for name in ("trajectories.npz", "events.jsonl", "outcome.json")}
    buf = io.BytesIO()
    np.savez_compressed(
        buf,
        times_s=log.times_s,
        xy_m=log.xy_m,
        heading_rad=log.heading_rad,
        alive=log.alive,
        phase=log.phase,
        role=log.role if log.role is not None else np.empty((0, len(log.robots)), np.int8),
        roles=np.array(ROLES),
        robots=np.array(log.robots),
        phases=np.array(PHASES),
        mines_m=log.mines_m,
        objects_m=log.objects_m,
        object_mine=log.object_mine,
    )
    write_bytes_atomic(paths["trajectories.npz"], buf.getvalue())
    write_text_atomic(
        paths["events.jsonl"], "".join(json.dumps(ev, sort_keys=True) + "\n" for ev in log.events)
    )
    summary = log.summary() | {"mines_state": log.mines_state}
    write_text_atomic(paths["outcome.json"], json.dumps(summary, indent=1, sort_keys=True) + "\n")
    return paths


#: The files of a written log.
LOG_FILES = ("trajectories.npz", "events.jsonl", "outcome.json")


def _end_reasons(robots: list[str], events: list[dict], alive_at_end: np.ndarray) -> list[str | None]:
    """How each robot left the mission, from the events: its loss cause, expended or recovered; a
    robot gone without such an event was stopped at the time limit; None while still active."""
    index = {r: i for i, r in enumerate(robots)}
    out: list[str | None] = [None] * len(robots)
    for ev in events:
        i = index.get(ev.get("robot"))
        if i is None:
            continue
        if ev["kind"] == "loss":
            out[i] = ev["cause"]
        elif ev["kind"] in ("expended", "recovered"):
            out[i] = ev["kind"]
    for i, alive in enumerate(alive_at_end):
        if out[i] is None and not alive:
            out[i] = "time_limit"
    return out


def _read_json_lines(path: Path, whole: bool = False) -> list:
    """A JSON file as one value (`whole`), else JSON Lines as a list; bad JSON is an `InputError`."""
    text = read_text(path, path.name)
    if whole:
        if not text.strip():
            raise InputError(path, "(file)", "nothing", "JSON written by swarm simulate")
        return [parse_json(text, path, path.name)]
    return [
        parse_json(line, path, path.name, n) for n, line in enumerate(text.splitlines(), 1) if line.strip()
    ]


def _check_trajectories(where: Path, arrays, n: int) -> None:
    """The arrays `write_log` writes, as it writes them: a sample per time and robot, times rising,
    phases and roles that exist (positions may be NaN: a robot not yet launched has none)."""
    times = np.asarray(arrays["times_s"])
    if times.ndim != 1:
        raise InputError(where, "times_s", f"shape {times.shape}", "one sample time after another")
    bad = ~np.isfinite(times)
    bad[1:] |= ~(times[1:] > times[:-1])
    if bad.any():
        i = int(np.argmax(bad))
        after = f" after {times[i - 1]:g}" if i and np.isfinite(times[i]) else ""
        raise InputError(
            where, f"times_s[{i}]", f"{times[i]:g}{after}", "finite sample times, each later than the last"
        )
    per_robot = (len(times), n)
    shapes = {"xy_m": (*per_robot, 2), "heading_rad": per_robot, "alive": per_robot, "phase": per_robot}
    if len(arrays["role"]):
        shapes["role"] = per_robot
    for name, shape in shapes.items():
        if np.shape(arrays[name]) != shape:
            raise InputError(
                where, name, f"shape {np.shape(arrays[name])}", f"{shape}: a value per sample time and robot"
            )
    for name, names in (("phase", PHASES), ("role", ROLES)):
        if name in shapes:
            values = np.asarray(arrays[name])
            bad = values[(values < 0) | (values >= len(names))]
            if len(bad):
                raise InputError(where, name, int(bad[0]), f"an index into {name}s, 0..{len(names) - 1}")


def read_log(out_dir: str | Path, plan: MissionPlan | None = None) -> MissionLog:
    """The log `write_log` wrote into `out_dir`, with `plan` attached (plan.json is read by
    `swarm.report.load`, which can find the map). A missing or damaged file is an `InputError`."""
    out = Path(out_dir)
    for name in LOG_FILES:
        if not (out / name).is_file():
            raise InputError(
                out, name, "no such file", f"a simulation log folder with {', '.join(LOG_FILES)}"
            )
    summary = _read_json_lines(out / "outcome.json", whole=True)[0]
    validate(OutcomeFile, summary, out / "outcome.json")
    events = _read_json_lines(out / "events.jsonl")
    for n, event in enumerate(events, 1):
        validate(LogEvent, event, f"{out / 'events.jsonl'}: event {n}")
    where = out / "trajectories.npz"
    try:
        arrays = read_npz(where, "the trajectories swarm simulate wrote")
        robots = [str(r) for r in arrays["robots"]]
        n = len(robots)
        times = arrays["times_s"]
        _check_trajectories(where, arrays, n)
        role = arrays["role"] if len(arrays["role"]) else None
        alive = arrays["alive"].astype(bool).reshape(len(times), n)
        log = MissionLog(
            mission=str(summary["mission"]),
            map=str(summary["map"]),
            seed=int(summary["seed"]),
            robots=robots,
            times_s=times,
            xy_m=arrays["xy_m"].reshape(len(times), n, 2),
            heading_rad=arrays["heading_rad"].reshape(len(times), n),
            alive=alive,
            phase=arrays["phase"].reshape(len(times), n),
            events=events,
            outcome={"success": bool(summary["success"]), "criteria": summary["criteria"]},
            losses=losses_of(events),
            mines_m=arrays["mines_m"].reshape(-1, 2),
            mines_state={k: list(v) for k, v in (summary.get("mines_state") or {}).items()},
            objects_m=arrays["objects_m"].reshape(-1, 2),
            object_mine=arrays["object_mine"],
            plan=plan,
            role=role,
            completed_s=summary.get("completed_s"),
        )
        log.end_reasons = _end_reasons(robots, events, alive[-1] if len(alive) else np.ones(n, bool))
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        found = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise InputError(where, "(contents)", found, "a log written by swarm simulate") from None
    return log
