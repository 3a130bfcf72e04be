"""A model validation (`swarm model validate --out DIR`) on disk and as a report.

```
DIR/validation.json   the scores `--json` prints (the chosen model's, then "compare"), plus the run,
                      the terrain mode, the models and the accuracy target
DIR/validation.npz    the reference and every model's predicted poses, to redraw the figures
DIR/report.*          the report: verdict against the target, scores table, thesis-style overlay
```

The accuracy target (issue 2, `tests/robot/test_accuracy.py`): path RMSE under 3% of the distance
the reference travelled. The verdict holds the chosen model to it; the table shows every model.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import get_type_hints

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, create_model

from swarm.errors import InputError
from swarm.files import atomic_path, read_json, read_npz, write_text_atomic
from swarm.inputs import validate
from swarm.report.document import Figure, Report, Table, header, jsonable, verdict
from swarm.report.validation import Poses, errors_png, validation_png
from swarm.robot.predict import Trajectory
from swarm.robot.validate import Score

VALIDATION_FILE = "validation.json"
ARRAYS_FILE = "validation.npz"
#: Path RMSE must stay under this percentage of the distance travelled.
TARGET_RMSE_PCT = 3.0
POSE_KEYS = ("t_s", "x_m", "y_m", "heading_rad")


#: One model's score as validation.json keeps it (`Score.as_dict`): the dataclass's fields, checked.
_ScoreEntry = create_model(
    "_ScoreEntry",
    __config__=ConfigDict(extra="ignore", strict=True, frozen=True),
    **{name: (kind, ...) for name, kind in get_type_hints(Score).items()},
)


class _ValidationMeta(BaseModel):
    model_config = ConfigDict(extra="ignore", strict=True, frozen=True)

    run: str
    distance_m: float
    model: str
    models: list[str] = Field(min_length=1)
    terrain: str
    robot: str | None = None
    target_rmse_pct: float = Field(TARGET_RMSE_PCT, gt=0)
    arrays: str = Field(ARRAYS_FILE, pattern=r"^[^/\\]+$")


class ValidationFile(_ScoreEntry):  # type: ignore[misc,valid-type]
    """validation.json (`Validation.as_json`) as `swarm report` reads it: the chosen model's score,
    the others' under "compare", and what the report needs under "validation"."""

    compare: list[_ScoreEntry] = Field(default_factory=list)
    validation: _ValidationMeta


@dataclass
class Validation:
    """One run scored by one or more models: `model` is the one asked for, the others compared."""

    run: str
    distance_m: float
    truth: Poses  # the reference: a `Truth` from the run, or a `Trajectory` read back
    trajectories: dict[str, Trajectory]
    scores: dict[str, Score]
    model: str
    terrain: str
    robot: str | None = None
    target_pct: float = TARGET_RMSE_PCT

    def printed(self) -> dict:
        """What `swarm model validate --json` prints: the chosen model's score, then "compare"."""
        out = self.scores[self.model].as_dict()
        others = [m for m in self.scores if m != self.model]
        if others:
            out["compare"] = [self.scores[m].as_dict() for m in others]
        return out

    def as_json(self) -> dict:
        """validation.json: the printed scores plus what the report needs to read them."""
        return {
            **self.printed(),
            "validation": {
                "run": self.run,
                "distance_m": self.distance_m,
                "model": self.model,
                "models": list(self.scores),
                "terrain": self.terrain,
                "robot": self.robot,
                "target_rmse_pct": self.target_pct,
                "arrays": ARRAYS_FILE,
            },
        }


def write_validation(out_dir: str | Path, v: Validation) -> dict[str, Path]:
    """validation.json and validation.npz in `out_dir` (created), each atomically."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {VALIDATION_FILE: out / VALIDATION_FILE, ARRAYS_FILE: out / ARRAYS_FILE}
    arrays = {f"truth_{k}": np.asarray(getattr(v.truth, k), dtype=np.float64) for k in POSE_KEYS}
    for model, traj in v.trajectories.items():
        arrays.update({f"{model}_{k}": np.asarray(getattr(traj, k), dtype=np.float64) for k in POSE_KEYS})
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    with atomic_path(paths[ARRAYS_FILE]) as tmp:
        Path(tmp).write_bytes(buf.getvalue())
    write_text_atomic(paths[VALIDATION_FILE], json.dumps(jsonable(v.as_json()), indent=1) + "\n")
    return paths


def read_validation(out_dir: str | Path) -> Validation:
    """The validation `write_validation` wrote into `out_dir`; a damaged file is an `InputError`."""
    out = Path(out_dir)
    path = out / VALIDATION_FILE
    data = read_json(path, VALIDATION_FILE)
    file = validate(ValidationFile, data, path)
    meta = file.validation
    fields = [f.name for f in dataclasses.fields(Score)]
    scores = [file, *file.compare]
    by_model = {s.model: Score(**{k: getattr(s, k) for k in fields}) for s in scores}
    arrays_path = out / meta.arrays
    try:
        a = read_npz(arrays_path, "the arrays swarm model validate --out wrote")
        truth = Trajectory(*(a[f"truth_{k}"] for k in POSE_KEYS))
        trajectories = {m: Trajectory(*(a[f"{m}_{k}"] for k in POSE_KEYS)) for m in meta.models}
    except (ValueError, KeyError) as exc:
        found = f"{type(exc).__name__}: {exc}"
        raise InputError(
            arrays_path, "(contents)", found, "the arrays swarm model validate --out wrote"
        ) from None
    return Validation(
        run=meta.run,
        distance_m=meta.distance_m,
        truth=truth,
        trajectories=trajectories,
        scores={m: by_model[m] for m in meta.models if m in by_model},
        model=meta.model,
        terrain=meta.terrain,
        robot=meta.robot,
        target_pct=meta.target_rmse_pct,
    )


def _meets(s: Score, target_pct: float) -> bool:
    return bool(np.isfinite(s.path_rmse_pct) and s.path_rmse_pct < target_pct)


def validation_data(v: Validation, date: str | None = None) -> dict:
    """The validation report's numbers (report.json)."""
    # the scores as validation.json keeps them (6 decimals): the same report from memory or from disk
    scores = {m: Score(**v.scores[m].as_dict()) for m in v.scores}
    s = scores[v.model]
    met = _meets(s, v.target_pct)
    text = (
        f"{'MEETS' if met else 'MISSES'} the accuracy target: {v.model} path RMSE {s.path_rmse_m:.3f} m = "
        f"{s.path_rmse_pct:.2f}% of the {s.distance_m:.2f} m travelled (target < {v.target_pct:g}%)"
    )
    if not math.isfinite(s.path_rmse_pct):  # a pivot in place: no distance to share the error by
        text = (
            f"NO VERDICT on the accuracy target (a share of the distance travelled): the run travelled "
            f"{s.distance_m:.2f} m; {v.model} path RMSE {s.path_rmse_m:.3f} m, heading RMSE "
            f"{s.heading_rmse_deg:.2f} deg"
        )
    robot = Path(v.robot).stem if v.robot else None
    return jsonable(
        {
            "header": header("validation", None, None, None, date, run=v.run, terrain=v.terrain, robot=robot),
            "verdict": verdict(
                text, "met" if met else "not met", model=v.model, target_rmse_pct=v.target_pct
            ),
            "run": {"name": v.run, "distance_m": s.distance_m, "duration_s": s.duration_s},
            "scores": [{**x.as_dict(), "meets_target": _meets(x, v.target_pct)} for x in scores.values()],
        }
    )


def _fmt(x: float | None, spec: str) -> str:
    return "-" if x is None else format(x, spec)


def score_table(data: dict) -> list[list[str]]:
    target = data["verdict"]["target_rmse_pct"]
    rows = [
        [
            "model",
            "path RMSE (m)",
            "RMSE % of distance",
            "final error (m)",
            "max error (m)",
            "heading RMSE (deg)",
            "final heading error (deg)",
            f"under {target:g}%",
        ]
    ]
    for s in data["scores"]:
        rows.append(
            [
                s["model"],
                _fmt(s["path_rmse_m"], ".3f"),
                _fmt(s["path_rmse_pct"], ".2f"),
                _fmt(s["final_error_m"], ".3f"),
                _fmt(s["max_error_m"], ".3f"),
                _fmt(s["heading_rmse_deg"], ".2f"),
                _fmt(s["final_heading_error_deg"], ".2f"),
                "yes" if s["meets_target"] else "NO",
            ]
        )
    return rows


def run_table(data: dict) -> list[list[str]]:
    r = data["run"]
    return [
        ["run", r["name"]],
        ["terrain mode", str(data["header"]["terrain"])],
        ["distance travelled (reference)", f"{r['distance_m']:.3f} m"],
        ["duration", f"{r['duration_s']:.1f} s"],
    ]


def validation_report(v: Validation, *, date: str | None = None) -> Report:
    """The report of a validation: verdict against the target, run and score tables, the overlay."""
    data = validation_data(v, date)
    models = ", ".join(v.scores)
    blocks = [
        Table("Run", run_table(data), header=False),
        Table("Scores", score_table(data), note="Errors at the reference's own sample times."),
        Figure(
            "Predicted against reference",
            lambda: validation_png(v.run, v.distance_m, v.truth, v.trajectories, v.scores),
            alt=f"Thesis-style overlay for {v.run}: the reference path from motion capture and the path "
            f"predicted by {models}; X, Y and heading against time",
            caption="Left: the path (diamond: start; dots: where each model ends). Right: X, Y and heading "
            "against time; black: the reference.",
        ),
        Figure(
            "Prediction error over the run",
            lambda: errors_png(v.truth, v.trajectories, v.distance_m),
            alt=f"Position and heading error of {models} against the reference over time, with the 3% line",
        ),
    ]
    return Report(
        "validation",
        f"Model validation: {v.run} on {v.terrain} ({models})",
        data,
        blocks,
        files_note="Data: validation.json (scores), validation.npz (reference and predicted poses).",
    )
