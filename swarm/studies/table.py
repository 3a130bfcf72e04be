"""The results table of a study: one row per run, its columns and their Arrow types.

Columns, in order:

- ``point`` (int32), ``run`` (int32): the parameter point and the run's index within it; the
  pair identifies a run.
- ``seed`` (uint64): the run's simulator seed, from ``SeedSequence(study seed, spawn_key=(point,
  run))``.
- one column per swept key, named by its key path (``swarm.count``, ``hazards.surf.wave_height_m``),
  as the sweep's values are (`param_type`): int64 (uint64 for seeds past its range), float64,
  bool, or text, where a list or mapping is its JSON; a null value is the column's null.
- ``robots`` (int32): robots launched.
- ``success`` (bool): every success criterion met.
- ``value_<criterion>`` (float64) and ``met_<criterion>`` (bool) for each criterion the mission
  has (landing, detection, relay, surveillance, beacon, recovered; null/False where absent).
- ``lost`` (int32) and ``lost_<cause>`` (int32) for each cause of `swarm.sim.hazards.CAUSES`.
- ``planned_lost`` (float64): the robots the point's plan expects to lose (its budget's
  ``expected_lost``, the same in each of the point's rows), to set beside ``lost``; null with the
  hazards off, and in tables written before it existed.
- ``planned_lost_<cause>`` (float64) for each cause of `swarm.sim.hazards.CAUSES`: the robots the
  point's plan expects to lose to that cause (`MissionPlan.expected_lost_by_cause`, 0 for a cause
  it does not expect), to set beside ``lost_<cause>``; null as ``planned_lost`` is, and in tables
  written before they existed.
- ``planned_detection`` (float64): the share of the mines the point's plan expects found after its
  losses (`MissionPlan.expected_detection`), to set beside ``value_detection``; null without a
  search, and in tables written before it existed.
- ``planned_success`` (float64): the point's plan's chance that a run meets every criterion
  (`swarm.mission.plan.success_chance`), to set beside ``success``; null where the plan gives no
  chance for some criterion a run is judged by, and in tables written before it existed.
- ``takeovers`` (int32): lost robots' stations a spare took over (the policy's ``takeover`` events
  of a landing, relay, surveillance or beacon robot's point); null in tables written before it
  existed. ``planned_takeovers`` (float64): the point's plan's (`MissionPlan.expected_takeovers`),
  to set beside it; null with the hazards off, and in tables written before it existed.
- ``mines``, ``mines_detected``, ``mines_cleared`` (int32): mines laid, found by a sensor, and set
  off by the synchronized clearance (each by the robot marking it); null in tables written before
  they existed.
- ``expended``, ``recovered`` (int32): robots the clearance expended (their mines' markers), and
  robots picked up at sea; null in tables written before they existed.
- ``losses`` (list of struct cause: string, phase: string, t_s: float64, x_m: float64,
  y_m: float64): every loss, for loss maps and losses by phase.
- ``completed_s`` (float64): mission time when every criterion was first met; null if never.
- ``duration_s`` (float64): mission time simulated.
- ``runtime_s`` (float64): wall-clock seconds the run took, its share of its batch's when it ran in
  a batch (the only column that differs between two runs of the same study).
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import pyarrow as pa

from swarm.sim.hazards import CAUSES

CRITERIA = ("landing", "detection", "relay", "surveillance", "beacon", "recovered")
LOSS = pa.struct(
    [
        ("cause", pa.string()),
        ("phase", pa.string()),
        ("t_s", pa.float64()),
        ("x_m", pa.float64()),
        ("y_m", pa.float64()),
    ]
)
#: Counts of a run's outcome beside its losses: its mines (as the log's summary counts them), and
#: how its robots ended besides lost (the summary's end states).
MINE_COUNTS = ("mines", "mines_detected", "mines_cleared")
END_COUNTS = ("expended", "recovered")
OUTCOME_COUNTS = MINE_COUNTS + END_COUNTS
#: Columns that may differ between two runs of the same study (wall-clock time).
VOLATILE = ("runtime_s",)


def loss_row(loss: dict) -> dict:
    """A loss of the log (`swarm.sim.run.LOSS_FIELDS`) as the table's `losses` holds it: cause,
    phase, time and place (the robot's name is not kept)."""
    return {
        "cause": loss["cause"],
        "phase": loss["phase"],
        "t_s": float(loss["t_s"]),
        "x_m": float(loss["x_m"]),
        "y_m": float(loss["y_m"]),
    }


def schema(sweep_types: Sequence[tuple[str, pa.DataType]]) -> pa.Schema:
    """The table's schema for a study sweeping these (key, type) pairs."""
    fields = [pa.field("point", pa.int32()), pa.field("run", pa.int32()), pa.field("seed", pa.uint64())]
    fields += [pa.field(param_column(key), kind) for key, kind in sweep_types]
    fields += [pa.field("robots", pa.int32()), pa.field("success", pa.bool_())]
    for c in CRITERIA:
        fields += [pa.field(f"value_{c}", pa.float64()), pa.field(f"met_{c}", pa.bool_())]
    fields += [pa.field("lost", pa.int32())]
    fields += [pa.field(f"lost_{c}", pa.int32()) for c in CAUSES]
    fields += [pa.field("planned_lost", pa.float64())]
    fields += [pa.field(f"planned_lost_{c}", pa.float64()) for c in CAUSES]
    fields += [pa.field("planned_detection", pa.float64())]
    fields += [pa.field("planned_success", pa.float64())]
    fields += [pa.field("takeovers", pa.int32()), pa.field("planned_takeovers", pa.float64())]
    fields += [pa.field(c, pa.int32()) for c in OUTCOME_COUNTS]
    fields += [
        pa.field("losses", pa.list_(LOSS)),
        pa.field("completed_s", pa.float64()),
        pa.field("duration_s", pa.float64()),
        pa.field("runtime_s", pa.float64()),
    ]
    return pa.schema(fields)


#: The table's own columns, whatever the study sweeps.
OWN_COLUMNS = frozenset(schema([]).names)


def param_column(key: str) -> str:
    """The column of a swept (or held) mission key: the key itself, or "mission.KEY" for a key
    named like one of the table's own columns (the mission's `seed` against each run's)."""
    return f"mission.{key}" if key in OWN_COLUMNS else key


def param_type(values: Sequence[object]) -> pa.DataType:
    """The column type of a swept key's values (a null among them is the column's null): integers
    as int64, or uint64 when one is past int64 and none is negative (a seed from 2**63 on);
    numbers as float64; booleans; anything else, or a mix, as text (`param_cell`)."""
    given = [v for v in values if v is not None]
    if given and all(isinstance(v, int) and not isinstance(v, bool) for v in given):
        if all(-(2**63) <= v < 2**63 for v in given):
            return pa.int64()
        if all(0 <= v < 2**64 for v in given):
            return pa.uint64()
    elif given and all(isinstance(v, int | float) and not isinstance(v, bool) for v in given):
        return pa.float64()
    elif given and all(isinstance(v, bool) for v in given):
        return pa.bool_()
    return pa.string()


def param_cell(value: object, kind: pa.DataType) -> object:
    """A swept value as its column of type `kind` holds it: itself, or in a text column, text as
    is and any other value (a number among text, a list of launch points) as its JSON."""
    if value is None or not pa.types.is_string(kind) or isinstance(value, str):
        return value
    return json.dumps(value, default=str)
