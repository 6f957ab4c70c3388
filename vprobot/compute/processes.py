"""Child processes that end with their parent: the workers of vprobot's process pools and the
vprobot commands it runs as children (`report check`'s `evaluate`).

A parent killed without a chance to clean up (SIGKILL, the kernel's out-of-memory killer) would
otherwise leave its children running on: holding memory, a run's lock and, for a child that
writes into its parent's temporary folder, that folder. So each child watches its parent from a
daemon thread (`end_with_parent`): once the parent is gone (the child has been handed to
another parent), the child sends itself SIGTERM, which a vprobot command takes as Ctrl-C (it
saves what it finished and exits 130) and which ends a pool worker at once; it is ended
`GRACE_S` later if that did not end it. A poll of the parent's pid, not Linux's
`PR_SET_PDEATHSIG`: that fires when the *thread* that started the child ends, and only on
Linux.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import shutil
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from vprobot.extensions import plugins

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

POLL_S = 0.2
"""How often a child checks that its parent is still there."""
GRACE_S = 10.0
"""How long an orphaned child may take to end itself after its SIGTERM before it is ended."""
ORPHAN_EXIT_CODE = 130
"""What a child ended after `GRACE_S` exits with: the CLI's code for an interrupted command."""
PARENT_ENV = "VPROBOT_PARENT_PID"
"""In a vprobot command's environment (`child_environment`): the parent it ends with."""
SCRATCH_ENV = "VPROBOT_PARENT_SCRATCH"
"""In a vprobot command's environment: the parent's temporary folder it removes if it outlives
that parent (nobody else is left to)."""


def end_with_parent(parent: int, scratch: Path | None = None) -> None:
    """End this process when the process `parent` (its parent when it started) has ended; then
    remove `scratch` too (on the way out, or after `GRACE_S` at the latest)."""
    threading.Thread(target=_watch, args=(parent, scratch), daemon=True,
                     name="end-with-parent").start()


def _watch(parent: int, scratch: Path | None) -> None:
    # A child whose parent has ended is handed to init or a subreaper: its parent pid changes.
    while os.getppid() == parent:
        time.sleep(POLL_S)
    if scratch is not None:
        atexit.register(shutil.rmtree, scratch, ignore_errors=True)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(GRACE_S)
    # Still here: the main thread is stuck where no signal handler runs (a long C call).
    if scratch is not None:
        shutil.rmtree(scratch, ignore_errors=True)
    os._exit(ORPHAN_EXIT_CODE)


def child_environment(scratch: Path | None = None) -> dict[str, str]:
    """This process's environment for a vprobot command run as its child that ends with it
    (`end_with_environment`), removing `scratch` if it outlives it."""
    environment = {**os.environ, PARENT_ENV: str(os.getpid())}
    if scratch is not None:
        environment[SCRATCH_ENV] = str(scratch)
    return environment


def end_with_environment() -> None:
    """In a vprobot command started with `child_environment`: end with that parent. The
    variables are taken out of the environment, so that this command's own children do not
    watch a process that is not their parent."""
    parent = os.environ.pop(PARENT_ENV, None)
    scratch = os.environ.pop(SCRATCH_ENV, None)
    if parent is not None and parent.isdecimal():
        end_with_parent(int(parent), Path(scratch) if scratch else None)


@contextlib.contextmanager
def worker_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    """A pool of `workers` spawned processes that end with this one (`end_with_parent`), each
    with this process's plugins loaded (`vprobot.extensions.plugins.in_child`) before it takes a
    task.

    Leaving the block by an exception (Ctrl-C, SIGTERM, a task's error) cancels the tasks not
    started and ends the workers at once, rather than waiting for every task to finish. The
    workers ignore Ctrl-C, which the terminal sends them too: this process ends them.
    """
    # Here, not at the top: every command line imports this module, few start a pool.
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # Spawned: MuJoCo's and torch's threads do not survive a fork.
    context = multiprocessing.get_context("spawn")
    others = set(multiprocessing.active_children())
    # Loaded by the initializer, so that a task's arguments may hold a plugin's classes.
    pool = ProcessPoolExecutor(workers, mp_context=context,
                               initializer=plugins.in_child(_start_worker), initargs=(os.getpid(),))
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        started = set(multiprocessing.active_children()) - others
        for worker in started:
            worker.terminate()
        for worker in started:
            worker.join()
        raise
    pool.shutdown()


def _start_worker(parent: int) -> None:
    """A `worker_pool` worker's first step: it leaves Ctrl-C to its parent (rather than print
    a KeyboardInterrupt traceback of its own) and ends with it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    end_with_parent(parent)
