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


class Infeasible(InputError):
    """Input whose values are each valid but cannot work together: a swarm too small for its
    stations, a dwell longer than the time left at its point. Still bad input to a plan (one line,
    exit 2); a study sweeping into it records the point as infeasible and runs the others."""


class FolderBusy(SwarmError):
    """Another process holds the lock on an output folder (`swarm.files.folder_lock`)."""

    def __init__(self, folder: str | Path, holder: str) -> None:
        self.folder = str(folder)
        self.holder = holder
        super().__init__(
            f"{self.folder}: in use by {holder}; wait for it to finish, or write to another folder"
        )


class OutputError(SwarmError, OSError):
    """An output could not be written (a full disk, a folder gone read-only); nothing partial is
    left. Still an `OSError`, for callers of the library that catch one."""

    def __init__(self, path: str | Path, reason: str, errno: int | None = None) -> None:
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: could not write it ({reason}); nothing partial was left")
        self.errno, self.strerror, self.filename = errno, reason, self.path

    def __str__(self) -> str:  # not OSError's "[Errno N] ..." form
        return str(self.args[0])
