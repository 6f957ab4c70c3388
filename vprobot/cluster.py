"""Ray, for work that outgrows one process: a local Ray started on demand, or a cluster.

Ray is an optional extra (`pip install -e ".[cluster]"`); without it the commands that need it
say how to install it. Each task takes one CPU and sets torch to one thread, so that two tasks
keep two cores busy without oversubscribing them.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any

INSTALL_HINT = 'pip install -e ".[cluster]"'


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


def start(address: str | None, cpus: int) -> Any:
    """Connect to the cluster at `address`, or start a local Ray with `cpus` CPUs (once).

    Raises:
        ValueError: Without Ray, or if the cluster cannot be reached.
    """
    ray = require_ray()
    if not ray.is_initialized():
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
    import torch

    torch.set_num_threads(1)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
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
                 workers: int, address: str | None = None) -> Iterator[tuple[int, Any]]:
    """Run `function(*item)` for every item as a Ray task (one CPU each), yielding
    (item index, result) as tasks finish; on an interrupt (or when closed early) the pending
    tasks are cancelled and their workers ended.

    Raises:
        ValueError: Without Ray or a reachable cluster, or for workers < 1.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    ray = start(address, workers)
    remote = ray.remote(num_cpus=1)(_one_thread)
    pending = {remote.remote(function, *item): index for index, item in enumerate(items)}
    try:
        while pending:
            (ready,), _ = ray.wait(list(pending), num_returns=1)
            yield pending.pop(ready), _result(ray, ready)
    except BaseException:
        if pending:
            # Disconnecting ends this driver's tasks and their workers (all of a local Ray's).
            # Not ray.cancel(force=True): racing a task that is just finishing, it can abort
            # the driver in Ray's task manager ("Tried to complete task that was not pending").
            ray.shutdown()
        raise
