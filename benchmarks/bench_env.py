"""Agent-steps per second through `SwarmEnv.step` against MPE's `simple_spread_v3` at the same
agent counts.

    python benchmarks/bench_env.py [--counts 10 100 1000] [--steps 200] [--box-s 15] [--no-breakdown]
        [--batches 1000x10 100x100 10x1000] [--vector-only] [--today-ref REF] [--jaxmarl-python PY]

Our side: `benchmarks/missions/beach_swarm.yaml`, a swarm already on the beach of gentle_fine
searching it for mines (no sea transit), the count set per run with overrides={"swarm.count": n},
wheels mode, hazards at their defaults. The peer: mpe2's `simple_spread_v3.parallel_env(N=n,
max_cycles=..., continuous_actions=True)` (PettingZoo's parallel API through its AEC conversion).

Method, the same for both: build the env, `reset(seed=0)`, draw every action of the run from a
seeded numpy Generator and pack them into per-step action dicts *before* the clock starts (sampling
is not timed), run `--warmup` steps, then time `env.step` for `--steps` steps or until `--box-s`
seconds have passed, whichever comes first (at least one step; the last step may run past the box).
A rate is the number of live agents summed over the timed steps, divided by the wall time. When
MPE's warm-up step alone takes more than half the time box (N = 1000: one step takes over ten
seconds), that step is the measurement; the table says how many steps each rate rests on. Single
process, one core; on a shared machine expect +-20% between runs.

Targets: at least 100x MPE's agent-steps/s at 100 agents, and at least 200,000 agent-steps/s at
1000 robots.

The batched environment (`swarm.sim.vector_env`, `--batches BxN`): B runs of N robots of the same
mission, random actions (B, N, 3) drawn beforehand, agent-steps = robots in the mission summed over
the timed steps; next to it the PettingZoo adapter (`SwarmEnv.step`, dicts) on one run of N robots,
the same method. Issue 13's target: 2 M agent-steps/s at B x N = 10,000 robots. Beside it, with
`--today-ref REF`, the same measurement on the code of git commit REF (`git archive`, a fresh
process with it first on the path: before the batched core, the vector env looped over B
`SwarmEnv`s), and with `--jaxmarl-python PY` JaxMARL's MPE `simple_spread_v3` at the same B and N
on one core (`benchmarks/peer_jaxmarl.py`, run by PY, a Python with jaxmarl installed; JaxMARL is
not a dependency). `--vector-only` skips the MPE table (which needs the `bench` extra).

`--adapter-only --today-ref REF`: the PettingZoo adapter at `--counts`, the code of git commit REF
against this code, alternately `--repeat` times (issue 13: no slower than today at 100 and 1000).

Then (unless --no-breakdown), where our step's time goes at 100 robots and at the largest count:
timers wrapped around the environment's internals for a separate run (so they do not slow the rates
above).
`--profile` prints cProfile's top functions for that run instead of the timers; with
`--vector-only`, those of the vector env at each `--batches` size (by own time: the kernels).
"""

from __future__ import annotations

import argparse
import cProfile
import functools
import io
import json
import os
import platform
import pstats
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import swarm.sim
from swarm.sim.env import SwarmEnv

MISSION = Path(__file__).resolve().parent / "missions" / "beach_swarm.yaml"
ROOT = Path(__file__).resolve().parents[1]
#: The targets: ratio to MPE at 100 agents, our absolute rate at 1000 robots.
TARGET_RATIO_AT_100 = 100.0
TARGET_RATE_AT_1000 = 200_000.0
#: Issue 13: the batched environment at B x N = 10,000 robots, random actions, one core.
TARGET_VECTOR_RATE = 2_000_000.0


@dataclass
class Rate:
    agent_steps: int
    steps: int
    seconds: float

    @property
    def per_s(self) -> float:
        return self.agent_steps / self.seconds if self.seconds > 0 else float("nan")

    @property
    def ms_per_step(self) -> float:
        return 1e3 * self.seconds / self.steps if self.steps else float("nan")


def _time_steps(env: Any, actions: list[dict[str, Any]], warmup: int, steps: int, box_s: float) -> Rate:
    """Warm up, then time `env.step` over pre-built action dicts (only live agents get one)."""
    k = 0

    def one() -> tuple[int, float]:
        nonlocal k
        acts = actions[k % len(actions)]
        if len(env.agents) != len(acts):
            acts = {a: acts[a] for a in env.agents}
        live = len(env.agents)
        t0 = time.perf_counter()
        env.step(acts)
        k += 1
        return live, time.perf_counter() - t0

    first = None
    for _ in range(warmup):
        first = one()
        if first[1] > box_s / 2:  # one step takes half the time box: it is the measurement
            return Rate(first[0], 1, first[1])
    done, seconds, agent_steps = 0, 0.0, 0
    while done < steps and (done == 0 or seconds < box_s) and env.agents:
        live, dt = one()
        done += 1
        seconds += dt
        agent_steps += live
    return Rate(agent_steps, done, seconds)


def _wheel_actions(env: SwarmEnv, steps: int, seed: int) -> list[dict[str, np.ndarray]]:
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1.0, 1.0, (steps, len(env.possible_agents), 3)).astype(np.float32)
    return [dict(zip(env.possible_agents, a[k], strict=True)) for k in range(steps)]


def warmed_vector(b: int, n: int, steps: int, warmup: int, seed: int):
    """`vector_env` with b runs of n robots after `warmup` steps, the random wheel actions drawn
    beforehand for it (cycled), and its agent mask: what `vector_rate` and `vector_profile` time."""
    vec = swarm.sim.vector_env(
        mission=MISSION, num_envs=b, overrides={"swarm.count": n}, action_mode="wheels", seed=0
    )
    _, infos = vec.reset()
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.0, 1.0, (min(steps + warmup, 20), b, n, 3)).astype(np.float32)
    mask = infos["agent_mask"]
    for k in range(warmup):
        mask = vec.step(actions[k % len(actions)])[4]["agent_mask"]
    return vec, actions, mask


def vector_rate(b: int, n: int, steps: int, warmup: int, box_s: float, seed: int) -> Rate:
    """Agent-steps/s of `vector_env` with b runs of n robots (autoreset keeps every run going)."""
    vec, actions, mask = warmed_vector(b, n, steps, warmup, seed)
    done, seconds, agent_steps = 0, 0.0, 0
    while done < steps and (done == 0 or seconds < box_s):
        live = int(mask.sum())
        t0 = time.perf_counter()
        infos = vec.step(actions[(warmup + done) % len(actions)])[4]
        seconds += time.perf_counter() - t0
        mask = infos["agent_mask"]
        done += 1
        agent_steps += live
    return Rate(agent_steps, done, seconds)


#: `vector_rate` of another checkout, in a fresh process (`--today-ref`): prints agent-steps/s.
TODAY_VECTOR = """
import sys, time
import numpy as np
import swarm.sim
mission = sys.argv[1]
b, n, steps, warmup = (int(v) for v in sys.argv[2:6])
box_s, seed = float(sys.argv[6]), int(sys.argv[7])
vec = swarm.sim.vector_env(
    mission=mission, num_envs=b, overrides={"swarm.count": n}, action_mode="wheels", seed=0
)
_, infos = vec.reset()
rng = np.random.default_rng(seed)
actions = rng.uniform(-1.0, 1.0, (min(steps + warmup, 20), b, n, 3)).astype(np.float32)
mask = infos["agent_mask"]
for k in range(warmup):
    mask = vec.step(actions[k % len(actions)])[4]["agent_mask"]
done, seconds, agent_steps = 0, 0.0, 0
while done < steps and (done == 0 or seconds < box_s):
    live = int(mask.sum())
    t0 = time.perf_counter()
    infos = vec.step(actions[(warmup + done) % len(actions)])[4]
    seconds += time.perf_counter() - t0
    mask = infos["agent_mask"]
    done += 1
    agent_steps += live
print(agent_steps / seconds)
"""


#: The most memory a measurement of another checkout may take, as a share of what is available
#: when it starts: past it the measurement fails (MemoryError) rather than call the kernel's
#: out-of-memory killer onto the machine (the vector env before the batched core held B whole
#: SwarmEnvs: 1000 x 10 wanted about 20 GB).
TODAY_MEMORY_SHARE = 0.5


def _memory_cap() -> None:
    import resource

    from swarm.sim.memory import available_bytes

    free = available_bytes()
    if free:
        cap = int(free * TODAY_MEMORY_SHARE)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))


def today_vector_rate(src: Path, b: int, n: int, steps: int, warmup: int, box_s: float, seed: int) -> float:
    """`vector_rate` of the code exported to `src`, in a fresh process (nan if it failed, e.g.
    out of its memory cap)."""
    args = [str(MISSION), str(b), str(n), str(steps), str(warmup), str(box_s), str(seed)]
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run(
        [sys.executable, "-c", TODAY_VECTOR, *args],
        capture_output=True, text=True, cwd=src, env=env, preexec_fn=_memory_cap,
    )  # fmt: skip
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["?"])[-1]
        print(f"  today at {b} x {n} failed: {last[:120]}", flush=True)
        return float("nan")
    return float(out.stdout.strip().splitlines()[-1])


#: `ours_rate` of another checkout, in a fresh process (`--today-ref`): prints agent-steps/s.
TODAY_PZ = """
import sys, time
import numpy as np
import swarm.sim
mission = sys.argv[1]
n, steps, warmup = (int(v) for v in sys.argv[2:5])
box_s, seed = float(sys.argv[5]), int(sys.argv[6])
env = swarm.sim.parallel_env(mission=mission, overrides={"swarm.count": n}, action_mode="wheels")
env.reset(seed=0)
rng = np.random.default_rng(seed)
a = rng.uniform(-1.0, 1.0, (steps + warmup, len(env.possible_agents), 3)).astype(np.float32)
acts = [dict(zip(env.possible_agents, a[k], strict=True)) for k in range(steps + warmup)]
for k in range(warmup):
    env.step({x: acts[k][x] for x in env.agents})
done, seconds, agent_steps = 0, 0.0, 0
while done < steps and (done == 0 or seconds < box_s) and env.agents:
    step = {x: acts[warmup + done][x] for x in env.agents}
    live = len(step)
    t0 = time.perf_counter()
    env.step(step)
    seconds += time.perf_counter() - t0
    done += 1
    agent_steps += live
print(agent_steps / seconds)
"""


def today_adapter_rate(src: Path, n: int, steps: int, warmup: int, box_s: float, seed: int) -> float:
    """The PettingZoo adapter's agent-steps/s in the code exported to `src`, in a fresh process."""
    args = [str(MISSION), str(n), str(steps), str(warmup), str(box_s), str(seed)]
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run(
        [sys.executable, "-c", TODAY_PZ, *args],
        capture_output=True, text=True, check=True, cwd=src, env=env, preexec_fn=_memory_cap,
    )  # fmt: skip
    return float(out.stdout.strip().splitlines()[-1])


def adapter_table(
    counts: list[int], steps: int, warmup: int, box_s: float, seed: int, ref: str, repeat: int
) -> None:
    """The PettingZoo adapter (`SwarmEnv.step`, dicts) today (git `ref`) and now, alternately."""
    header = f"{'agents':>6} | {'today agent-steps/s':>19} {'now agent-steps/s':>17} | {'now / today':>11}"
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory(prefix="bench_env-today-") as tmp:
        src = Path(tmp)
        archive = subprocess.run(["git", "archive", ref], cwd=ROOT, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(src)], input=archive.stdout, check=True)
        for n in counts:
            old, new = [], []
            for _ in range(repeat):
                old.append(today_adapter_rate(src, n, steps, warmup, box_s, seed))
                new.append(ours_rate(n, steps, warmup, box_s, seed).per_s)
            print(
                f"{n:>6} | {max(old):>19,.0f} {max(new):>17,.0f} | {max(new) / max(old):>10.2f}x"
                f"   (each the best of {repeat}, alternating)",
                flush=True,
            )
    print(f"today: git {ref}, the same method in a fresh process; target: now >= today at 100 and 1000")


def jaxmarl_rates(python: str, batches: list[tuple[int, int]], steps: int, box_s: float, seed: int) -> dict:
    """JaxMARL's MPE at each (B, N), from `peer_jaxmarl.py` run by `python`: {(B, N): agent-steps/s}."""
    script = Path(__file__).resolve().parent / "peer_jaxmarl.py"
    configs = [f"{b}x{n}" for b, n in batches]
    cmd = [
        python,
        str(script),
        *configs,
        "--steps",
        str(min(steps, 50)),
        "--box-s",
        str(box_s),
        "--seed",
        str(seed),
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    rows = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    return {(r["B"], r["N"]): r["agent_steps_per_s"] for r in rows}


def vector_table(
    batches: list[tuple[int, int]],
    steps: int,
    warmup: int,
    box_s: float,
    seed: int,
    today_ref: str | None = None,
    jaxmarl_python: str | None = None,
) -> None:
    peer = jaxmarl_rates(jaxmarl_python, batches, steps, box_s, seed) if jaxmarl_python else {}
    header = (
        f"{'B x N':>11} {'robots':>7} | {'vector steps':>12} {'agent-steps/s':>14} {'ms/step':>8} | "
        f"{'PZ (N) steps':>12} {'agent-steps/s':>14} {'ms/step':>8} | {'vs 2M':>6}"
    )
    if today_ref:
        header += f" | {'today':>12} {'x today':>8}"
    if jaxmarl_python:
        header += f" | {'JaxMARL MPE':>12} {'x JaxMARL':>9}"
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory(prefix="bench_env-today-") as tmp:
        src = Path(tmp)
        if today_ref:
            archive = subprocess.run(["git", "archive", today_ref], cwd=ROOT, capture_output=True, check=True)
            subprocess.run(["tar", "-x", "-C", str(src)], input=archive.stdout, check=True)
        for b, n in batches:
            vec = vector_rate(b, n, steps, warmup, box_s, seed)
            pz = ours_rate(n, steps, warmup, box_s, seed)
            share = vec.per_s / TARGET_VECTOR_RATE
            line = (
                f"{f'{b} x {n}':>11} {b * n:>7} | {vec.steps:>12} {vec.per_s:>14,.0f} "
                f"{vec.ms_per_step:>8.2f} | {pz.steps:>12} {pz.per_s:>14,.0f} {pz.ms_per_step:>8.2f} | "
                f"{share:>6.1%}"
            )
            if today_ref:
                old = today_vector_rate(src, b, n, steps, warmup, box_s, seed)
                line += f" | {old:>12,.0f} {vec.per_s / old:>7.1f}x"
            if jaxmarl_python:
                mpe = peer.get((b, n), float("nan"))
                line += f" | {mpe:>12,.0f} {vec.per_s / mpe:>8.1f}x"
            print(line, flush=True)
    if today_ref:
        print(f"today: the vector env of git {today_ref}, the same method in a fresh process")
    if jaxmarl_python:
        print("JaxMARL MPE: simple_spread_v3, B envs of N agents, vmap + jit, continuous actions, one core")


def make_ours(n: int) -> SwarmEnv:
    env = swarm.sim.parallel_env(mission=MISSION, overrides={"swarm.count": n}, action_mode="wheels")
    env.reset(seed=0)
    return env


def ours_rate(n: int, steps: int, warmup: int, box_s: float, seed: int) -> Rate:
    env = make_ours(n)
    actions = _wheel_actions(env, steps + warmup, seed)
    return _time_steps(env, actions, warmup, steps, box_s)


def mpe_rate(n: int, steps: int, warmup: int, box_s: float, seed: int) -> Rate:
    from mpe2 import simple_spread_v3

    env = simple_spread_v3.parallel_env(N=n, max_cycles=10**9, continuous_actions=True)
    env.reset(seed=0)
    rng = np.random.default_rng(seed)
    agents = list(env.possible_agents)
    shape = env.action_space(agents[0]).shape
    low, high = env.action_space(agents[0]).low, env.action_space(agents[0]).high
    k = min(steps + warmup, 50)  # the action dicts are reused cyclically
    a = rng.uniform(low, high, (k, n, *shape)).astype(np.float32)
    actions = [dict(zip(agents, a[i], strict=True)) for i in range(k)]
    return _time_steps(env, actions, max(warmup, 1), steps, box_s)


# the breakdown ----------------------------------------------------------------------------------------
class Timers:
    """Wall time per label, accumulated by wrappers set on an object's attributes."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}

    def wrap(self, obj: object, name: str, label: str) -> None:
        fn: Callable[..., Any] = getattr(obj, name)
        self.seconds.setdefault(label, 0.0)
        self.calls.setdefault(label, 0)

        @functools.wraps(fn)
        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.seconds[label] += time.perf_counter() - t0
                self.calls[label] += 1

        setattr(obj, name, timed)


#: (attribute of the env, label): the parts of `_advance` timed one by one.
ADVANCE_PARTS = (
    ("_commands", "actions -> wheel and jet commands"),
    ("_sense", "mine sensing"),
    ("_update_comms", "radio links (every comms_period_s)"),
    ("_hazards", "hazards"),
)


def breakdown(n: int, steps: int, seed: int, profile: bool) -> str:
    env = make_ours(n)
    actions = _wheel_actions(env, steps, seed)
    if profile:
        pr = cProfile.Profile()
        pr.enable()
        for k in range(steps):
            env.step(actions[k] if len(env.agents) == n else {a: actions[k][a] for a in env.agents})
        pr.disable()
        out = io.StringIO()
        pstats.Stats(pr, stream=out).sort_stats("cumulative").print_stats(25)
        return out.getvalue()
    timers = Timers()
    timers.wrap(env, "_advance", "_advance")
    timers.wrap(env.physics, "step", "physics (skid model, terrain, waves)")
    for name, label in ADVANCE_PARTS:
        timers.wrap(env, name, label)
    timers.wrap(env, "observe", "observations (own, patch, neighbours, links, task)")
    timers.wrap(env, "info", "infos (one dict per agent)")
    total = 0.0
    agent_steps = 0
    for k in range(steps):
        acts = actions[k] if len(env.agents) == n else {a: actions[k][a] for a in env.agents}
        agent_steps += len(env.agents)
        t0 = time.perf_counter()
        env.step(acts)
        total += time.perf_counter() - t0
    s = timers.seconds
    parts = {name: s[name] for name in s if name not in ("_advance",)}
    inner = sum(s[label] for _, label in ADVANCE_PARTS) + s["physics (skid model, terrain, waves)"]
    parts["rest of the world step (release, phases, routes, score...)"] = s["_advance"] - inner
    parts["step(): building the returned dicts, ending agents"] = (
        total - s["_advance"] - s["observations (own, patch, neighbours, links, task)"]
        - s["infos (one dict per agent)"]
    )  # fmt: skip
    lines = [
        f"Where SwarmEnv.step's time goes at {n} robots ({steps} steps, {agent_steps / total:,.0f} "
        f"agent-steps/s with the timers on; {1e3 * total / steps:.2f} ms/step):",
        "",
        f"{'part':<62} {'ms/step':>8} {'share':>6}",
        f"{'-' * 62} {'-' * 8} {'-' * 6}",
    ]
    for label, sec in sorted(parts.items(), key=lambda kv: -kv[1]):
        lines.append(f"{label:<62} {1e3 * sec / steps:>8.2f} {100 * sec / total:>5.1f}%")
    lines.append(f"{'total':<62} {1e3 * total / steps:>8.2f} {100.0:>5.1f}%")
    calls = timers.calls["radio links (every comms_period_s)"]
    lines.append("")
    lines.append(
        f"The radio update runs every {env.config.comms_period_s:g} s of simulated time "
        f"({env.config.comms_period_s / env.config.dt_s:g} steps); its ms/step above is averaged over "
        f"all {calls} calls, of which {env.links_version} rebuilt the links."
    )
    return "\n".join(lines)


def batch_spec(text: str) -> tuple[int, int]:
    """`--batches` item RUNSxROBOTS, e.g. 10x1000: (runs, robots)."""
    runs, sep, robots = text.lower().partition("x")
    if not (sep and runs.isdigit() and robots.isdigit() and int(runs) > 0 and int(robots) > 0):
        raise argparse.ArgumentTypeError(f"found {text!r}, expected RUNSxROBOTS, e.g. 10x1000")
    return int(runs), int(robots)


def vector_profile(b: int, n: int, steps: int, warmup: int, seed: int) -> str:
    """cProfile's top functions by own time over `steps` steps of `vector_env` with b runs of n
    robots (`--profile --vector-only`): the batched core's kernels by name."""
    vec, actions, _ = warmed_vector(b, n, steps, warmup, seed)
    pr = cProfile.Profile()
    pr.enable()
    for k in range(steps):
        vec.step(actions[(warmup + k) % len(actions)])
    pr.disable()
    out = io.StringIO()
    pstats.Stats(pr, stream=out).sort_stats("tottime").print_stats(25)
    return f"vector_env {b} x {n}, {steps} steps, by own time:\n{out.getvalue()}"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[10, 100, 1000])
    ap.add_argument("--steps", type=int, default=200, help="timed steps per measurement (at most)")
    ap.add_argument("--warmup", type=int, default=5, help="untimed steps first")
    ap.add_argument("--box-s", type=float, default=15.0, help="time box per measurement, seconds")
    ap.add_argument("--seed", type=int, default=0, help="seed of the pre-drawn actions")
    ap.add_argument("--no-breakdown", action="store_true")
    ap.add_argument("--profile", action="store_true", help="cProfile instead of the timers")
    ap.add_argument(
        "--batches",
        nargs="+",
        type=batch_spec,
        default=[(1000, 10), (100, 100), (10, 1000)],
        metavar="RUNSxROBOTS",
        help="vector_env runs x robots (default 1000x10 100x100 10x1000)",
    )
    ap.add_argument("--vector-only", action="store_true", help="only the vector env table (no MPE)")
    ap.add_argument("--today-ref", help="also the vector env of this git commit (today's)")
    ap.add_argument(
        "--adapter-only",
        action="store_true",
        help="only the PettingZoo adapter at --counts, today (--today-ref) and now, alternately",
    )
    ap.add_argument("--repeat", type=int, default=3, help="--adapter-only: alternations")
    ap.add_argument("--jaxmarl-python", help="a Python with jaxmarl: JaxMARL's MPE beside the vector env")
    args = ap.parse_args(argv)
    if not (args.vector_only or args.adapter_only):  # before any measurement
        try:
            import mpe2  # noqa: F401 (the peer; the `bench` extra)
        except ImportError:
            raise SystemExit(
                "bench_env: the MPE peer needs the bench extra (pip install '.[bench]'); "
                "--vector-only runs without it"
            ) from None
    batches = args.batches

    print(
        f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} cpus; "
        f"mission {MISSION.relative_to(MISSION.parents[2])}; wheels mode, random actions drawn beforehand"
    )
    print(f"up to {args.steps} timed steps after {args.warmup} warm-up steps, {args.box_s:g} s time box each")
    print()
    if args.adapter_only:
        if not args.today_ref:
            ap.error("--adapter-only needs --today-ref")
        adapter_table(
            args.counts, args.steps, args.warmup, args.box_s, args.seed, args.today_ref, args.repeat
        )
        return
    if batches:
        vector_table(
            batches,
            args.steps,
            args.warmup,
            args.box_s,
            args.seed,
            args.today_ref,
            args.jaxmarl_python,
        )
        print()
    if args.vector_only:
        if args.profile:
            for b, n in batches:
                print(vector_profile(b, n, min(args.steps, 100), args.warmup, args.seed))
        return
    header = (
        f"{'agents':>6} | {'ours steps':>10} {'ours agent-steps/s':>18} {'ms/step':>8} | "
        f"{'MPE steps':>9} {'MPE agent-steps/s':>17} {'ms/step':>9} | {'ratio':>8}"
    )
    print(header)
    print("-" * len(header))
    rows: dict[int, tuple[Rate, Rate]] = {}
    for n in args.counts:
        ours = ours_rate(n, args.steps, args.warmup, args.box_s, args.seed)
        mpe = mpe_rate(n, args.steps, args.warmup, args.box_s, args.seed)
        rows[n] = (ours, mpe)
        print(
            f"{n:>6} | {ours.steps:>10} {ours.per_s:>18,.0f} {ours.ms_per_step:>8.2f} | "
            f"{mpe.steps:>9} {mpe.per_s:>17,.1f} {mpe.ms_per_step:>9.1f} | {ours.per_s / mpe.per_s:>7,.1f}x",
            flush=True,
        )
    print()
    if 100 in rows:
        ratio = rows[100][0].per_s / rows[100][1].per_s
        verdict = "PASS" if ratio >= TARGET_RATIO_AT_100 else "FAIL"
        print(
            f"{verdict}  100 agents: {ratio:,.1f}x MPE's agent-steps/s (target >= {TARGET_RATIO_AT_100:g}x)"
        )
    if 1000 in rows:
        rate = rows[1000][0].per_s
        verdict = "PASS" if rate >= TARGET_RATE_AT_1000 else "FAIL"
        print(f"{verdict}  1000 robots: {rate:,.0f} agent-steps/s (target >= {TARGET_RATE_AT_1000:,.0f})")
    if not args.no_breakdown:
        for n in sorted({n for n in args.counts if n == 100} | {max(args.counts)}):
            print()
            print(breakdown(n, min(args.steps, 200), args.seed, args.profile))


if __name__ == "__main__":
    main()
