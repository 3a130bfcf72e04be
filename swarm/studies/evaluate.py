"""`swarm plan --evaluate N`: the plan simulated N times with the study machinery, so the plan report
can put what the simulation delivers next to what the plan promises.

The evaluation is a study of one point (the mission with the plan's overrides and plan seed as
single-valued sweeps) in ``<plan folder>/evaluation/``, resumable like any study. When the observed
P(success) misses the target, a quick sweep of the swarm size (1.5x and 2x the count, with
`QUICK_RUNS` runs each, or N if that is fewer) suggests the size to study properly; when it meets the
target but its Wilson lower bound does not, the evaluation says how many runs would show it.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np

from swarm.errors import SwarmError
from swarm.files import write_text_atomic
from swarm.studies import stats
from swarm.studies.store import SPEC, read_study_file
from swarm.studies.study import Progress, StudySpec, run_study
from swarm.studies.sweep import Sweep
from swarm.studies.table import END_COUNTS

#: Runs per size of the quick sweep that suggests a size when the target is missed.
QUICK_RUNS = 16
#: Multiples of the planned swarm size the quick sweep tries.
QUICK_FACTORS = (1.5, 2.0)
EVALUATION_FILE = "evaluation.json"
#: The evaluation's studies, in a plan's folder: the plan's own runs, and the quick sweep of sizes.
EVALUATION_DIR = "evaluation"
STUDY_DIRS = ("plan", "sizes")


def discard_stale(out: str | Path, spec: StudySpec | None) -> None:
    """Before a plan is written into `out`: drop its earlier evaluation (evaluation.json, which a
    report would put beside the new plan), and its runs unless they are `spec`'s (the same plan
    evaluated again resumes them; None: no evaluation this time). A refusal to resume another
    plan's runs, after the new plan.json, left the folder half rewritten."""
    (Path(out) / EVALUATION_FILE).unlink(missing_ok=True)
    folder = Path(out) / EVALUATION_DIR
    if spec is None:
        shutil.rmtree(folder, ignore_errors=True)
        return
    _fresh(folder / STUDY_DIRS[0], spec)  # the quick sweep's is checked when it is known


def _fresh(study: Path, spec: StudySpec) -> None:
    """Remove the study folder `study` unless it holds `spec`'s runs."""
    if not study.exists():
        return
    try:
        same = read_study_file(study / SPEC).model_dump() == spec.as_dict()
    except SwarmError:  # missing or unreadable: not this study's
        same = False
    if not same:
        shutil.rmtree(study)


def plan_spec(
    mission_path: str | Path,
    runs: int,
    overrides: dict[str, object] | None = None,
    plan_seed: int | None = None,
    target: float = 0.9,
    confidence: float = 0.95,
) -> StudySpec:
    """The study that evaluates a plan: its mission with the overrides held, `runs` runs."""
    fixed = dict(overrides or {})
    if plan_seed is not None:
        fixed["seed"] = plan_seed
    sweeps = [Sweep(k, (v,)) for k, v in fixed.items()]
    return StudySpec(str(mission_path), runs, sweeps, seed=0, target=target, confidence=confidence)


def evaluate_plan(
    mission_path: str | Path,
    out: str | Path,
    *,
    runs: int,
    count: int,
    overrides: dict[str, object] | None = None,
    plan_seed: int | None = None,
    target: float = 0.9,
    confidence: float = 0.95,
    workers: int | None = None,
    progress: Progress | None = None,
) -> dict:
    """Simulate the plan `runs` times; write and return the evaluation (module docstring)."""
    spec = plan_spec(mission_path, runs, overrides, plan_seed, target, confidence)
    sweeps = spec.sweeps
    folder = Path(out) / EVALUATION_DIR
    table, summary = run_study(spec, folder / STUDY_DIRS[0], workers=workers, progress=progress)
    cols = table.to_pydict()
    (point,) = summary["points"]
    detection = [v for v in cols.get("value_detection", []) if v is not None]
    ends = {c: [v for v in cols.get(c, []) if v is not None] for c in END_COUNTS}
    result = {
        "runs": point["runs"],
        "successes": point["successes"],
        "success_rate": point["success_rate"],
        "wilson_low": point["wilson_low"],
        "wilson_high": point["wilson_high"],
        # the plan's chance of success (`success_chance`; None where it gives none)
        "planned_success": point.get("planned_success"),
        "target": target,
        "confidence": confidence,
        "detection": stats.distribution(np.asarray(detection, dtype=np.float64)) if detection else None,
        "detection_values": detection,
        # the t intervals of the means, for `stats.agreement` with the plan's expectations
        "detection_interval": point["detection_interval"],
        "lost_interval": point["lost_interval"],
        "lost": stats.distribution(np.asarray([len(x) for x in cols["losses"]], dtype=np.float64)),
        "lost_values": [len(x) for x in cols["losses"]],
        # robots the clearance expended (one a mine cleared) and robots back at sea
        **{c: stats.distribution(np.asarray(v, dtype=np.float64)) if v else None for c, v in ends.items()},
        "losses_by_cause": point["losses_by_cause"],
        # each cause's robots lost a run with its interval, beside the plan's (`summarize`)
        "lost_by_cause": point.get("lost_by_cause") or [],
        # lost robots' stations the spares took over a run, with its interval (`summarize`)
        "takeovers_mean": point.get("takeovers_mean"),
        "takeovers_interval": point.get("takeovers_interval"),
        "losses_by_phase": point["losses_by_phase"],
        "seeds": cols["seed"],
        "folder": str(folder / "plan"),
        "suggested_count": None,
    }
    if point["wilson_low"] < target <= point["success_rate"]:
        # the plan looks good enough, the runs are too few to say so at this confidence
        result["runs_needed"] = stats.runs_for_lower_bound(point["success_rate"], target, confidence)
    elif point["success_rate"] < target:
        sizes = sorted({max(count + 1, math.ceil(count * f)) for f in QUICK_FACTORS})
        quick = StudySpec(
            str(mission_path),
            min(runs, QUICK_RUNS),
            [Sweep("swarm.count", tuple(sizes)), *(s for s in sweeps if s.key != "swarm.count")],
            seed=1,
            target=target,
            confidence=confidence,
        )
        _fresh(folder / STUDY_DIRS[1], quick)
        _, qs = run_study(quick, folder / STUDY_DIRS[1], workers=workers, progress=progress)
        result["sizes"] = [
            {
                "count": p["params"]["swarm.count"],
                "runs": p["runs"],
                "success_rate": p["success_rate"],
                "wilson_low": p["wilson_low"],
                "wilson_high": p["wilson_high"],
            }
            for p in qs["points"]
            if not p.get("infeasible")
        ]
        met = [
            p["params"]["swarm.count"]
            for p in qs["points"]
            if p["success_rate"] is not None and p["success_rate"] >= target
        ]
        result["suggested_count"] = min(met) if met else None
    write_text_atomic(Path(out) / EVALUATION_FILE, json.dumps(result, indent=1, sort_keys=True) + "\n")
    return result
