"""Writing outputs so nothing is ever half-written: a temporary name beside the target, then a rename."""

from __future__ import annotations

import contextlib
import os
import secrets
from collections.abc import Iterator
from pathlib import Path

import yaml

from swarm.errors import InputError


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside `path`; on success it replaces `path`, on error it vanishes.

    The temporary name keeps the target's suffix, so writers that choose a format from the file
    name (matplotlib, pyarrow) still do the right thing.
    """
    target = Path(path)
    tmp = target.with_name(f".{target.stem}.{os.getpid()}.{secrets.token_hex(4)}.tmp{target.suffix}")
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write text (UTF-8, LF newlines, fsynced) so a reader sees all of it or the old file."""
    with atomic_path(path) as tmp, open(tmp, "x", encoding="utf-8", newline="\n") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def read_text(path: str | os.PathLike[str], what: str) -> str:
    """A text file's contents; a missing, unreadable or non-UTF-8 file is an `InputError`."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(path, "(file)", exc.strerror, f"a readable {what}") from None
    except UnicodeDecodeError:
        raise InputError(path, "(file)", "bytes that are not UTF-8 text", f"a readable {what}") from None


def parse_yaml(text: str, source: str | os.PathLike[str], loader: type = yaml.SafeLoader) -> object:
    """YAML text to Python objects; a syntax error is an `InputError` naming the line."""
    try:
        return yaml.load(text, Loader=loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else "(file)"
        raise InputError(
            source, where, getattr(exc, "problem", None) or "invalid YAML", "valid YAML"
        ) from None


def read_yaml(path: str | os.PathLike[str], what: str) -> object:
    """Read and parse a YAML file with one-line errors for the user (what: 'robot YAML file')."""
    return parse_yaml(read_text(path, what), path)
