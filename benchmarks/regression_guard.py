"""Regression guard: hashes of whole simulated runs (events, outcome, trajectories), to check that
a refactor of the simulator reproduces today's runs bit for bit.

    python benchmarks/regression_guard.py record guard.json            # on the reference code
    python benchmarks/regression_guard.py check guard.json [--batch]   # on the changed code

`--batch` also runs the same seeds together in one batch (`swarm.sim.batch`, when it exists) and
compares each against the recorded lone run. Runs: mine_clear seeds 3 and 11, landing seed 1,
full_conops seed 1 (the plans made with each mission's own seed, as `swarm simulate` does).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RUNS = [("mine_clear", 3), ("mine_clear", 11), ("landing", 1), ("full_conops", 1)]


def digest_dir(out: Path) -> dict[str, str]:
    """sha256 of events.jsonl and outcome.json, and of every array of trajectories.npz."""
    h = {
        name: hashlib.sha256((out / name).read_bytes()).hexdigest()
        for name in ("events.jsonl", "outcome.json")
    }
    with np.load(out / "trajectories.npz") as z:
        for k in sorted(z.files):
            a = z[k]
            h[f"npz:{k}"] = hashlib.sha256(
                a.dtype.str.encode() + str(a.shape).encode() + a.tobytes()
            ).hexdigest()
    return h


def digest_log(log) -> dict[str, str]:
    from swarm.sim.run import write_log

    with tempfile.TemporaryDirectory() as tmp:
        write_log(log, tmp)
        return digest_dir(Path(tmp))


def run_all(batch: bool) -> dict[str, dict]:
    from swarm.mission.load import load_mission
    from swarm.mission.plan import plan_mission
    from swarm.sim.run import simulate

    out: dict[str, dict] = {}
    by_mission: dict[str, list[int]] = {}
    for name, seed in RUNS:
        by_mission.setdefault(name, []).append(seed)
    for name, seeds in by_mission.items():
        mission = load_mission(ROOT / "missions" / f"{name}.yaml")
        plan = plan_mission(mission, seed=mission.seed, workers=1)
        for seed in seeds:
            t0 = time.perf_counter()
            log = simulate(mission, seed=seed, plan=plan)
            out[f"{name}:{seed}"] = digest_log(log) | {"_runtime_s": round(time.perf_counter() - t0, 2)}
            print(f"{name} seed {seed}: {out[f'{name}:{seed}']['_runtime_s']} s", file=sys.stderr)
        if batch:
            from swarm.sim.run import simulate_batch

            t0 = time.perf_counter()
            logs = simulate_batch(mission, seeds=[*seeds, seeds[0]], plan=plan)
            dt = time.perf_counter() - t0
            for i, (seed, log) in enumerate(zip([*seeds, seeds[0]], logs, strict=True)):
                out[f"{name}:{seed}:batch{i}"] = digest_log(log) | {"_runtime_s": round(dt, 2)}
            print(f"{name} batch of {len(seeds) + 1}: {dt:.2f} s", file=sys.stderr)
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("action", choices=["record", "check"])
    ap.add_argument("file")
    ap.add_argument("--batch", action="store_true")
    a = ap.parse_args()
    got = run_all(a.batch)
    if a.action == "record":
        Path(a.file).write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        return 0
    ref = json.loads(Path(a.file).read_text())
    bad = 0
    for key, h in sorted(got.items()):
        base = ref[":".join(key.split(":")[:2])]
        diff = sorted(k for k in base if not k.startswith("_") and base[k] != h.get(k))
        print(f"{key}: {'identical' if not diff else 'DIFFERS in ' + ', '.join(diff)}")
        bad += bool(diff)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
