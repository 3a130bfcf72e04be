"""Write held-out reference runs, in the thesis's file formats, for any wheel-command pattern.

The MuJoCo reference (skid4_mujoco.py, parameters in surfaces.yaml) drives the pattern; the
output looks exactly like the bundled sample runs so the project's readers, calibration and
validation can consume it unchanged:

- ``<surface>_<pattern>.ssv``: t, measured wL, measured wR, heading, X, Y at 100 Hz (5 decimals);
- ``<surface>_<pattern>_truth.txt``: t X Y heading at 100 Hz (4 decimals);
- ``<surface>_<pattern>_encoders.txt``: time_ms, left_ticks, right_ticks (tab-separated, ~38 Hz,
  25-28 ms jitter from a seeded generator, cumulative ticks floored from the wheel angle).

    python benchmarks/reference/make_runs.py --pattern-npz P.npz --surface concrete --out DIR \\
        --heading0-deg 180
    python benchmarks/reference/make_runs.py --demo --surface hardsand --out DIR  # square-spiral-line
    python benchmarks/reference/make_runs.py --patterns --out DIR  # the held-out benchmark's set
    python benchmarks/reference/make_runs.py --patterns --timeconst 0.004 --out DIR  # stiffer contacts

``--patterns`` writes, for each surface, the thesis's straight, square, spiral and
square-spiral-line as `swarm.robot.patterns` builds them for skid4 (initial headings 136, 180, 0
and 180 degrees, as the sample runs start), and the hand-made ``--demo`` run as ``demo``: the
set `benchmarks/bench_heldout.py` scores (``--tests spiral,demo,square_spiral_line``).

``--timeconst S`` replaces every surface's contact softness (MuJoCo's solref time constant,
0.014-0.022 s in surfaces.yaml) by S: the same engine with stiffer (or softer) contacts, to see
what the fitted softness does to turning (README, Accuracy: at 0.004 s most of skid4's rise in
hard-sand turning efficiency from wide arcs to a pivot, and its speed dependence, are gone).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run_files import RATE_HZ, write_run
from skid4_mujoco import REPO, Surface, load_robot, load_surfaces, simulate


def surface_for(name: str, timeconst: float | None = None) -> Surface:
    """A surface of surfaces.yaml, its contact time constant replaced when `timeconst` is given."""
    surface = load_surfaces()[name]
    return surface if timeconst is None else replace(surface, timeconst=timeconst)


def make_run(
    t_s: np.ndarray,
    left_radps: np.ndarray,
    right_radps: np.ndarray,
    surface: str,
    pattern: str,
    out_dir: Path,
    heading0_rad: float,
    seed: int = 0,
    timeconst: float | None = None,
) -> dict[str, Path]:
    """Simulate a commanded pattern on a surface and write its three files; returns their paths.

    Commands may be at any rate; the run is sampled at 100 Hz from t_s[0] (time reset to 0).
    ``seed`` draws the soft-sand lumps and the encoder timing jitter.
    """
    t_s = np.asarray(t_s, dtype=float)
    dur = t_s[-1] - t_s[0]
    t = np.round(np.arange(0, round(dur * RATE_HZ) + 1) / RATE_HZ, 6)
    left = np.interp(t, t_s - t_s[0], left_radps)
    right = np.interp(t, t_s - t_s[0], right_radps)
    sim = simulate(t, left, right, surface_for(surface, timeconst), heading0_rad, seed=seed)
    return write_run(
        Path(out_dir) / f"{surface}_{pattern}",
        t,
        sim,
        int(load_robot()["encoder_ticks_per_wheel_rev"]),
        seed,
    )


def square_spiral_line() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hand-made ~60 s test pattern: the sample square's wheel speeds, a ~180 deg pivot at +-4 rad/s,
    a counter-clockwise tightening spiral with rising speed, then an accelerating straight.

    Only for testing this tool; the project's real patterns come from swarm/robot/patterns.py.
    """
    sq = np.loadtxt(REPO / "swarm" / "data" / "robot-runs" / "concrete_square.ssv")
    dt = 1.0 / RATE_HZ
    parts_l, parts_r = [sq[:, 1]], [sq[:, 2]]

    def ramp(n_total: int, n_ramp: int) -> np.ndarray:
        env = np.ones(n_total)
        up = np.linspace(0.0, 1.0, n_ramp)
        env[:n_ramp], env[-n_ramp:] = up, up[::-1]
        return env

    n = int(4.5 / dt)  # pivot: about 180 deg on concrete with 0.3 s ramps
    env = ramp(n, int(0.3 / dt))
    parts_l.append(-4.0 * env)
    parts_r.append(4.0 * env)

    n = int(18.0 / dt)  # spiral: mean 3 -> 6 rad/s, right-left 1.5 -> 7 rad/s (radius ~2.2 -> ~0.9 m)
    s = np.linspace(0.0, 1.0, n)
    env = np.minimum(1.0, s * 18.0 / 0.5)  # 0.5 s start-up ramp
    mean_end, diff_end = 6.0, 7.0
    mean = (3.0 + (mean_end - 3.0) * s) * env
    diff = (1.5 + (diff_end - 1.5) * s) * env
    parts_l.append(mean - diff / 2)
    parts_r.append(mean + diff / 2)

    n = int(11.5 / dt)  # straight: blend out the turn over 1 s, accelerate 6 -> 8.5 rad/s, stop
    s = np.linspace(0.0, 1.0, n)
    blend = np.clip(1.0 - s * 11.5, 0.0, 1.0)
    mean = mean_end + 2.5 * s
    end_ramp = np.clip((1.0 - s) * 11.5 / 0.8, 0.0, 1.0)  # stop over the last 0.8 s
    parts_l.append((mean - diff_end / 2 * blend) * end_ramp)
    parts_r.append((mean + diff_end / 2 * blend) * end_ramp)

    left = np.concatenate(parts_l)
    right = np.concatenate(parts_r)
    t = np.arange(len(left)) * dt
    return t, left, right


#: Pattern name -> initial heading (degrees), as the sample runs start.
PATTERN_HEADINGS = {"straight": 136.0, "square": 180.0, "spiral": 0.0, "square_spiral_line": 180.0}


def pattern_set(out_dir: Path, surfaces: list[str], seed: int = 0, timeconst: float | None = None) -> None:
    """The held-out benchmark's runs: the four thesis patterns and the demo, on each surface
    (its contact time constant replaced by `timeconst` if given)."""
    from swarm.robot.patterns import make_pattern

    for surface in surfaces:
        for name, heading0_deg in PATTERN_HEADINGS.items():
            p = make_pattern(name.replace("_", "-"), dt_s=1.0 / RATE_HZ)
            t = np.round(p.t_s - p.t_s[0], 6)  # already the 100 Hz grid: no resampling
            surf = surface_for(surface, timeconst)
            sim = simulate(t, p.left_radps, p.right_radps, surf, math.radians(heading0_deg), seed=seed)
            write_run(
                Path(out_dir) / f"{surface}_{name}",
                t,
                sim,
                int(load_robot()["encoder_ticks_per_wheel_rev"]),
                seed,
            )
            print(f"{surface}_{name}")
        t, left, right = square_spiral_line()
        make_run(t, left, right, surface, "demo", out_dir, math.radians(180.0), seed, timeconst)
        print(f"{surface}_demo")


def main() -> None:
    ap = argparse.ArgumentParser(description="Write a held-out reference run in the thesis formats.")
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--pattern-npz", type=Path, help="npz with arrays t_s, left_radps, right_radps")
    src.add_argument("--demo", action="store_true", help="use the built-in square-spiral-line test pattern")
    src.add_argument(
        "--patterns", action="store_true", help="the thesis's four patterns and the demo on every surface"
    )
    ap.add_argument(
        "--surface", choices=sorted(load_surfaces()), help="see surfaces.yaml (all with --patterns)"
    )
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    ap.add_argument("--pattern", help="pattern name in file names (default: npz stem or square_spiral_line)")
    ap.add_argument(
        "--heading0-deg",
        type=float,
        default=None,
        help="initial heading, degrees CCW from +X (default 180 for --demo, else 0)",
    )
    ap.add_argument("--seed", type=int, default=0, help="soft-sand lumps and encoder jitter")
    ap.add_argument("--save-demo-npz", type=Path, help="with --demo: also save the commands as npz")
    ap.add_argument(
        "--timeconst", type=float, help="contact time constant (s) of every surface (default: surfaces.yaml)"
    )
    args = ap.parse_args()
    if args.patterns:
        surfaces = [args.surface] if args.surface else sorted(load_surfaces())
        pattern_set(args.out, surfaces, args.seed, args.timeconst)
        return
    if args.surface is None:
        ap.error("--surface is required with --pattern-npz or --demo")

    if args.demo:
        t, left, right = square_spiral_line()
        pattern = args.pattern or "square_spiral_line"
        heading0 = 180.0 if args.heading0_deg is None else args.heading0_deg
        if args.save_demo_npz:
            np.savez(args.save_demo_npz, t_s=t, left_radps=left, right_radps=right)
    else:
        npz = np.load(args.pattern_npz)
        t, left, right = npz["t_s"], npz["left_radps"], npz["right_radps"]
        pattern = args.pattern or args.pattern_npz.stem
        heading0 = 0.0 if args.heading0_deg is None else args.heading0_deg

    t0 = time.time()
    paths = make_run(
        t, left, right, args.surface, pattern, args.out, math.radians(heading0), args.seed, args.timeconst
    )
    print(f"{args.surface}_{pattern}: {t[-1] - t[0]:.1f} s simulated in {time.time() - t0:.1f} s")
    for p in paths.values():
        print(f"  {p}")


if __name__ == "__main__":
    main()
