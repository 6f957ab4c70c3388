"""Writing output files atomically: readers never see a half-written file."""

from __future__ import annotations

import contextlib
import csv
import errno
import io
import os
import re
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any


def _new_file_mode() -> int:
    """Permissions a plainly created file would get (mkstemp's are owner-only)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _temporary_pattern(path: Path) -> re.Pattern[str]:
    """Names of `atomic_output`'s temporaries for `path`: `.{name}.{pid}.{random}{suffix}`."""
    # mkstemp's random part never contains a dot, so a temporary of another target whose name
    # extends this one's cannot match.
    return re.compile(rf"\.{re.escape(path.name)}\.(\d+)\.[a-z0-9_]+{re.escape(path.suffix)}")


def _is_alive(pid: int) -> bool:
    """Whether process `pid` may still exist; True whenever that cannot be told."""
    if os.name != "posix" or pid <= 0:
        # On Windows os.kill terminates the process instead of probing it.
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):
        # PermissionError: the process exists but belongs to another user.
        return True
    return True


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Delete temporaries that writers of `path` left when killed (their process is gone).

    Temporaries of live processes, of other targets and files named otherwise are kept.
    Failures are ignored: this is housekeeping and must not stop the write.

    Returns:
        The files removed.
    """
    pattern = _temporary_pattern(path)
    removed: list[Path] = []
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return removed
    for entry in entries:
        match = pattern.fullmatch(entry.name)
        if match is None or _is_alive(int(match.group(1))):
            continue
        try:
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            continue
    return removed


@contextlib.contextmanager
def atomic_output(path: Path) -> Iterator[Path]:
    """Yield a temporary file beside `path` that replaces `path` only if the block succeeds.

    The temporary is named `.{name}.{pid}.{random}{suffix}`: a writer killed without a chance
    to clean up (SIGKILL, an unhandled SIGTERM) leaves it behind, and the next write to `path`
    removes it once that process is gone.
    """
    remove_stale_temporaries(path)
    # Same folder so that os.replace is an atomic rename; same suffix so writers pick the format.
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.",
                                         suffix=path.suffix)
    try:
        os.close(handle)
        yield Path(temporary)
        os.chmod(temporary, _new_file_mode())
        os.replace(temporary, path)
    except BaseException:
        # BaseException: KeyboardInterrupt and SystemExit must not leave the temporary either.
        Path(temporary).unlink(missing_ok=True)
        raise


def append_line(path: Path, text: str) -> None:
    """Append whole lines in one write, flushed to disk: a kill leaves whole lines, and at worst
    a last line cut short (readers drop a line without its newline).

    The caller must be the file's only writer (hold a lock): a short write is cut back to the
    length the file had before it.

    Raises:
        OSError: If the write fails or is short (a full disk): the file is as it was.
    """
    data = text.encode()
    descriptor = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        start = os.lseek(descriptor, 0, os.SEEK_END)
        written = os.write(descriptor, data)
        if written != len(data):
            # A cut line would glue the next append onto it; the next write would most likely
            # fail anyway (a full disk writes what fits, then nothing).
            os.ftruncate(descriptor, start)
            raise OSError(errno.ENOSPC, f"only {written} of {len(data)} bytes could be "
                          f"appended (disk full?); the file is left as it was", str(path))
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def batch_folder(out_dir: str | Path, count: int, seed: int) -> Path:
    """The folder a batch of `count` seeded files (from `seed` on) goes into, created.

    Raises:
        ValueError: If count < 1 or seed < 0.
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    folder = Path(out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def read_text(path: Path) -> str:
    """The text of a file vprobot reads (a table, a log, a list).

    Raises:
        OSError: If it cannot be read.
        ValueError: If it is not UTF-8 text; the message names the file.
    """
    data = path.read_bytes()
    try:
        return data.decode()
    except UnicodeDecodeError as error:
        raise ValueError(f"{path} is not UTF-8 text (byte {error.start} is "
                         f"{data[error.start:error.start + 1]!r}): not a file vprobot wrote, or "
                         f"a damaged one") from None


def write_text(path: Path, text: str) -> Path:
    """Write `text` to `path` atomically (the old file, or none, until it is complete)."""
    with atomic_output(path) as temporary:
        temporary.write_text(text)
    return path


def csv_text(columns: Sequence[str], rows: Iterable[Mapping[str, Any]],
             header: bool = True) -> str:
    """Rows as CSV text ("\n" line ends); a missing or None value is an empty cell."""
    stream = io.StringIO()
    writer = csv.DictWriter(stream, fieldnames=list(columns), lineterminator="\n")
    if header:
        writer.writeheader()
    for row in rows:
        writer.writerow({key: "" if row.get(key) is None else row[key] for key in columns})
    return stream.getvalue()


class InUseError(ValueError):
    """Another live process holds the lock (a `ValueError`: a user error, exit 2)."""


@contextlib.contextmanager
def exclusive_lock(path: Path, what: str) -> Iterator[None]:
    """Hold an exclusive lock on the file `path` (created if missing) for the block.

    The lock is flock(2) (POSIX): the kernel drops it when its holder ends, however it ends
    (kill -9 included), so a crash never leaves a stale lock. The file keeps the holder's pid,
    for the refusal to name it.

    Args:
        path: The lock file.
        what: What the lock guards, as the user knows it (e.g. the folder they gave).

    Raises:
        InUseError: At once, if another process holds the lock.
    """
    import fcntl  # POSIX only; imported here so that the module still imports elsewhere

    descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(descriptor, 32, 0).decode(errors="replace").strip()
            by = f"pid {holder}" if holder.isdigit() else "another process"
            raise InUseError(f"{what} is in use by {by}; wait for it to end, or stop it "
                             f"first") from None
        os.ftruncate(descriptor, 0)
        os.pwrite(descriptor, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        # Closing the descriptor releases the lock.
        os.close(descriptor)


FOLDER_LOCK = "folder.lock"
"""The lock file `folder_lock` keeps in an output folder."""


@contextlib.contextmanager
def folder_lock(folder: str | Path, what: str) -> Iterator[Path]:
    """Create `folder` (with its parents) and hold its lock for the block, so that a second
    command writing into it (whose rows and resumes would mix with this one's) is refused.

    Args:
        folder: The output folder.
        what: The folder as the user gave it, for the refusal.

    Yields:
        The folder.

    Raises:
        InUseError: At once, if another process holds the folder.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with exclusive_lock(folder / FOLDER_LOCK, what):
        yield folder


def save_figure(figure: Any, path: str | Path, title: str) -> Path:
    """Title a matplotlib figure, write it as a PNG atomically and close it."""
    import matplotlib.pyplot as plt

    figure.suptitle(title)
    figure.tight_layout()
    path = Path(path)
    with atomic_output(path) as temporary:
        figure.savefig(temporary, dpi=110)
    plt.close(figure)
    return path
