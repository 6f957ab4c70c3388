"""Ray, for work that outgrows one process: a local Ray started on demand, or a cluster.

Ray is an optional extra (`pip install -e ".[cluster]"`); without it the commands that need it
say how to install it. Each task takes one CPU and sets torch to one thread, so that two tasks
keep two cores busy without oversubscribing them.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Generator, Iterable
from pathlib import Path
from typing import Any

from vprobot.extensions import plugins

INSTALL_HINT = 'pip install -e ".[cluster]"'
SHUTDOWN_GRACE_S = 5.0
"""How long an interrupted `parallel_map` lets its local Ray's processes end by themselves before
it kills those left."""
PROBE_TIMEOUT_S = 10.0
"""How long `start` waits for a cluster's `HOST:PORT` to accept a connection before it gives up
(`ray.init` itself retries an unreachable GCS for many minutes)."""


def require_ray() -> Any:
    """The `ray` module.

    Raises:
        ValueError: If Ray is not installed, saying how to install it.
    """
    try:
        import ray
    except ImportError:
        raise ValueError(f"this needs Ray, which is not installed; install it with "
                         f"{INSTALL_HINT}") from None
    return ray


def probe(address: str) -> None:
    """Check that a cluster address of the form `HOST:PORT` (a head node's GCS) accepts a
    connection; other forms (`ray://...`, `auto`) are left to Ray, which fails fast on them.

    Raises:
        ValueError: If nothing answers at `HOST:PORT` within `PROBE_TIMEOUT_S`.
    """
    host, separator, port = address.rpartition(":")
    if not separator or not host or "://" in address or not port.isdecimal():
        return
    try:
        with socket.create_connection((host.strip("[]"), int(port)), PROBE_TIMEOUT_S):
            pass
    except (OSError, OverflowError) as error:
        raise ValueError(f"cannot reach the Ray cluster at {address}: nothing answers there "
                         f"({error}); start it with `ray start --head`, or check the address"
                         ) from None


def start(address: str | None, cpus: int) -> Any:
    """Connect to the cluster at `address`, or start a local Ray with `cpus` CPUs (once).

    Raises:
        ValueError: Without Ray, or if the cluster cannot be reached.
    """
    ray = require_ray()
    if not ray.is_initialized():
        if address is not None:
            probe(address)
        in_main_thread = threading.current_thread() is threading.main_thread()
        caller_handler = signal.getsignal(signal.SIGTERM) if in_main_thread else None
        try:
            if address is not None:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=cpus, include_dashboard=False, log_to_driver=False)
        except ConnectionError as error:
            raise ValueError(f"cannot reach the Ray cluster at {address}: {error}") from None
        except SystemExit as exit_request:
            # While ray.init runs, Ray's own handler turns SIGTERM into sys.exit(15): hand that
            # SIGTERM to the caller's handler instead.
            if callable(caller_handler) and exit_request.code == signal.SIGTERM:
                caller_handler(signal.SIGTERM, None)
            raise
        finally:
            if callable(caller_handler):
                # ray.init replaces SIGTERM handling with a C++ stack dump and sys.exit(15);
                # a handler the caller installed (the CLI's: SIGTERM as Ctrl-C, so partial
                # results are saved and the exit code is 130) stays in charge.
                signal.signal(signal.SIGTERM, caller_handler)
    return ray


def _one_thread(function: Callable[..., Any], *args: Any) -> Any:
    """A Ray task: `function(*args)` on one thread."""
    # One CPU per task. Torch takes its thread count from OMP_NUM_THREADS when first imported;
    # it is not imported here, since evaluation tasks never need it and its import costs each
    # worker seconds.
    os.environ["OMP_NUM_THREADS"] = "1"
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)
    return function(*args)


def _result(ray: Any, reference: Any) -> Any:
    """A finished task's result; a user error it raised (a bad input, a run in use) is raised
    as itself, so that its message, not Ray's remote traceback, reaches the user."""
    try:
        return ray.get(reference)
    except ray.exceptions.RayTaskError as error:
        if isinstance(error.cause, ValueError | OSError):
            raise error.cause from None
        raise


def parallel_map(function: Callable[..., Any], items: Iterable[tuple[Any, ...]],
                 workers: int, address: str | None = None,
                 ) -> Generator[tuple[int, Any], None, None]:
    """Run `function(*item)` for every item as a Ray task (one CPU each, after this process's
    plugins), yielding (item index, result) as tasks finish; on an interrupt (or when closed
    early) the pending tasks are cancelled and their workers ended.

    Raises:
        ValueError: Without Ray or a reachable cluster, or for workers < 1.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    ray = start(address, workers)
    remote = ray.remote(num_cpus=1)(_one_thread)
    task = plugins.in_child(function)
    pending = {remote.remote(task, *item): index for index, item in enumerate(items)}
    try:
        while pending:
            (ready,), _ = ray.wait(list(pending), num_returns=1)
            yield pending.pop(ready), _result(ray, ready)
    except BaseException:
        if pending:
            # Disconnecting ends this driver's tasks and their workers (all of a local Ray's).
            # Not ray.cancel(force=True): racing a task that is just finishing, it can abort
            # the driver in Ray's task manager ("Tried to complete task that was not pending").
            local = _descendants(os.getpid())
            ray.shutdown()
            _end(local)
        raise


def _descendants(pid: int) -> set[int]:
    """The processes below `pid` (Linux /proc; empty elsewhere): a local Ray's raylet, its
    workers and their helpers."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        fields = _stat_fields(stat)
        if fields:  # else ended meanwhile
            children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, stack = set(), [pid]
    while stack:
        for child in children.get(stack.pop(), []):
            found.add(child)
            stack.append(child)
    return found


def _stat_fields(stat: Path) -> list[str]:
    """The fields of a /proc/PID/stat after the command name (state, parent pid, ...); empty
    if the process has ended."""
    try:
        return stat.read_text().rsplit(")", 1)[1].split()
    except OSError:
        return []


def _running(pid: int) -> bool:
    fields = _stat_fields(Path(f"/proc/{pid}/stat"))
    return bool(fields) and fields[0] != "Z"


def _wait_until_ended(pids: set[int], timeout_s: float) -> bool:
    """Wait up to `timeout_s` for the processes to end; whether they all have."""
    deadline = time.monotonic() + timeout_s
    while any(_running(pid) for pid in pids):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def _end(pids: set[int]) -> None:
    """End a local Ray's processes after `ray.shutdown()`, which signals them but does not wait:
    a worker that lived on (orphaned, slow to notice under load) would still hold its run's
    lock when the user reruns the command."""
    if _wait_until_ended(pids, SHUTDOWN_GRACE_S):
        return
    for pid in pids:
        if _running(pid):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
    _wait_until_ended(pids, SHUTDOWN_GRACE_S)
