"""`--sweep KEY=VALUES`: which mission keys a study varies and over what values; the study is
their product.

VALUES is a list, ``0.5,1,2``, or an inclusive range ``start:stop:step`` (``10:60:10`` is 10, 20,
..., 60); each value is read as YAML (``20`` an integer, ``1.5`` a number, ``true``, text), then
as the schema reads its key (`check_points`: an integer key's ``10.0`` is 10, ``10.5`` an error).
KEY is a dotted key path of the mission schema, as `--set` and `parallel_env(overrides=...)` take
(`swarm.mission.load.apply_overrides`). Every point is checked against the schema before a single
run starts, so a bad key or value is one line naming it; a point whose values do not work
together is reported as infeasible and the others run (`feasibility`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from swarm.errors import Infeasible, InputError
from swarm.files import parse_yaml

#: A range may not expand to more values than this (a typo like 1:1000000:1 is refused).
MAX_VALUES = 1000
#: A study may not hold more runs than this, all points together: a million runs of a few seconds
#: are months of one core, and `--runs 100000000` spent minutes building its list of runs.
MAX_STUDY_RUNS = 1_000_000


def check_study_size(option: str, runs: int, sweeps: Sequence[Sweep]) -> None:
    """Refuse more than `MAX_STUDY_RUNS` runs in all (`runs` at each point of `sweeps`' product)."""
    points = math.prod(len(s.values) for s in sweeps)
    if runs * points > MAX_STUDY_RUNS:
        each = f"{points:,} point{'s' if points != 1 else ''} x {runs:,}"
        raise InputError("command line", option, runs, f"at most {MAX_STUDY_RUNS:,} runs in all ({each})")


@dataclass(frozen=True)
class Sweep:
    """One swept key and its values, in order."""

    key: str
    values: tuple[object, ...]

    @property
    def is_integer(self) -> bool:
        return all(isinstance(v, int) and not isinstance(v, bool) for v in self.values)

    @property
    def is_number(self) -> bool:
        return all(isinstance(v, int | float) and not isinstance(v, bool) for v in self.values)


def _number(text: str, source: str) -> int | float:
    value = parse_yaml(text, source)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError("command line", source, text, "a number (start:stop:step)")
    return value


def _range(key: str, text: str) -> tuple[object, ...]:
    parts = text.split(":")
    if len(parts) != 3:
        raise InputError("command line", f"--sweep {key}", text, "start:stop:step, e.g. 10:60:10")
    start, stop, step = (_number(p.strip(), f"--sweep {key}") for p in parts)
    if step <= 0 or stop < start:
        raise InputError("command line", f"--sweep {key}", text, "start <= stop and a step > 0")
    count = math.floor((stop - start) / step + 1e-9) + 1
    if count > MAX_VALUES:
        raise InputError("command line", f"--sweep {key}", text, f"at most {MAX_VALUES} values")
    if all(isinstance(v, int) for v in (start, stop, step)):
        return tuple(int(start + i * step) for i in range(count))
    return tuple(round(start + i * step, 12) for i in range(count))


def parse_sweep(text: str) -> Sweep:
    """One `--sweep KEY=VALUES` argument."""
    key, sep, values = text.partition("=")
    key = key.strip()
    if not sep or not key or not values.strip():
        raise InputError(
            "command line",
            "--sweep",
            text,
            "KEY=VALUES, e.g. swarm.count=10:60:10 or hazards.surf.wave_height_m=0.5,1,2",
        )
    if ":" in values and "," not in values:
        items = _range(key, values.strip())
    else:
        items = tuple(parse_yaml(v.strip(), f"--sweep {key}") for v in values.split(",") if v.strip())
    if not items:
        raise InputError("command line", f"--sweep {key}", values, "at least one value")
    if len(set(map(repr, items))) != len(items):
        raise InputError("command line", f"--sweep {key}", values, "values without repeats")
    return Sweep(key, items)


def parse_sweeps(texts: Sequence[str]) -> list[Sweep]:
    sweeps = [parse_sweep(t) for t in texts]
    keys = [s.key for s in sweeps]
    for k in keys:
        if keys.count(k) > 1:
            raise InputError("command line", f"--sweep {k}", "the key twice", "each key swept once")
    return sweeps


def points(sweeps: Sequence[Sweep]) -> list[dict[str, object]]:
    """The product of the sweeps, the last key varying fastest: one overrides dict per point (a
    study without sweeps has one point, the mission as written)."""
    return [
        dict(zip([s.key for s in sweeps], combo, strict=True))
        for combo in itertools.product(*(s.values for s in sweeps))
    ]


def check_points(mission_path: str | Path, sweeps: Sequence[Sweep], at_once: int = 1) -> list[Sweep]:
    """The sweeps of `feasibility`, as the schema reads their values."""
    return feasibility(mission_path, sweeps, at_once)[0]


def feasibility(
    mission_path: str | Path, sweeps: Sequence[Sweep], at_once: int = 1
) -> tuple[list[Sweep], dict[int, str]]:
    """Load the mission at every point (keys exist, values are valid), so a bad sweep fails before
    any run: `--sweep swarm.count: found -5, expected ...` (one line, naming the key); and refuse a
    point whose `at_once` runs in parallel would not fit in memory (`swarm.sim.memory`).

    A point whose values are each valid but do not work together (`Infeasible`: recon at 2 robots
    for stations that hold 5) is no mistake in a sweep but one of its answers: it is returned,
    by point index, with the loader's line (without the file's name), and the other points run.
    A sweep with no feasible point is the first point's error (`swarm study missions/recon.yaml
    --sweep swarm.count=2,8` stopped the whole study on 2).

    Returns the sweeps with their values as the schema reads them, as it reads one `--set`: an
    integer key swept over 8,10.0 is swept over 8 and 10 (the float went into the table, the
    summary and the answer as 10.0)."""
    from swarm.mission.load import load_mission, value_at
    from swarm.sim.memory import check_fits

    read: dict[tuple[str, str], object] = {}
    infeasible: dict[int, str] = {}
    first: Infeasible | None = None
    for p, point in enumerate(points(sweeps)):
        try:
            mission = load_mission(mission_path, point, overrides_source="--sweep")
        except Infeasible as exc:
            first = first or exc
            infeasible[p] = f"{exc.where}: found {exc.found!r}, expected {exc.expected}"
            continue
        check_fits(mission, at_once=at_once)
        for key, value in point.items():
            if (key, repr(value)) not in read:
                read[key, repr(value)] = _as_read(value, value_at(mission, key))
    if first is not None and len(infeasible) == len(points(sweeps)):
        raise first
    # a value only infeasible points take stays as written
    typed = [Sweep(s.key, tuple(read.get((s.key, repr(v)), v) for v in s.values)) for s in sweeps]
    for given, sweep in zip(sweeps, typed, strict=True):
        if len(set(map(repr, sweep.values))) != len(sweep.values):
            found = ",".join(map(str, given.values))
            raise InputError("command line", f"--sweep {sweep.key}", found, "values without repeats")
    return typed, infeasible


def _as_read(given: object, read: object) -> object:
    """A swept value as the schema read it where only its type changed: an integer-valued float
    an integer key took as an int. Anything else stays as written (a path or a list is its own
    name in the table and in study.json, whatever the schema makes of it)."""
    if isinstance(given, float) and isinstance(read, int) and not isinstance(read, bool) and read == given:
        return read
    return given
