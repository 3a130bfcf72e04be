"""The result store: a run stored twice counts once; an unreadable part is one line naming it."""

from __future__ import annotations

import pytest

from swarm.errors import InputError
from swarm.studies.store import PARTS, ResultStore
from swarm.studies.table import schema


def _rows(keys: list[tuple[int, int]], runtime_s: float) -> list[dict]:
    return [
        {"point": p, "run": r, "seed": 1000 * p + r, "success": (p + r) % 2 == 0, "runtime_s": runtime_s}
        for p, r in keys
    ]


def test_a_run_stored_twice_counts_once_and_the_first_copy_wins(tmp_path) -> None:
    """What two studies writing one folder at once left behind (issue 15): runs 1 and 2 twice."""
    store = ResultStore(tmp_path, schema([]))
    store.open({"mission": "m", "runs": 3, "sweeps": {}, "seed": 0})
    store.append(_rows([(0, 0), (0, 1), (1, 2)], runtime_s=1.0))
    store.append(_rows([(1, 0), (0, 1), (1, 2), (0, 2)], runtime_s=2.0))
    table = store.finish()
    keys = list(zip(table.column("point").to_pylist(), table.column("run").to_pylist(), strict=True))
    assert keys == [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2)]
    assert table.column("seed").to_pylist() == [0, 1, 2, 1000, 1002]
    assert table.column("runtime_s").to_pylist() == [1.0, 1.0, 2.0, 2.0, 1.0]
    assert store.done() == set(keys)


def test_an_unreadable_part_is_one_line_naming_it(tmp_path) -> None:
    store = ResultStore(tmp_path, schema([]))
    store.open({"seed": 0})
    part = store.append(_rows([(0, 0), (0, 1)], runtime_s=1.0))
    part.write_bytes(part.read_bytes()[:100])  # truncated
    with pytest.raises(InputError) as caught:
        store.done()
    assert str(caught.value).startswith(f"{tmp_path / PARTS / part.name}: (file): found ")
    assert "\n" not in str(caught.value)
