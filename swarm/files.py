"""Writing outputs so nothing is ever half-written (a temporary name beside the target, then a
rename) and no two processes write one folder (`folder_lock`); reading inputs with one-line errors."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import re
import secrets
import sys
import time
import tokenize
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path

import yaml

from swarm.errors import FolderBusy, InputError, OutputError, SwarmError

#: The lock file `folder_lock` keeps inside an output folder while a process writes it.
LOCK_FILE = ".swarm.lock"
#: How long a refused process waits for the holder's line in the lock file (`_holder`).
HOLDER_WAIT_S = 1.0
_held: dict[Path, int] = {}  # folders this process holds, and how many nested holds


def _holder(fd: int, wait_s: float = HOLDER_WAIT_S) -> str:
    """What the lock file says about the process holding it ("pid 1234 (swarm study ...)"). The
    holder writes its line just after it takes the lock, so an empty file is read again for up to
    `wait_s` before the holder is called "another process"."""
    deadline = time.monotonic() + wait_s
    while True:
        with contextlib.suppress(OSError):
            text = os.pread(fd, 4096, 0).decode("utf-8", "replace").strip()
            pid, _, command = text.partition(" ")
            if pid.isdigit():
                return f"pid {pid} ({command})" if command else f"pid {pid}"
        if time.monotonic() >= deadline:
            return "another process"
        time.sleep(0.01)


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike[str], command: str | None = None) -> Iterator[Path]:
    """Hold an exclusive lock on output folder `folder` (created if missing) while writing it.

    The lock is `fcntl.flock` on `folder/.swarm.lock`, which records the holder's pid and command;
    the kernel drops it when the process ends, however it ends, so a killed run never leaves the
    folder locked. A second process gets `FolderBusy` naming the folder and the holder, having
    changed nothing. Nested holds in one process are fine (the CLI and the library both lock). A
    folder this call created and left empty is removed on release.
    """
    path = Path(folder)
    key = path.resolve()
    if key in _held:
        _held[key] += 1
        try:
            yield path
        finally:
            _held[key] -= 1
        return
    created = not path.exists()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(path, "(folder)", exc.strerror, "a folder this user may create and write") from None
    lock = path / LOCK_FILE
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise InputError(path, "(folder)", exc.strerror, "a folder this user may write") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = _holder(fd)
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN):
                raise FolderBusy(path, holder) from None
            raise SwarmError(f"{path}: cannot lock the folder ({exc.strerror})") from None
        try:  # the holder before us may have removed the file between our open and our lock
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        text = f"{os.getpid()} {command or ' '.join([Path(sys.argv[0]).name, *sys.argv[1:]])}\n"
        os.ftruncate(fd, 0)
        os.pwrite(fd, text.encode("utf-8"), 0)
        _held[key] = 1
        yield path
    finally:
        _held.pop(key, None)
        with contextlib.suppress(OSError):
            lock.unlink()  # while still locked: a waiter that opened it retries on the new file
        os.close(fd)
        if created:
            with contextlib.suppress(OSError):
                path.rmdir()  # only if nothing was written in it


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside `path`; on success it replaces `path`, on error it vanishes.

    The temporary name keeps the target's suffix, so writers that choose a format from the file
    name (matplotlib, pyarrow) still do the right thing. A write that fails with an `OSError` (a
    full disk: ENOSPC, EDQUOT) is an `OutputError` naming `path`, which is left as it was.
    """
    target = Path(path)
    tmp = target.with_name(f".{target.stem}.{os.getpid()}.{secrets.token_hex(4)}.tmp{target.suffix}")
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, OSError):
            raise OutputError(target, exc.strerror or str(exc).splitlines()[0], exc.errno) from None
        raise


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write bytes (fsynced) so a reader sees all of them or the old file."""
    with atomic_path(path) as tmp, open(tmp, "xb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write text (UTF-8, LF newlines, fsynced) so a reader sees all of it or the old file."""
    write_bytes_atomic(path, text.encode("utf-8"))


def read_text(path: str | os.PathLike[str], what: str) -> str:
    """A text file's contents; a missing, unreadable or non-UTF-8 file is an `InputError`."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(path, "(file)", exc.strerror, f"a readable {what}") from None
    except UnicodeDecodeError:
        raise InputError(path, "(file)", "bytes that are not UTF-8 text", f"a readable {what}") from None


def read_npz(path: str | os.PathLike[str], expected: str) -> dict[str, object]:
    """The members of an `.npz` archive (arrays; a member that is not `.npy` comes back as bytes).
    An empty, truncated, damaged or foreign file is one `InputError` naming it, saying `expected`."""
    import numpy as np

    path = Path(path)
    try:
        size = path.stat().st_size
        whole = zipfile.is_zipfile(path)
    except OSError as exc:
        raise InputError(path, "(file)", exc.strerror, expected) from None
    if size == 0:
        raise InputError(path, "(file)", "an empty file", expected)
    if not whole:  # a truncated archive has lost its central directory, at the end
        raise InputError(path, "(file)", f"{size} bytes that are not a whole zip archive", expected)
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:  # numpy leaks a file it opens
            return {k: npz[k] for k in npz.files}
    except (
        OSError,
        ValueError,
        EOFError,
        KeyError,
        zipfile.BadZipFile,
        zlib.error,
        NotImplementedError,  # a header naming a compression method zipfile does not have
        RuntimeError,  # a header flagging the member as encrypted
        SyntaxError,  # an .npy header numpy cannot parse (numpy tokenizes it as Python)
        tokenize.TokenError,
    ) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(path, "(file)", f"a damaged archive ({first[:100]})", expected) from None
    except MemoryError:
        raise InputError(path, "(file)", "arrays larger than this machine's memory", expected) from None


class _DuplicateKey(Exception):
    def __init__(self, key: object, line: int) -> None:
        super().__init__(key)
        self.key, self.line = key, line


class StrictLoader(yaml.SafeLoader):
    """Safe YAML with duplicate keys refused and YAML 1.2's core schema for plain scalars
    (`_CORE_SCHEMA`): `2.4e9` is a number (YAML 1.1, PyYAML's default, reads it as a string),
    `yes`, `no`, `on`, `off`, `1_000` and `12:30` are text, not true, false, 1000 and 750."""

    def construct_mapping(self, node, deep=False):  # type: ignore[override]
        self.flatten_mapping(node)
        seen: set[object] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
            except TypeError:  # unhashable keys: let the base class complain
                break
            if duplicate:
                raise _DuplicateKey(key, key_node.start_mark.line + 1)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


#: YAML 1.2's core schema (spec 1.2.2, sec. 10.3.2): the plain scalars that are not strings.
_CORE_SCHEMA = (
    ("tag:yaml.org,2002:bool", r"^(?:true|True|TRUE|false|False|FALSE)$", "tTfF"),
    ("tag:yaml.org,2002:int", r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$", "-+0123456789"),
    (
        "tag:yaml.org,2002:float",
        r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$",
        "-+0123456789.",
    ),
    ("tag:yaml.org,2002:null", r"^(?:~|null|Null|NULL|)$", ["~", "n", "N", ""]),
)
#: YAML 1.1 resolvers dropped: its timestamps (`2026-11-26` is text in 1.2) and `=`.
_NOT_CORE = {t for t, _, _ in _CORE_SCHEMA} | {"tag:yaml.org,2002:timestamp", "tag:yaml.org,2002:value"}
StrictLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in _NOT_CORE]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
for _tag, _pattern, _first in _CORE_SCHEMA:
    StrictLoader.add_implicit_resolver(_tag, re.compile(_pattern), list(_first))


def _core_int(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    """A YAML 1.2 integer: decimal (`017` is 17, where YAML 1.1 reads octal 15), 0o octal, 0x hex."""
    text = str(loader.construct_scalar(node))
    return int(text, 0) if text[:2] in ("0o", "0x") else int(text)


StrictLoader.add_constructor("tag:yaml.org,2002:int", _core_int)


def parse_yaml(text: str, source: str | os.PathLike[str], loader: type = StrictLoader) -> object:
    """YAML text to Python objects (strictly: `StrictLoader`); a syntax error or a key given twice
    in one mapping is an `InputError` naming the line."""
    try:
        return yaml.load(text, Loader=loader)
    except _DuplicateKey as exc:
        raise InputError(source, f"line {exc.line}", exc.key, "each key once in a mapping") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else "(file)"
        raise InputError(
            source, where, getattr(exc, "problem", None) or "invalid YAML", "valid YAML"
        ) from None


def read_yaml(path: str | os.PathLike[str], what: str) -> object:
    """Read and parse a YAML file with one-line errors for the user (what: 'robot YAML file')."""
    return parse_yaml(read_text(path, what), path)


def _unique_keys(pairs: list[tuple[str, object]]) -> dict:
    seen: dict[str, object] = {}
    for key, value in pairs:
        if key in seen:
            raise _DuplicateKey(key, 0)
        seen[key] = value
    return seen


def _duplicate_line(text: str) -> tuple[str, int] | None:
    """(key, 1-based line) of the first key given twice in one object of the JSON `text`; None if
    the text nests deeper than this slower scanner can follow.

    Run only once a key is known to repeat: the stdlib's pure-Python scanner, with its object
    parser wrapped, hands over where each object starts; the object is then walked pair by pair
    (it parsed, so the walk cannot fail) to find where the key comes again.
    """
    decoder = json.JSONDecoder()

    def parse_object(s_and_end, strict, scan_once, object_hook, object_pairs_hook, memo=None):
        s, start = s_and_end
        pairs, end = json.decoder.JSONObject(s_and_end, strict, scan_once, None, list, memo)
        if len({k for k, _ in pairs}) < len(pairs):
            seen: set[str] = set()
            i = start
            for _ in pairs:
                i = _JSON_SPACE.match(s, i).end()
                key_at = i
                key, i = json.decoder.scanstring(s, i + 1, strict)
                if key in seen:
                    raise _DuplicateKey(key, s.count("\n", 0, key_at) + 1)
                seen.add(key)
                i = _JSON_SPACE.match(s, i).end() + 1  # past the colon
                i = scan_once(s, _JSON_SPACE.match(s, i).end())[1]
                i = _JSON_SPACE.match(s, i).end() + 1  # past the comma
        return dict(pairs), end

    decoder.parse_object = parse_object
    decoder.scan_once = json.scanner.py_make_scanner(decoder)
    try:
        decoder.decode(text)
    except _DuplicateKey as exc:
        return exc.key, exc.line
    except RecursionError:
        return None
    return None  # not reached: called only when a key repeats


_JSON_SPACE = re.compile(r"[ \t\n\r]*")


def parse_json(text: str, source: str | os.PathLike[str], what: str, first_line: int = 1) -> object:
    """JSON text to Python objects with one-line errors: syntax, or a key given twice in one object
    (naming the key and its second appearance), each at its line, counted from `first_line` (the
    text's line in its file: a line of a JSON Lines file)."""
    try:
        return json.loads(text, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as exc:
        at = f"line {exc.lineno + first_line - 1}"
        raise InputError(source, at, exc.msg, f"valid JSON ({what})") from None
    except _DuplicateKey as exc:
        key, where = exc.key, "(a JSON object)"
        found = _duplicate_line(text)
        if found is not None:
            key, where = found[0], f"line {found[1] + first_line - 1}"
        raise InputError(source, where, key, "each key once in an object") from None
    except RecursionError:
        raise InputError(source, "(file)", "nesting too deep", f"valid JSON ({what})") from None


def read_json(path: str | os.PathLike[str], what: str) -> object:
    """Read and parse a JSON file (`parse_json`); an unreadable file is an `InputError` too."""
    return parse_json(read_text(path, what), path, what)
