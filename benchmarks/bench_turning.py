"""Steady turning, engine against a fitted `skid` mode: how turning efficiency depends on the
turn's radius and speed.

    python benchmarks/bench_turning.py --engine mujoco|bullet|rear_heavy --surface hardsand \\
        --fit FIT.yaml [--robot ROBOT.yaml] [--timeconst S]

Drives the reference engine with constant wheel commands (1 s ramp, 7 s in all) over a grid of
rim speeds v (m/s) and commanded turn ratios q = (w_R - w_L) / (w_R + w_L) (0: straight, 1: inner
wheel stopped, pivot: equal and opposite), then drives `skid` on FIT.yaml's mode (a
`swarm model calibrate` output) with the engine's own measured wheel speeds. Prints each one's
turning efficiency: yaw rate over the kinematic R_w (w_R - w_L) / B, averaged over the last 2.5 s.
A square's corners sit near q = 1; the square-spiral-line's pivot at q = inf and its spiral at
q = 0.6-1 and lower speed, so a flat model row against a sloped engine row is what a fit on the
square cannot carry to those turns.

`--timeconst S` (MuJoCo engines) replaces the surface's contact time constant: how much of the
engine's slope belongs to its contact softness. skid4 on hard sand (0.0136 s in surfaces.yaml):
0.60 in wide arcs to 0.66-0.68 in a pivot, up to 5% more at 0.6 m/s; at 0.004 s, 0.60-0.62 to
0.62, nearly speed-free. The rear-heavy robot's slope stays (0.51-0.52 to 0.64 at 0.004 s).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "reference"))
sys.path.insert(0, str(HERE / "reference_bullet"))

from swarm.robot.params import load_robot  # noqa: E402
from swarm.robot.predict import predict  # noqa: E402
from swarm.robot.terrain import load_library  # noqa: E402
from swarm.robot.wheels import WheelInput  # noqa: E402

MODE = {"concrete": "concrete", "hardsand": "wet_hard_sand", "softsand": "soft_sand"}
SPEEDS_MPS = (0.15, 0.35, 0.6)
RATIOS = (0.1, 0.25, 0.5, 1.0, 2.0, math.inf)
DT_S, T_S, AVERAGE_S = 0.01, 7.0, 2.5


def engine(name: str, surface: str, timeconst: float | None = None):
    """simulate(t, left, right, heading0) -> dict of the engine's run, and the default robot file."""
    if timeconst is not None and name == "bullet":
        raise SystemExit("--timeconst is for the MuJoCo engines")
    if name == "bullet":
        from husky_bullet import simulate

        return (lambda t, left, right: simulate(t, left, right, surface, 0.0)), None
    if name == "rear_heavy":
        from make_variant import VARIANT_SURFACES, VARIANTS
        from skid4_mujoco import Skid4Sim

        surf = VARIANT_SURFACES[surface]
        surf = surf if timeconst is None else replace(surf, timeconst=timeconst)
        sim = Skid4Sim(surf, robot=VARIANTS["rear_heavy"])
        return (lambda t, left, right: sim.run(t, left, right, 0.0)), None
    from skid4_mujoco import load_surfaces, simulate

    surf = load_surfaces()[surface]
    surf = surf if timeconst is None else replace(surf, timeconst=timeconst)
    robot = HERE.parent / "swarm" / "data" / "robots" / "skid4.yaml"
    return (lambda t, left, right: simulate(t, left, right, surf, 0.0)), robot


def efficiency(t: np.ndarray, heading: np.ndarray, yaw_kinematic: float) -> float:
    keep = t >= t[-1] - AVERAGE_S
    return float(np.polyfit(t[keep], np.unwrap(heading)[keep], 1)[0] / yaw_kinematic)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", choices=("mujoco", "bullet", "rear_heavy"), default="mujoco")
    ap.add_argument("--surface", choices=sorted(MODE), default="hardsand")
    ap.add_argument("--fit", type=Path, required=True, help="terrain YAML from swarm model calibrate")
    ap.add_argument("--robot", type=Path, help="robot file (skid4 for mujoco; required otherwise)")
    ap.add_argument("--timeconst", type=float, help="MuJoCo contact time constant (s) for the surface")
    args = ap.parse_args()
    simulate, default_robot = engine(args.engine, args.surface, args.timeconst)
    robot = load_robot(args.robot or default_robot)
    mode = load_library(args.fit)[MODE[args.surface]]
    t = np.round(np.arange(0.0, T_S + 1e-9, DT_S), 6)
    ramp = np.clip(t / 1.0, 0.0, 1.0)
    print(f"turning efficiency (yaw rate / kinematic), {args.engine} {args.surface}: engine / skid")
    print(f"{'v m/s':>6}" + "".join(f"{'q=' + ('pivot' if math.isinf(q) else f'{q:g}'):>14}" for q in RATIOS))
    for v in SPEEDS_MPS:
        cells = []
        for q in RATIOS:
            w = v / robot.wheel_radius_m
            mean, diff = (0.0, 2 * w) if math.isinf(q) else (w, 2 * q * w)
            run = simulate(t, (mean - diff / 2) * ramp, (mean + diff / 2) * ramp)
            keep = t >= T_S - AVERAGE_S
            yaw_kin = robot.wheel_radius_m * float(np.mean((run["right_radps"] - run["left_radps"])[keep]))
            yaw_kin /= robot.track_width_m
            wheels = WheelInput.from_speeds(t, run["left_radps"], run["right_radps"])
            model = predict("skid", wheels, robot, mode)
            ref = efficiency(t, run["heading_rad"], yaw_kin)
            ours = efficiency(t, np.interp(t, model.t_s, model.heading_rad), yaw_kin)
            cells.append(f"{ref:6.3f}/{ours:5.3f}")
        print(f"{v:6.2f}" + "".join(f"{c:>14}" for c in cells))


if __name__ == "__main__":
    main()
