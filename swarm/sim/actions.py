"""Actions at the environments' edge (`SwarmEnv`, `SwarmVectorEnv`), checked before any is applied.

A bad action is a `SwarmError` naming the agent (or the row), what was given and what was expected,
not numpy's error from deep inside, and not a silent wrong result: a NaN wheel speed once made a
robot's state NaN for good, three scalars were read as one row for every robot, a NaN target left
observations NaN for the rest of the episode. A step with one bad action applies none of them.

- "wheels": each action is 3 numbers (left, right, jet), finite; they are clipped to [-1, 1], the
  action space's Box, as Gymnasium's `ClipAction` would.
- "command": each action is {"command": a whole number in 0..5 (`COMMANDS`), "target": (x, y)
  finite and on the map}; in an array row, (command, x, y), the command any number in -0.5..5.5
  taken to the nearest whole one (each command owns the unit interval around it, 2.5 is 3), so
  every sample of the vector env's Box is an action and each command is drawn alike.
Robots that have left the mission may be given actions (they are ignored); an id that is no robot's
is an error. A robot still in the mission without an action stands still (wheels) or keeps its
last command.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence

import numpy as np

from swarm.errors import SwarmError
from swarm.sim.runview import COMMANDS

WHEELS_EXPECTED = "3 finite numbers (left wheel, right wheel, jet), each in [-1, 1]"


def agent_rows(names: Sequence[object], agent_index: Mapping[str, int]) -> np.ndarray:
    """The robot index of each agent id in `names`; an unknown id is an error."""
    try:
        return np.fromiter((agent_index[a] for a in names), np.intp, len(names))  # type: ignore[index]
    except (KeyError, TypeError):
        bad = next(a for a in names if not isinstance(a, str) or a not in agent_index)
        raise SwarmError(
            f"sim: an action for {bad!r}, expected agent ids robot_0 .. robot_{len(agent_index) - 1}"
        ) from None


def wheel_rows(
    actions: Mapping[object, object], agent_index: Mapping[str, int]
) -> tuple[np.ndarray, np.ndarray]:
    """(robot indices, (k, 3) float64 rows clipped to [-1, 1]) of a dict of wheel actions."""
    names = list(actions)
    idx = agent_rows(names, agent_index)
    try:
        raw = np.asarray(list(actions.values())) if names else np.zeros((0, 3))
    except ValueError:  # rows of different lengths
        raw = np.zeros(0, object)
    if raw.dtype.kind not in "iuf" or raw.shape != (len(names), 3):
        for name, value in actions.items():  # the first bad one, named
            one = np.asarray(value)
            if one.dtype.kind not in "iuf" or one.shape != (3,):
                raise SwarmError(f"sim: action of {name}: found {value!r}, expected {WHEELS_EXPECTED}")
    rows = raw.astype(np.float64)
    bad = ~np.isfinite(rows).all(axis=1)
    if bad.any():
        name = names[int(np.argmax(bad))]
        raise SwarmError(f"sim: action of {name}: found {actions[name]!r}, expected {WHEELS_EXPECTED}")
    return idx, np.clip(rows, -1.0, 1.0)


def wheel_array(actions: np.ndarray, live: np.ndarray) -> np.ndarray:
    """`actions` (..., 3) as float64 clipped to [-1, 1], the rows `live` checked finite (the
    others are ignored, NaN or not)."""
    if actions.dtype.kind not in "iuf":
        raise SwarmError(f"sim: actions of dtype {actions.dtype}, expected numbers")
    rows = actions.astype(np.float64)
    bad = live & ~np.isfinite(rows).all(axis=-1)
    if bad.any():
        at = tuple(int(i) for i in np.argwhere(bad)[0])
        raise SwarmError(f"sim: actions{list(at)}: found {rows[at].tolist()}, expected {WHEELS_EXPECTED}")
    return np.clip(rows, -1.0, 1.0)


class Commands:
    """Checks command-mode actions against the map (`bounds_m`: x0, y0, x1, y1)."""

    def __init__(self, bounds_m: Sequence[float]) -> None:
        self.x0, self.y0, self.x1, self.y1 = (float(v) for v in bounds_m)
        self.expected = (
            f'{{"command": a whole number 0..{len(COMMANDS) - 1} ({", ".join(COMMANDS)}), '
            f'"target": (x, y) on the map, x {self.x0:g}..{self.x1:g}, y {self.y0:g}..{self.y1:g}}}'
        )

    def from_dict(
        self, actions: Mapping[object, object], agent_index: Mapping[str, int]
    ) -> list[tuple[int, int, np.ndarray]]:
        """(robot, command, target) of each action of a dict, all checked first."""
        idx = agent_rows(list(actions), agent_index)
        out = []
        for i, (name, value) in zip(idx.tolist(), actions.items(), strict=True):
            if not isinstance(value, Mapping) or set(value) != {"command", "target"}:
                raise SwarmError(f"sim: action of {name}: found {value!r}, expected {self.expected}")
            out.append((i, *self._checked(name, value["command"], value["target"])))
        return out

    def from_rows(
        self, rows: np.ndarray, idx: np.ndarray, where: str = ""
    ) -> list[tuple[int, int, np.ndarray]]:
        """(robot, command, target) of rows `idx` of (n, 3) (command, x, y) rows, all checked first."""
        picked = zip(idx.tolist(), rows[idx], strict=True)
        return [(i, *self._checked(f"{where}row {i}", self.nearest(row[0]), row[1:])) for i, row in picked]

    @staticmethod
    def nearest(value: object) -> object:
        """An array row's command: the nearest whole command to a number in -0.5..5.5 (the
        vector env's Box), anything else as given, for `_checked` to refuse."""
        top = len(COMMANDS) - 0.5
        if isinstance(value, numbers.Real) and not isinstance(value, bool) and -0.5 <= value <= top:
            return min(int(np.floor(float(value) + 0.5)), len(COMMANDS) - 1)
        return value

    def _checked(self, name: object, command: object, target: object) -> tuple[int, np.ndarray]:
        boolean = isinstance(command, bool | np.bool_)
        whole = isinstance(command, numbers.Integral) and not boolean
        if not whole and not boolean and isinstance(command, numbers.Real) and float(command).is_integer():
            whole = True  # 2.0, as a float array row holds it
        try:
            xy = np.asarray(target, dtype=np.float64)
        except (TypeError, ValueError):
            xy = np.full(2, np.nan)
        ok = (
            whole
            and 0 <= int(command) < len(COMMANDS)  # type: ignore[call-overload]
            and xy.shape == (2,)
            and bool(np.isfinite(xy).all())
            and self.x0 <= xy[0] <= self.x1
            and self.y0 <= xy[1] <= self.y1
        )
        if not ok:
            found = {"command": command, "target": target}
            raise SwarmError(f"sim: action of {name}: found {found!r}, expected {self.expected}")
        return int(command), xy  # type: ignore[call-overload]
