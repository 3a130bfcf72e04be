"""Robot-steps per second of the `skid` model against one `solve_ivp` per robot (the thesis's way).

    python benchmarks/bench_dynamics.py [--seconds 2.0] [--dt 0.01]

For n = 1, 100, 1000, 10000 robots on mixed terrain, times `SkidModel.step` (all robots in one
vectorized call) and scipy's RK45 run robot by robot over the same simulated time, and prints both
rates and their ratio. One core: numpy's elementwise loops do not thread. The RK45 peer is timed on
at most `--peer-robots` robots and scaled linearly (it is one independent solve per robot).
Target (issue 2): at least 5 million robot-steps per second at n = 1000.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from swarm.robot.params import load_robot
from swarm.robot.skid import SkidModel, coeffs_for
from swarm.robot.terrain import load_library

ROBOT_YAML = Path(__file__).resolve().parents[1] / "swarm" / "data" / "robots" / "skid4.yaml"
LAND = ("concrete", "wet_hard_sand", "soft_sand", "dirt", "rock", "vegetation", "shallow_water")


def swarm_rate(model: SkidModel, n: int, sim_s: float, dt: float, rng: np.random.Generator) -> float:
    lib = load_library()
    coeffs = coeffs_for([lib[LAND[i % len(LAND)]] for i in range(n)])
    omega = rng.uniform(2.0, 9.0, (n, 2))
    state = np.zeros((n, 6))
    steps = max(1, round(sim_s / dt))
    best = 0.0
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(steps):
            state = model.step(state, omega, coeffs, dt)
        best = max(best, n * steps / (time.perf_counter() - t0))
    return best


def peer_rate(model: SkidModel, n: int, sim_s: float, dt: float, rng: np.random.Generator, cap: int) -> float:
    lib = load_library()
    m = min(n, cap)
    steps = max(1, round(sim_s / dt))
    t_eval = np.linspace(0.0, steps * dt, steps + 1)
    t0 = time.perf_counter()
    for i in range(m):
        coeffs = coeffs_for(lib[LAND[i % len(LAND)]])
        omega = rng.uniform(2.0, 9.0, (1, 2))

        def rhs(_t: float, s: np.ndarray, omega: np.ndarray = omega, coeffs: dict = coeffs) -> np.ndarray:
            return model.derivatives(s[None, :], omega, coeffs)[0]

        solve_ivp(rhs, (0.0, t_eval[-1]), np.zeros(6), method="RK45", t_eval=t_eval, rtol=1e-6, atol=1e-8)
    return m * steps / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated time per measurement")
    parser.add_argument("--dt", type=float, default=0.01, help="fixed step (s)")
    parser.add_argument("--peer-robots", type=int, default=5, help="robots timed for the solve_ivp peer")
    args = parser.parse_args()
    model = SkidModel(load_robot(ROBOT_YAML))
    rng = np.random.default_rng(0)
    print(f"skid model, dt = {args.dt} s, {args.seconds} s simulated per run, one core")
    print(f"{'robots':>7} {'skid step (robot-steps/s)':>27} {'solve_ivp per robot':>21} {'ratio':>9}")
    for n in (1, 100, 1000, 10000):
        ours = swarm_rate(model, n, args.seconds, args.dt, rng)
        peer = peer_rate(model, n, args.seconds, args.dt, rng, args.peer_robots)
        print(f"{n:>7} {ours:>27,.0f} {peer:>21,.0f} {ours / peer:>8.0f}x")
    print("target: >= 5,000,000 robot-steps/s at n = 1000")


if __name__ == "__main__":
    main()
