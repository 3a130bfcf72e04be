"""Where a study's runs execute: a local process pool (the default: no setup, all cores), or Ray
(`pip install surf-swarm[ray]`) on a running cluster or a local one it starts.

Both take the same `RunTask`s and yield the same rows, as runs finish (in any order); the seeds are
in the tasks, so which backend, how many workers and the order make no difference to the table.
Processes, not threads: the simulator is numpy-heavy Python, and OMPL (planning a point) holds the
GIL. Local workers start with the "forkserver" method, which never forks a process with threads.

Each worker runs its share of a point's runs in batches (`batches`, `runner.run_batch`): B runs
stepped together on the batched world core cost little more than one, and give the same rows.
"""

from __future__ import annotations

import contextlib
import logging
import math
import multiprocessing
import os
import socket
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait

from swarm.errors import InputError, SwarmError
from swarm.studies.runner import RunTask, run_batch

BACKENDS = ("local", "ray")
#: Times Ray runs a task again after the process running it died.
RAY_RETRIES = 3
#: The automatic batch size: at most this many runs, and this many robots over all its runs (past
#: a few thousand robots a step's numpy work outweighs its Python overhead: batching gains little).
AUTO_BATCH_RUNS = 64
AUTO_BATCH_ROBOTS = 4096


def auto_batch(runs: int, workers: int, robots: int) -> int:
    """The batch size for `runs` runs of a point of `robots` robots shared by `workers` workers:
    each worker's share in one batch, within `AUTO_BATCH_RUNS` and `AUTO_BATCH_ROBOTS`."""
    share = math.ceil(runs / max(1, workers))
    return max(1, min(share, AUTO_BATCH_RUNS, AUTO_BATCH_ROBOTS // max(1, robots)))


def batches(tasks: Sequence[RunTask], size: int | dict[int, int]) -> list[list[RunTask]]:
    """`tasks` in batches of at most `size` runs (or `size[point]`), each of one point, in order."""
    out: list[list[RunTask]] = []
    for task in tasks:
        cap = size if isinstance(size, int) else size.get(task.point, 1)
        last = out[-1] if out else None
        if last is not None and last[0].point == task.point and len(last) < max(1, cap):
            last.append(task)
        else:
            out.append([task])
    return out


def default_workers() -> int:
    """All the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def run_local(
    tasks: Sequence[RunTask],
    workers: int,
    batch: int | dict[int, int] = 1,
    working: Callable[[float], None] | None = None,
) -> Iterator[dict]:
    """Rows as runs finish on `workers` processes (1: in this process, in order), in batches of
    `batch` runs of a point (or `batch[point]`; 1: one run at a time). `working(runs_worth)` is
    told now and then how much of the batches still running is done, in runs, beside the rows
    already yielded (`runner.run_batch`): a batch's runs finish together, at its end."""
    groups = batches(tasks, batch)
    if workers <= 1:
        for group in groups:
            yield from run_batch(group, working)
        return
    context = multiprocessing.get_context("forkserver")
    shared = context.Value("d", 0.0) if working is not None else None
    pending = list(reversed(groups))
    with ProcessPoolExecutor(
        max_workers=workers, mp_context=context, initializer=_share_work, initargs=(shared,)
    ) as pool:
        running: set[Future] = set()
        try:
            while pending or running:
                while pending and len(running) < 2 * workers:  # a short queue: a kill loses little
                    running.add(pool.submit(_run_shared, pending.pop()))
                timeout = None if shared is None else WORKING_POLL_S
                finished, running = wait(running, timeout=timeout, return_when=FIRST_COMPLETED)
                for future in finished:
                    yield from future.result()
                if shared is not None and working is not None:
                    working(shared.value)
        except BaseException:  # Ctrl-C or a failed run: stop now, do not wait for the queue
            pool.shutdown(wait=False, cancel_futures=True)
            raise


#: How often `run_local` reads how far its workers' batches have got (s).
WORKING_POLL_S = 0.5
#: A worker process's share of `run_local`'s count of work done in batches still running (runs).
_WORK_DONE = None


def _share_work(shared) -> None:
    """A worker's start: the count it adds its batches' progress to (None: nobody reads it)."""
    global _WORK_DONE
    _WORK_DONE = shared


def _run_shared(group: list[RunTask]) -> list[dict]:
    """`run_batch` in a worker, adding its progress to the shared count and taking it back at the
    end, when its rows count instead."""
    shared = _WORK_DONE
    if shared is None:
        return run_batch(group)
    told = 0.0

    def add(runs_worth: float) -> None:
        nonlocal told
        with shared.get_lock():
            shared.value += runs_worth - told
        told = runs_worth

    try:
        return run_batch(group, add)
    finally:
        add(0.0)


def start_ray(workers: int | None, address: str | None) -> bool:
    """Connect to the Ray cluster at `address` (e.g. "auto" or "ray://host:10001"), or start a
    local Ray instance (`workers` CPUs) when no address is given, unless Ray is already running
    here; True if this call started it (the caller shuts it down). Before a study writes anything:
    an address with no cluster is one line, not a traceback after study.json."""
    try:
        import ray
    except ImportError:
        raise InputError(
            "command line", "--backend", "ray", "the ray extra installed: pip install 'surf-swarm[ray]'"
        ) from None
    if ray.is_initialized():
        return False
    expected = "a running Ray cluster ('auto' on one of its nodes, or ray://HOST:10001)"
    unreachable = None if address is None else _unreachable(address)
    if unreachable is not None:  # Ray itself waits 20 s for a silent host, and for ever for some
        raise InputError("command line", "--address", address, f"{expected}: {unreachable}")
    # Ray's "ray" logger at ERROR (ray.init's own logging_level): a local start printed a
    # warning that token authentication is on (Ray 2.5x turns it on for a cluster it starts), and
    # a connection one that a token was found; only real errors are the user's business
    kwargs: dict = {
        "include_dashboard": False,
        "log_to_driver": False,
        "configure_logging": True,
        "logging_level": logging.ERROR,
    }
    try:
        if address is not None:
            with _native_stderr_muted():
                ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers or default_workers(), **kwargs)
    except (ConnectionError, ValueError, RuntimeError) as exc:
        reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise InputError("command line", "--address", address, f"{expected}: {reason}") from None
    return True


#: How long `start_ray` waits for a cluster's port to answer before giving up on the address (s).
RAY_CONNECT_TIMEOUT_S = 5.0


#: The HTTP/2 client preface and an empty SETTINGS frame (RFC 9113, 3.4 and 6.5): a gRPC server,
#: as Ray's GCS and client server are, answers with a SETTINGS frame of its own.
HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"
HTTP2_SETTINGS = 0x04


def _unreachable(address: str) -> str | None:
    """Why no Ray cluster answers at `address` (HOST:PORT or ray://HOST:PORT), None if one may
    (a gRPC server, as Ray's ports are) or the address names no port (e.g. "auto": Ray finds the
    cluster itself). Ray waits for ever on a port where something else listens (a web server)."""
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not port.isdigit():
        return None
    where = f"{host}:{port}"
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=RAY_CONNECT_TIMEOUT_S) as sock:
            sock.sendall(HTTP2_PREFACE)
            head = sock.recv(9)
    except TimeoutError:
        return f"what listens at {where} says nothing to a gRPC client (a Ray port is a gRPC server)"
    except OSError as exc:
        return f"nothing answers at {where} ({exc.strerror or type(exc).__name__})"
    if len(head) < 4 or head[3] != HTTP2_SETTINGS:
        return f"what listens at {where} is not a gRPC server (a Ray port is one)"
    return None


@contextlib.contextmanager
def _native_stderr_muted() -> Iterator[None]:
    """File descriptor 2 to /dev/null meanwhile: Ray's core logs each retry of a connection to a
    cluster that is not there straight to it, ahead of the one line that says so."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def stop_ray() -> None:
    import ray

    ray.shutdown()


def run_ray(
    tasks: Sequence[RunTask],
    workers: int | None,
    address: str | None,
    batch: int | dict[int, int] = 1,
    started: bool | None = None,
) -> Iterator[dict]:
    """Rows as runs finish on Ray (`start_ray`; `started`: whether the caller has already started
    it here, None: start it now), in batches as `run_local`; Ray is shut down at the end if it was
    started for these runs."""
    import ray

    started = start_ray(workers, address) if started is None else started
    try:
        # a worker that dies (kill -9, out of memory, a lost node) has its run retried elsewhere:
        # the run's seed is in its task, so the retry gives the same row
        remote = ray.remote(num_cpus=1, max_retries=RAY_RETRIES, retry_exceptions=False)(run_batch)
        in_flight = max(2, 2 * int(ray.cluster_resources().get("CPU", 1)))
        pending = list(reversed(batches(tasks, batch)))
        running: list = []
        while pending or running:
            while pending and len(running) < in_flight:
                running.append(remote.remote(pending.pop()))
            done, running = ray.wait(running, num_returns=1)
            for ref in done:
                yield from ray.get(ref)
    except ray.exceptions.RayError as exc:
        raise SwarmError(f"study: the Ray backend failed: {exc}") from None
    finally:
        if started:
            stop_ray()
