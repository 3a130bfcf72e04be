"""One error family for the whole project, so the CLI can turn bad input into one line and exit 2."""

from __future__ import annotations

from pathlib import Path


class SwarmError(Exception):
    """Base class: anything the user can fix by changing their input or arguments."""


class InputError(SwarmError):
    """Bad input: says which file, where in it, what was found and what was expected."""

    def __init__(
        self,
        source: str | Path,
        where: str,
        found: object,
        expected: str,
    ) -> None:
        self.source = str(source)
        self.where = where
        self.found = found
        self.expected = expected
        super().__init__(f"{self.source}: {where}: found {found!r}, expected {expected}")
