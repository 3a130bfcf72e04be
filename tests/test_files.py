"""The output-folder lock: a second process is refused with one line naming the holder and touches
nothing; a holder killed with SIGKILL leaves the folder free; nested holds in one process work."""

from __future__ import annotations

import errno
import fcntl
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from swarm import files
from swarm.errors import FolderBusy, OutputError
from swarm.files import LOCK_FILE, folder_lock, write_text_atomic

HOLD = """
import sys
from swarm.files import folder_lock
with folder_lock(sys.argv[1], "swarm study missions/landing.yaml --out x"):
    print("held", flush=True)
    sys.stdin.read()
"""


def _holder(folder: Path) -> subprocess.Popen:
    """Another process holding the lock on `folder` until its stdin closes."""
    proc = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(folder)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None and proc.stdout.readline() == "held\n"
    return proc


def _snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    return {p.name: (p.stat().st_size, p.stat().st_mtime_ns) for p in folder.iterdir()}


def test_a_second_process_is_refused_naming_the_folder_and_the_holder(tmp_path) -> None:
    out = tmp_path / "study"
    proc = _holder(out)
    try:
        (out / "results.parquet").write_bytes(b"the holder's work")
        before = _snapshot(out)
        with pytest.raises(FolderBusy) as caught, folder_lock(out, "swarm plan"):
            pytest.fail("the lock was granted twice")
        message = str(caught.value)
        assert message == (
            f"{out}: in use by pid {proc.pid} (swarm study missions/landing.yaml --out x); "
            "wait for it to finish, or write to another folder"
        )
        assert "\n" not in message
        assert _snapshot(out) == before  # refused without touching anything
    finally:
        proc.communicate("")
    assert proc.returncode == 0
    assert sorted(p.name for p in out.iterdir()) == ["results.parquet"]  # the lock file went with it


def test_a_holder_that_has_not_written_its_line_yet_is_still_named(tmp_path) -> None:
    """The race CI met: the second process reads the lock file between the holder's lock and its
    line. It waits for the line instead of naming "another process"."""
    folder = tmp_path / "out"
    folder.mkdir()
    fd = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # locked, nothing written yet
        late = threading.Timer(0.2, os.pwrite, (fd, b"4242 swarm study m.yaml\n", 0))
        late.start()
        with pytest.raises(FolderBusy) as refused, folder_lock(folder):
            pass
        late.join()
    finally:
        os.close(fd)
    assert "in use by pid 4242 (swarm study m.yaml)" in str(refused.value)


def test_a_holder_killed_with_sigkill_leaves_the_folder_free(tmp_path) -> None:
    out = tmp_path / "plan"
    proc = _holder(out)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert (out / LOCK_FILE).exists()  # left behind, but the kernel dropped the lock
    with folder_lock(out, "swarm plan") as held:
        assert (held / LOCK_FILE).read_text().split()[0] == str(os.getpid())


def test_nested_holds_in_one_process_and_an_unused_new_folder_is_removed(tmp_path) -> None:
    out = tmp_path / "new"
    with folder_lock(out, "outer"), folder_lock(out, "inner"):
        assert (out / LOCK_FILE).read_text() == f"{os.getpid()} outer\n"
    assert not out.exists()  # nothing was written: no empty folder left behind
    with folder_lock(out, "writes"):
        (out / "plan.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == ["plan.json"]


def test_a_full_disk_is_one_line_and_leaves_the_old_file(tmp_path, monkeypatch) -> None:
    target = tmp_path / "plan.json"
    target.write_text("the old plan\n")

    def full(_fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    with pytest.raises(OutputError) as caught:
        write_text_atomic(target, "a new plan\n" * 1000)
    reason = "No space left on device"
    assert str(caught.value) == f"{target}: could not write it ({reason}); nothing partial was left"
    assert target.read_text() == "the old plan\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.json"]  # no temporary file
