"""Held-out runs from a MuJoCo robot the project was never developed on: a rear-heavy variant.

    python benchmarks/reference/make_variant.py --out DIR [--variant rear_heavy] [--surfaces ...]

`make_runs.py` drives skid4 on the surfaces fitted to the sample runs; the model was developed
against those. This writes the thesis's four patterns (`swarm.robot.patterns`: straight, square,
spiral, square_spiral_line) for another robot on other surfaces, in the same file formats, plus
``robot.yaml``, the robot file the CLI reads (with the centre of mass and yaw inertia stated, as
a user who weighed and swung the robot would give them). Nothing in it was fitted to anything.

Variant `rear_heavy`: a 0.5 m track, 0.4 m wheelbase robot on 0.1 m wheels, 40 kg of which a
10.7 kg payload sits 0.25 m behind the wheel centre, so the centre of mass is 6.7 cm behind it
(the issue's engine B robot had its centre of mass that far back). Surfaces: other Coulomb,
torsional and rolling friction than skid4's (`VARIANT_SURFACES`), chosen, not fitted.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from run_files import RATE_HZ, write_run  # noqa: E402
from skid4_mujoco import Skid4Sim, Surface  # noqa: E402

from swarm.robot.patterns import spiral, square, square_spiral_line, straight  # noqa: E402

VARIANTS: dict[str, dict[str, float]] = {
    "rear_heavy": {
        "mass_kg": 40.0,
        "wheel_mass_kg": 1.2,
        "wheel_radius_m": 0.1,
        "track_width_m": 0.5,
        "wheelbase_m": 0.4,
        "length_m": 0.55,
        "width_m": 0.42,
        "height_m": 0.15,
        "encoder_ticks_per_wheel_rev": 1960,
        "ballast_kg": 10.7,
        "ballast_x_m": -0.25,
    },
}
#: Chosen, not fitted: a little less grip than skid4's surfaces, less torsional friction.
VARIANT_SURFACES: dict[str, Surface] = {
    "concrete": Surface(sliding=0.8, torsional=0.05, rolling=0.002, timeconst=0.02),
    "hardsand": Surface(sliding=0.7, torsional=0.03, rolling=0.012, timeconst=0.015),
    "softsand": Surface(
        sliding=0.6, torsional=0.04, rolling=0.04, timeconst=0.025, lump_rms_m=0.006, lump_wavelength_m=2.0
    ),
}
#: Effective track the patterns steer with (the square's corners come out near 90 degrees).
PATTERN_TRACK_M = 0.9
PATTERNS = {"straight": 136.0, "square": 180.0, "spiral": 0.0, "square_spiral_line": 180.0}
WHEEL_WIDTH_M = 0.08


def robot_file(robot: dict[str, float]) -> dict[str, object]:
    """The project's robot file: mass, geometry and the centre of mass and yaw inertia the MJCF has
    (box body, box payload, cylinder wheels, each about the whole robot's centre of mass)."""
    mw, r, bal = robot["wheel_mass_kg"], robot["wheel_radius_m"], robot["ballast_kg"]
    m_body = robot["mass_kg"] - 4 * mw - bal
    com_x = bal * robot["ballast_x_m"] / robot["mass_kg"]
    izz = m_body / 12 * (robot["length_m"] ** 2 + robot["width_m"] ** 2) + m_body * com_x**2
    izz += bal / 12 * (0.1**2 + 0.2**2) + bal * (robot["ballast_x_m"] - com_x) ** 2
    wheel_izz = mw * (3 * r**2 + WHEEL_WIDTH_M**2) / 12
    for sx in (1, -1):
        for sy in (1, -1):
            x, y = sx * robot["wheelbase_m"] / 2 - com_x, sy * robot["track_width_m"] / 2
            izz += wheel_izz + mw * (x * x + y * y)
    keys = [k for k in robot if k not in ("ballast_kg", "ballast_x_m")]
    doc: dict[str, object] = {"name": "rear_heavy", **{k: robot[k] for k in keys}}
    doc |= {
        "com_x_m": round(com_x, 4),
        "com_y_m": 0.0,
        "com_height_m": robot["wheel_radius_m"],
        "measured_yaw_inertia_kgm2": round(izz, 3),
    }
    return doc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--variant", default="rear_heavy", choices=sorted(VARIANTS))
    ap.add_argument("--surfaces", default="concrete,hardsand,softsand")
    ap.add_argument("--seed", type=int, default=0, help="soft-sand lumps and encoder jitter")
    args = ap.parse_args()
    robot = VARIANTS[args.variant]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "robot.yaml").write_text(yaml.safe_dump(robot_file(robot), sort_keys=False))
    builders = {
        "straight": straight,
        "square": square,
        "spiral": spiral,
        "square_spiral_line": square_spiral_line,
    }
    for surface in args.surfaces.split(","):
        sim = Skid4Sim(VARIANT_SURFACES[surface], seed=args.seed, robot=robot)
        for name, heading0_deg in PATTERNS.items():
            kwargs = {"wheel_radius_m": robot["wheel_radius_m"], "dt_s": 1 / RATE_HZ}
            if name != "straight":
                kwargs["track_width_m"] = PATTERN_TRACK_M
            pattern = builders[name](**kwargs)
            t = np.round(pattern.t_s - pattern.t_s[0], 6)
            out = sim.run(t, pattern.left_radps, pattern.right_radps, math.radians(heading0_deg))
            write_run(
                args.out / f"{surface}_{name}", t, out, int(robot["encoder_ticks_per_wheel_rev"]), args.seed
            )
            dist = float(np.sum(np.hypot(np.diff(out["x_m"]), np.diff(out["y_m"]))))
            turned = math.degrees(out["heading_rad"][-1] - out["heading_rad"][0])
            print(f"{surface}_{name}: {t[-1]:.1f} s, {dist:.2f} m, turned {turned:.0f} deg")


if __name__ == "__main__":
    main()
