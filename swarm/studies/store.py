"""Where a study keeps its results: Parquet written in chunks as runs finish, so a study killed at
any moment (Ctrl-C, kill -9, a lost node) keeps every finished run and resumes with the rest.

```
OUT/study.json              what the study is (mission, runs, sweeps, seed): a resume must match it
OUT/parts/part-NNNNNN.parquet   finished runs, a chunk each, each file written whole then renamed
OUT/results.parquet         all runs sorted by (point, run), written when the study completes
```

A chunk becomes visible only by an atomic rename, so a kill leaves either a whole part or none (a
leftover temporary file is ignored and removed). Runs found in the parts are never run again; the
final table is the same whatever the chunking, the worker count, or how often the study was
interrupted (up to the wall-clock `runtime_s` of each run).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from pydantic import Field

from swarm.errors import InputError
from swarm.files import atomic_path, read_json, write_text_atomic
from swarm.inputs import InputModel, validate

PARTS = "parts"
RESULTS = "results.parquet"
SPEC = "study.json"


class StudyFile(InputModel):
    """study.json: what identifies a study (`StudySpec.as_dict`); a resume must match it."""

    mission: str = Field(min_length=1, description="The mission file, resolved.")
    runs: int = Field(ge=1)
    sweeps: dict[str, list[Any]]
    seed: int = Field(ge=0)


def read_study_file(path: str | Path) -> StudyFile:
    """A study.json, checked; a damaged one is an `InputError` naming the file and key."""
    return validate(StudyFile, read_json(path, "study.json"), path)


class ResultStore:
    """The results of one study in folder `out`."""

    def __init__(self, out: str | Path, schema: pa.Schema) -> None:
        self.out = Path(out)
        self.schema = schema
        self.parts = self.out / PARTS

    def open(self, spec: dict) -> None:
        """Create the folder, or check that an existing one holds the same study."""
        path = self.out / SPEC
        if path.exists():
            old = read_study_file(path)
            if old.model_dump() != spec:
                raise InputError(
                    str(path),
                    "(study)",
                    "a different study",
                    "the same mission, runs, sweeps and seed to resume it, or a new --out folder",
                )
        self.parts.mkdir(parents=True, exist_ok=True)
        for stale in self.parts.glob(".*"):  # a temporary part a kill left behind
            stale.unlink(missing_ok=True)
        if not path.exists():
            write_text_atomic(path, json.dumps(spec, indent=1, sort_keys=True) + "\n")

    def _part_files(self) -> list[Path]:
        return sorted(self.parts.glob("part-*.parquet")) if self.parts.exists() else []

    def done(self) -> set[tuple[int, int]]:
        """(point, run) of every run already stored."""
        keys: set[tuple[int, int]] = set()
        for f in self._part_files():
            t = self._read(f, columns=["point", "run"])
            keys.update(zip(t.column("point").to_pylist(), t.column("run").to_pylist(), strict=True))
        return keys

    @staticmethod
    def _read(path: Path, **kwargs) -> pa.Table:
        """One part; an unreadable one is an `InputError` naming it (it was not written here)."""
        try:
            return pq.read_table(path, **kwargs)
        except (OSError, pa.ArrowException) as exc:
            raise InputError(
                path,
                "(file)",
                str(exc).splitlines()[0] if str(exc) else "an unreadable file",
                "a Parquet part this study wrote (move it away to run its runs again)",
            ) from None

    def append(self, rows: list[dict]) -> Path | None:
        """Write finished runs as one new part, atomically."""
        if not rows:
            return None
        index = len(self._part_files())
        path = self.parts / f"part-{index:06d}.parquet"
        while path.exists():
            index += 1
            path = self.parts / f"part-{index:06d}.parquet"
        table = pa.Table.from_pylist(rows, schema=self.schema)
        with atomic_path(path) as tmp:
            pq.write_table(table, tmp)
        return path

    def table(self) -> pa.Table:
        """Every stored run once, sorted by (point, run).

        A (point, run) stored twice (two processes that wrote one folder before it was locked, or
        a part copied in by hand) counts once: the first part that has it wins. The run's seed is
        in its key, so both copies hold the same outcome; only `runtime_s` may differ."""
        files = self._part_files()
        if not files:
            return self.schema.empty_table()
        table = pa.concat_tables([self._read(f, schema=self.schema) for f in files])
        point = table.column("point").to_numpy()
        run = table.column("run").to_numpy()
        order = np.lexsort((np.arange(len(table)), run, point))  # stable: earlier parts first
        p, r = point[order], run[order]
        first = np.ones(len(order), dtype=bool)
        first[1:] = (p[1:] != p[:-1]) | (r[1:] != r[:-1])
        return table.take(order[first])

    def finish(self) -> pa.Table:
        """Write results.parquet (all runs, sorted) and return the table."""
        table = self.table()
        with atomic_path(self.out / RESULTS) as tmp:
            pq.write_table(table, tmp)
        return table
