"""Regenerate the shipped maps: `python maps/generate_maps.py` (from the repository root).

Each map is `swarm.world.generate.generate_beach` with the arguments below, written with
`swarm.world.io.save_map` (YAML + compressed npz). Two of them need arguments `swarm map generate`
does not take (wave period, river mouth, rock outcrops), hence this script. `--figures DIR` also
draws each map (the same figure as `swarm map show`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

MAPS: dict[str, dict[str, object]] = {
    # a long, gentle, fine-sand beach: wide surf zone, wide dry beach, dunes, coast road
    "gentle_fine": dict(seed=11, length_m=1000, width_m=200, cell_m=1.0, d50_mm=0.2, breaker_height_m=1.0),
    # a steep, coarse beach with rock outcrops and a river mouth, under a longer swell
    "steep_coarse_river": dict(
        seed=7,
        length_m=600,
        width_m=250,
        cell_m=1.0,
        d50_mm=1.5,
        breaker_height_m=1.5,
        wave_period_s=10.0,
        river_mouth=True,
        rock_outcrops=1.0,
    ),
    # small and quick, for tests
    "test_small": dict(seed=3, length_m=120, width_m=80, cell_m=1.0, d50_mm=0.3, breaker_height_m=0.6),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", type=Path, default=Path(__file__).resolve().parent)
    parser.add_argument("--figures", type=Path, metavar="DIR", help="also draw each map as DIR/NAME.png")
    parser.add_argument("names", nargs="*", help=f"maps to write (default: all of {', '.join(MAPS)})")
    args = parser.parse_args()

    from swarm.world.generate import generate_beach
    from swarm.world.io import save_map

    for name in args.names or MAPS:
        beach_map = generate_beach(name=name, **MAPS[name])  # type: ignore[arg-type]
        out = args.out_dir / f"{name}.yaml"
        save_map(beach_map, out)
        print(f"wrote {out}: {beach_map.width_m:g} m x {beach_map.height_m:g} m, cells {beach_map.shape}")
        if args.figures is not None:
            from swarm.report.map_figure import plot_map

            args.figures.mkdir(parents=True, exist_ok=True)
            plot_map(beach_map, args.figures / f"{name}.png")


if __name__ == "__main__":
    main()
