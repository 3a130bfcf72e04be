"""How far one run scales: plan and step a swarm of 1,000 and 10,000 robots, with time and memory.

    python benchmarks/bench_scale.py [--mission benchmarks/missions/beach_swarm.yaml]
        [--counts 1000 10000] [--steps 50]

For each count: `plan_mission` (routes for every robot: OMPL, one worker), `SwarmEnv` in command
mode with that plan, `reset`, then `--steps` steps of the scripted policy (`ScriptedPolicy.update`
and `env.advance`, as `swarm simulate` runs). Printed per count: plan seconds, environment build
and reset seconds, milliseconds per step and robot-steps per second, the peak resident memory of
the process so far (`resource.getrusage`, so each row includes the rows before it), and
`swarm.sim.memory`'s estimate for the whole run, to check the refusal threshold against a
measurement. Each count runs in a fresh process, so the peaks do not pile up.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def one(mission_path: str, count: int, steps: int) -> dict:
    from swarm.mission.load import load_mission
    from swarm.mission.plan import plan_mission
    from swarm.sim.env import SwarmEnv
    from swarm.sim.memory import estimate_bytes, mission_time_s
    from swarm.sim.policy import ScriptedPolicy

    mission = load_mission(mission_path, {"swarm.count": count})
    t0 = time.perf_counter()
    plan = plan_mission(mission, seed=mission.seed, workers=1)
    t1 = time.perf_counter()
    env = SwarmEnv(mission, action_mode="command", plan=plan)
    policy = ScriptedPolicy(env)
    env.reset(seed=0)
    t2 = time.perf_counter()
    done = 0
    for _ in range(steps):
        if not env.agents:
            break
        policy.update()
        env.advance({})
        done += 1
    t3 = time.perf_counter()
    cells = mission.beach_map.shape[0] * mission.beach_map.shape[1]
    return {
        "robots": count,
        "plan_s": t1 - t0,
        "build_s": t2 - t1,
        "ms_per_step": 1e3 * (t3 - t2) / max(done, 1),
        "robot_steps_per_s": count * done / max(t3 - t2, 1e-9),
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "estimate_mb": estimate_bytes(cells, count, mission_time_s(mission)) / 2**20,
        "steps": done,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mission", default=str(HERE / "missions" / "beach_swarm.yaml"))
    ap.add_argument("--counts", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)  # a single count, in this process
    args = ap.parse_args()
    if args.one is not None:
        print(json.dumps(one(args.mission, args.one, args.steps)))
        return
    print(f"{'robots':>7} {'plan s':>8} {'build s':>8} {'ms/step':>9} {'robot-steps/s':>14} "
          f"{'peak MB':>8} {'estimate MB':>12}")  # fmt: skip
    for n in args.counts:
        cmd = [sys.executable, __file__, "--mission", args.mission, "--steps", str(args.steps)]
        cmd += ["--one", str(n)]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]
        r = json.loads(out)
        print(f"{r['robots']:>7} {r['plan_s']:>8.1f} {r['build_s']:>8.1f} {r['ms_per_step']:>9.1f} "
              f"{r['robot_steps_per_s']:>14,.0f} {r['peak_mb']:>8.0f} {r['estimate_mb']:>12.0f}")  # fmt: skip


if __name__ == "__main__":
    main()
