"""Fit the per-surface contact parameters of the MuJoCo reference to the bundled sample runs.

Each sample run's measured wheel speeds drive the model; the fit minimises path RMSE (as % of
distance travelled) against the sample truth, plus half the final position error, over the runs
of that surface. The result, and the errors it achieves, go to ``surfaces.yaml`` so that anyone
using the reference can see how far to trust it.

    python benchmarks/reference/calibrate.py            # fit all surfaces, rewrite surfaces.yaml
    python benchmarks/reference/calibrate.py --evaluate # only report errors of surfaces.yaml

A fit starts from the values in surfaces.yaml (or from START when there is no such file).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import mujoco
import numpy as np
import yaml
from scipy.optimize import minimize

sys.path.insert(0, str(Path(__file__).resolve().parent))
from skid4_mujoco import REPO, SURFACES_YAML, TIMESTEP_S, Skid4Sim, Surface, load_surfaces

RUNS_DIR = REPO / "swarm" / "data" / "robot-runs"
RUNS = {
    "concrete": ["concrete_square", "concrete_straight"],
    "hardsand": ["hardsand_square", "hardsand_straight"],
    "softsand": ["softsand_straight"],
}
# Parameters fitted per surface (log-space). Soft sand has only a straight run, which says nothing
# about turning, so its sliding/torsional friction is carried over from hard sand.
FREE = {
    "concrete": ["sliding", "torsional", "rolling", "timeconst"],
    "hardsand": ["sliding", "torsional", "rolling", "timeconst"],
    "softsand": ["rolling", "timeconst", "lump_rms_m"],
}
START = {
    "concrete": Surface(sliding=1.0, torsional=0.14, rolling=0.001, timeconst=0.02),
    "hardsand": Surface(sliding=0.7, torsional=0.08, rolling=0.01, timeconst=0.02),
    "softsand": Surface(
        sliding=0.7,
        torsional=0.08,
        rolling=0.06,
        timeconst=0.02,
        lump_rms_m=0.0067,
        lump_wavelength_m=1.5,
    ),
}
SOFT_SEEDS = (0, 1, 2, 3)  # lumps are random: fit and report the soft-sand mean over these


def load_run(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(ssv rows: t wL wR heading X Y, truth rows: t X Y heading)."""
    return np.loadtxt(RUNS_DIR / f"{name}.ssv"), np.loadtxt(RUNS_DIR / f"{name}_truth.txt")


def run_metrics(sim: dict[str, np.ndarray], truth: np.ndarray) -> dict[str, float]:
    """Path RMSE (m and % of truth distance), final position error (m) and final heading error (deg)."""
    err = np.hypot(sim["x_m"] - truth[:, 1], sim["y_m"] - truth[:, 2])
    dist = float(np.sum(np.hypot(np.diff(truth[:, 1]), np.diff(truth[:, 2]))))
    rmse = float(np.sqrt(np.mean(err**2)))
    dh = math.degrees(math.remainder(float(sim["heading_rad"][-1] - truth[-1, 3]), 2 * math.pi))
    sim_dist = float(np.sum(np.hypot(np.diff(sim["x_m"]), np.diff(sim["y_m"]))))
    return {
        "distance_m": round(dist, 3),
        "sim_distance_m": round(sim_dist, 3),
        "path_rmse_m": round(rmse, 4),
        "path_rmse_pct": round(100 * rmse / dist, 2),
        "final_error_m": round(float(err[-1]), 4),
        "final_heading_error_deg": round(dh, 2),
        "heading_range_deg": round(math.degrees(float(np.ptp(np.unwrap(sim["heading_rad"])))), 2),
        "truth_heading_range_deg": round(math.degrees(float(np.ptp(np.unwrap(truth[:, 3])))), 2),
    }


def evaluate(surface_name: str, surface: Surface, seeds: tuple[int, ...] = (0,)) -> dict[str, dict]:
    """Metrics of each sample run of a surface (averaged over seeds on lumpy ground)."""
    out: dict[str, dict] = {}
    for run in RUNS[surface_name]:
        ssv, truth = load_run(run)
        per_seed = []
        for seed in seeds:
            sim = Skid4Sim(surface, seed=seed).run(ssv[:, 0], ssv[:, 1], ssv[:, 2], float(ssv[0, 3]))
            per_seed.append(run_metrics(sim, truth))
        if len(per_seed) == 1:
            out[run] = per_seed[0]
        else:
            # Means over seeds; the heading error as a mean magnitude, since its sign is random.
            out[run] = {
                k: round(float(np.mean([abs(m[k]) if "heading_error" in k else m[k] for m in per_seed])), 4)
                for k in per_seed[0]
            }
            out[run]["seeds"] = list(seeds)
            out[run]["per_seed_path_rmse_pct"] = [m["path_rmse_pct"] for m in per_seed]
    return out


def _cost(metrics: dict[str, dict]) -> float:
    return sum(
        m["path_rmse_pct"] ** 2 + 0.5 * (100 * m["final_error_m"] / m["distance_m"]) ** 2
        for m in metrics.values()
    )


def fit(surface_name: str, start: Surface, max_evals: int = 120) -> Surface:
    """Nelder-Mead in log-parameter space from a hand-found start; prints progress."""
    names = FREE[surface_name]
    seeds = SOFT_SEEDS if start.lump_rms_m > 0 else (0,)
    x0 = np.log([getattr(start, n) for n in names])

    def surf(x: np.ndarray) -> Surface:
        return replace(start, **{n: float(v) for n, v in zip(names, np.exp(x), strict=True)})

    def cost(x: np.ndarray) -> float:
        return _cost(evaluate(surface_name, surf(x), seeds))

    t0 = time.time()
    simplex = np.vstack([x0, x0 + 0.3 * np.eye(len(x0))])  # +35% steps: the default 5% is too timid
    res = minimize(
        cost,
        x0,
        method="Nelder-Mead",
        options={"maxfev": max_evals, "xatol": 0.01, "fatol": 0.01, "initial_simplex": simplex},
    )
    print(f"{surface_name}: cost {res.fun:.3f} after {res.nfev} runs, {time.time() - t0:.0f} s", flush=True)
    return surf(res.x)


def _rounded(s: Surface) -> dict[str, float]:
    return {k: float(f"{v:.4g}") for k, v in asdict(s).items()}


def write_yaml(surfaces: dict[str, Surface], path: Path = SURFACES_YAML) -> dict:
    """surfaces.yaml with the parameters, how they were fitted and the errors they achieve."""
    fitted = {
        name: evaluate(name, s, SOFT_SEEDS if s.lump_rms_m > 0 else (0,)) for name, s in surfaces.items()
    }
    doc = {
        "note": (
            "Contact parameters of the MuJoCo reference simulator (skid4_mujoco.py), one set per "
            "surface, fitted by calibrate.py: each bundled sample run's measured wheel speeds drive "
            "the model and Nelder-Mead (log-parameters) minimises sum(path RMSE %^2 + "
            "0.5 * final error %^2) against the sample truth. Soft sand's sliding/torsional friction "
            "is copied from hard sand (no soft-sand turning run exists); its lumps are random, so its "
            "errors are means over seeds (heading error as mean magnitude)."
        ),
        "engine": (
            f"MuJoCo {mujoco.__version__}, timestep {TIMESTEP_S} s, elliptic friction cone, "
            "semi-implicit Euler, condim 6 wheel-ground pairs"
        ),
        "units": (
            "sliding: Coulomb coefficient; torsional, rolling: metres (torque per newton of normal "
            "force); timeconst (s)/dampratio: MuJoCo solref of the contact; lump_rms_m: RMS height "
            "of the soft-sand heightfield; lump_wavelength_m: lump size (smoothing std = it / 2 pi)"
        ),
        "surfaces": {name: _rounded(s) for name, s in surfaces.items()},
        "achieved": fitted,
    }
    with path.open("w") as f:
        yaml.safe_dump(doc, f, sort_keys=False, width=100)
    return doc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--evaluate", action="store_true", help="report errors of surfaces.yaml, fit nothing")
    ap.add_argument("--write", action="store_true", help="with --evaluate: rewrite surfaces.yaml's errors")
    ap.add_argument("--surface", choices=sorted(RUNS), action="append", help="fit only these")
    ap.add_argument("--max-evals", type=int, default=120)
    args = ap.parse_args()
    current = load_surfaces() if SURFACES_YAML.exists() else dict(START)
    if args.evaluate and args.write:
        print(yaml.safe_dump(write_yaml(current)["achieved"], sort_keys=False))
        return
    if args.evaluate:
        for name, s in current.items():
            seeds = SOFT_SEEDS if s.lump_rms_m > 0 else (0,)
            print(name, yaml.safe_dump(evaluate(name, s, seeds), sort_keys=False), sep="\n")
        return
    todo = args.surface or ["concrete", "hardsand", "softsand"]
    for name in todo:
        start = current.get(name, START[name])
        if name == "softsand":  # turning friction follows hard sand
            hs = current.get("hardsand", START["hardsand"])
            start = replace(start, sliding=hs.sliding, torsional=hs.torsional)
        current[name] = fit(name, start, args.max_evals)
        print(name, _rounded(current[name]), flush=True)
    doc = write_yaml(current)
    print(yaml.safe_dump(doc["achieved"], sort_keys=False))


if __name__ == "__main__":
    main()
