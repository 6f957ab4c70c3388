"""Writing output files atomically: readers never see a half-written file."""

from __future__ import annotations

import contextlib
import csv
import errno
import hashlib
import io
import os
import re
import tempfile
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.files.paths import CACHE_ENV_VAR

_WARNED_CACHE_DIRS: set[Path] = set()
"""Cache directories already reported as unwritable by this process."""


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


class LinkError(ValueError):
    """A file vprobot would write into an output folder is a symbolic link (a `ValueError`: a
    user error, exit 2)."""


@contextlib.contextmanager
def naming(path: Path) -> Iterator[None]:
    """Give an OSError of the block that names no file (a write's: a full disk) `path`'s name,
    so that the one-line error says which file could not be written."""
    try:
        yield
    except OSError as error:
        if error.filename is None and error.errno is not None:
            error.filename = str(path)
        raise


def _link_error(path: Path) -> LinkError:
    return LinkError(f"{path} is a symbolic link (to {os.readlink(path)!r}); vprobot writes no "
                     f"file of an output folder through a link: remove it")


def refuse_link(path: Path) -> None:
    """Refuse a symbolic link at `path`, a file of an output folder to be written: before the
    work whose results go into it, or where a library opens it (stable-baselines3's monitors).
    vprobot's own writes refuse one as they open the file (`open_output`).

    Raises:
        LinkError: If `path` is a symbolic link.
    """
    if os.path.islink(path):
        raise _link_error(path)


def open_output(path: Path, flags: int) -> int:
    """`os.open` a file that vprobot writes into an output folder (created with mode 0o644 when
    `flags` has O_CREAT), refusing a symbolic link: one planted there would have the write (an
    append, a lock's pid, a cut) land in a file outside the folder.

    Raises:
        LinkError: If `path` is a symbolic link (dangling or not).
        OSError: If it cannot be opened.
    """
    try:
        # O_NOFOLLOW is POSIX; where it is missing (Windows) links need privileges to be made.
        return os.open(path, flags | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except OSError as error:
        if error.errno == errno.ELOOP and os.path.islink(path):
            raise _link_error(path) from None
        raise


def truncate_output(path: Path, length: int) -> None:
    """Cut a file of an output folder back to its first `length` bytes (a line a kill left cut
    short), refusing a symbolic link (`open_output`)."""
    descriptor = open_output(path, os.O_WRONLY)
    try:
        with naming(path):
            os.ftruncate(descriptor, length)
    finally:
        os.close(descriptor)


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
        # os.replace renames over `path`: a symbolic link there is replaced, never followed.
        with naming(path):
            yield Path(temporary)
            os.chmod(temporary, _new_file_mode())
            os.replace(temporary, path)
    except BaseException:
        # BaseException: KeyboardInterrupt and SystemExit must not leave the temporary either.
        Path(temporary).unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def waiting_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on the file `path` (created, with its folder, if missing) for the
    block, waiting for any other holder first: for work that processes share once done (a
    cache entry), where the second should wait for the first rather than do it again. The
    file stays; flock(2) ends with its holder, however it ends. Where the file cannot be
    made (a read-only cache), the block runs unlocked: the work is then only done twice."""
    import fcntl  # POSIX only; imported here so that the module still imports elsewhere

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        stream = path.open("a")
    except OSError:
        yield
        return
    with stream:
        fcntl.flock(stream, fcntl.LOCK_EX)
        yield


def read_cached_arrays(path: Path) -> dict[str, np.ndarray] | None:
    """The arrays of the cache file `path` (`.npz`, no pickles), or None when there is none or
    it cannot be read: the caller recomputes, and checks what it reads."""
    try:
        # Our own handle: np.load leaks the one it opens when the zip directory is corrupt.
        with path.open("rb") as stream, np.load(stream, allow_pickle=False) as stored:
            return {name: stored[name] for name in stored.files}
    except Exception:
        # A corrupt file fails in many ways (BadZipFile, EOFError, ValueError, OSError, a
        # .npy instead of an .npz, ...); any of them just means "recompute".
        return None


def write_arrays(path: Path, arrays: Mapping[str, Any]) -> Path:
    """Write `arrays` to the `.npz` file `path` atomically (see `atomic_output`)."""
    with atomic_output(path) as temporary, temporary.open("wb") as stream:
        np.savez(stream, **arrays)
    return path


def write_cached_arrays(path: Path, arrays: Mapping[str, Any], what: str,
                        stacklevel: int = 3) -> None:
    """Store `arrays` in the cache file `path` atomically (see `atomic_output`); warn once per
    directory when it cannot be written, naming `what` the cache holds (e.g. "ground truths"),
    at the frame `stacklevel` counts from here (3: the caller's caller).

    A half-written or failed store leaves any previous file in place, and the next run
    recomputes it if it is bad.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_arrays(path, arrays)
    except OSError as error:
        # What was cached is computed; a cache that cannot be written only costs time later.
        directory = path.parent
        if directory not in _WARNED_CACHE_DIRS:
            _WARNED_CACHE_DIRS.add(directory)
            warnings.warn(f"cannot write the cache directory {directory} ({error}); {what} "
                          f"are not cached on disk and are recomputed in every run; set "
                          f"${CACHE_ENV_VAR} to a writable directory", RuntimeWarning,
                          stacklevel=stacklevel)


def append_line(path: Path, text: str) -> None:
    """Append whole lines in one write, flushed to disk: a kill leaves whole lines, and at worst
    a last line cut short (readers drop a line without its newline).

    The caller must be the file's only writer (hold a lock): a short write is cut back to the
    length the file had before it.

    Raises:
        LinkError: If `path` is a symbolic link.
        OSError: If the write fails or is short (a full disk), naming `path`: the file is as
            it was.
    """
    data = text.encode()
    descriptor = open_output(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
    try:
        with naming(path):
            start = os.lseek(descriptor, 0, os.SEEK_END)
            written = os.write(descriptor, data)
            if written != len(data):
                # A cut line would glue the next append onto it; the next write would most
                # likely fail anyway (a full disk writes what fits, then nothing).
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


def read_table(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    """The columns (the header) and the rows of a CSV table vprobot reads; blank lines are
    skipped.

    Raises:
        OSError: If it cannot be read.
        ValueError: If it is not UTF-8 text, or a row's cells are not one per column (a row
            cut short or glued onto another); the message names the file and the line.
    """
    reader = csv.reader(io.StringIO(read_text(path), newline=""))
    columns = next(reader, [])
    rows = []
    for cells in reader:
        if not cells:
            continue
        if len(cells) != len(columns):
            raise ValueError(f"{path}, line {reader.line_num}: {len(cells)} cells where the "
                             f"header has {len(columns)} columns: a damaged table (a row cut "
                             f"short?)")
        rows.append(dict(zip(columns, cells, strict=True)))
    return columns, rows


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


def _names(path: Path, descriptor: int) -> bool:
    """Whether `path` is (still) the file open as `descriptor`."""
    try:
        named = os.stat(path, follow_symlinks=False)
    except FileNotFoundError:
        return False
    held = os.fstat(descriptor)
    return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


@contextlib.contextmanager
def exclusive_lock(path: Path, what: str) -> Iterator[None]:
    """Hold an exclusive lock on the file `path` (created if missing) for the block.

    The lock is flock(2) (POSIX): the kernel drops it when its holder ends, however it ends
    (kill -9 included), so a crash never leaves a stale lock. The file keeps the holder's pid,
    for the refusal to name it, and is removed when the block ends (a kill -9 leaves it, with
    a pid no process has, and the next holder takes it over).

    Args:
        path: The lock file.
        what: What the lock guards, as the user knows it (e.g. the folder they gave).

    Raises:
        InUseError: At once, if another process holds the lock.
        LinkError: If `path` is a symbolic link.
    """
    import fcntl  # POSIX only; imported here so that the module still imports elsewhere

    while True:
        descriptor = open_output(path, os.O_RDWR | os.O_CREAT)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(descriptor, 32, 0).decode(errors="replace").strip()
            os.close(descriptor)
            by = f"pid {holder}" if holder.isdigit() else "another process"
            raise InUseError(f"{what} is in use by {by}; wait for it to end, or stop it "
                             f"first") from None
        # The holder before may have removed the file between our open and our lock (below):
        # a lock on a removed file guards nothing, so take the one now at `path`.
        if _names(path, descriptor):
            break
        os.close(descriptor)
    try:
        os.ftruncate(descriptor, 0)
        os.pwrite(descriptor, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        # Removed while still locked, so that no other process holds it; one that opened it
        # before and locks it after finds it gone (above). Housekeeping: a failure must not
        # hide the block's error. Closing releases the lock.
        with contextlib.suppress(OSError):
            if _names(path, descriptor):
                os.unlink(path)
        os.close(descriptor)


FOLDER_LOCK = "folder.lock"
"""The lock file `folder_lock` keeps in an output folder while it holds it."""


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


def file_sha256(path: Path) -> str | None:
    """The sha256 of a file's bytes; None if there is no such file."""
    try:
        with path.open("rb") as stream:
            return hashlib.file_digest(stream, "sha256").hexdigest()
    except FileNotFoundError:
        return None
