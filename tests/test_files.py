"""Tests of output files: atomic (all or nothing, no temporaries left behind by killed writers),
never written through a symbolic link, locks removed by their holder, errors naming the file."""

from __future__ import annotations

import errno
import os
import re
import signal
import stat
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from vprobot.files.atomic import (
    InUseError,
    append_line,
    atomic_output,
    exclusive_lock,
    remove_stale_temporaries,
    write_text,
)


@pytest.fixture
def dead_pid() -> int:
    """The PID of a process that has exited and been reaped."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


@pytest.fixture
def live_pid() -> Iterator[int]:
    """The PID of another process that stays alive during the test."""
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    yield child.pid
    child.kill()
    child.wait()


@pytest.fixture
def umask() -> Iterator[None]:
    previous = os.umask(0o027)
    yield
    os.umask(previous)


def test_success_leaves_only_the_target_with_plain_permissions(tmp_path: Path,
                                                                umask: None) -> None:
    target = tmp_path / "x.mp4"
    with atomic_output(target) as temporary:
        assert temporary.parent == tmp_path and temporary.suffix == ".mp4"
        assert re.fullmatch(rf"\.x\.mp4\.{os.getpid()}\.[a-z0-9_]+\.mp4", temporary.name)
        temporary.write_bytes(b"video")
        assert not target.exists()
    assert os.listdir(tmp_path) == ["x.mp4"]
    assert target.read_bytes() == b"video"
    # Like a file opened for writing under the umask 027, not mkstemp's 0600.
    assert stat.S_IMODE(target.stat().st_mode) == 0o640


@pytest.mark.parametrize("error", [ValueError, KeyboardInterrupt, SystemExit])
@pytest.mark.parametrize("existing", [False, True])
def test_failure_leaves_nothing_new(error: type[BaseException], existing: bool,
                                    tmp_path: Path) -> None:
    target = tmp_path / "x.png"
    if existing:
        target.write_bytes(b"old")
    with pytest.raises(error), atomic_output(target) as temporary:
        temporary.write_bytes(b"half")
        raise error
    assert os.listdir(tmp_path) == (["x.png"] if existing else [])
    if existing:
        assert target.read_bytes() == b"old"


def test_stale_temporaries_of_dead_writers_are_removed_others_kept(
        tmp_path: Path, dead_pid: int, live_pid: int) -> None:
    stale = [f".x.mp4.{dead_pid}.abcd_123.mp4", f".x.mp4.{dead_pid}.zz9.mp4"]
    kept = [
        f".x.mp4.{live_pid}.abcd_123.mp4",  # another process still writing
        f".x.mp4.{os.getppid()}.abcd_123.mp4",
        f".x.mp4.{os.getpid()}.abcd_123.mp4",
        f".y.mp4.{dead_pid}.abcd_123.mp4",  # other targets
        f".xx.mp4.{dead_pid}.abcd_123.mp4",
        f".x.mp4.7.mp4.{dead_pid}.abcd_123.mp4",
        f".x.{dead_pid}.abcd_123",
        ".x.mp4.abcd_123.mp4",  # not named by the PID scheme
        f".x.mp4.{dead_pid}.ab.cd.mp4",
        f".x.mp4.{dead_pid}.ABCD.mp4",
        f".x.mp4.{dead_pid}.abcd_123.mp4.bak",
        f"x.mp4.{dead_pid}.abcd_123.mp4",
        "x.mp4",
    ]
    for name in stale + kept:
        (tmp_path / name).write_bytes(b"")
    (tmp_path / f".x.mp4.{dead_pid}.dir.mp4").mkdir()
    kept.append(f".x.mp4.{dead_pid}.dir.mp4")
    with atomic_output(tmp_path / "x.mp4") as temporary:
        assert sorted(os.listdir(tmp_path)) == sorted([*kept, temporary.name])
        temporary.write_bytes(b"new")
    assert sorted(os.listdir(tmp_path)) == sorted(kept)
    assert (tmp_path / "x.mp4").read_bytes() == b"new"
    assert remove_stale_temporaries(tmp_path / "x.mp4") == []


def test_missing_folder_still_fails_as_before(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError), atomic_output(tmp_path / "no" / "x.json"):
        pass


_KILLED_WRITER = textwrap.dedent("""
    import os, signal, sys
    from pathlib import Path
    from vprobot.files.atomic import atomic_output

    with atomic_output(Path(sys.argv[1])) as temporary:
        temporary.write_bytes(b"half a video")
        os.kill(os.getpid(), signal.SIGKILL)
""")


def test_temporary_of_a_killed_writer_is_removed_by_the_next_write(tmp_path: Path) -> None:
    target = tmp_path / "render.mp4"
    child = subprocess.run([sys.executable, "-c", _KILLED_WRITER, str(target)],
                           capture_output=True, timeout=60, check=False)
    assert child.returncode == -signal.SIGKILL, child.stderr.decode()
    leftovers = os.listdir(tmp_path)
    assert len(leftovers) == 1
    assert re.fullmatch(r"\.render\.mp4\.\d+\.[a-z0-9_]+\.mp4", leftovers[0])
    with atomic_output(target) as temporary:
        temporary.write_bytes(b"video")
    assert os.listdir(tmp_path) == ["render.mp4"]
    assert target.read_bytes() == b"video"


def test_a_short_append_is_cut_back_and_raises(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A full disk writes what fits: that part of a line is removed and the write is an
    error, so that the next append does not glue its line onto a cut one."""
    path = tmp_path / "rows.csv"
    append_line(path, "a,b\n1,2\n")
    real_write = os.write
    monkeypatch.setattr(os, "write", lambda descriptor, data: real_write(descriptor, data[:3]))
    with pytest.raises(OSError, match="only 3 of 8 bytes"):
        append_line(path, "333,444\n")
    monkeypatch.undo()
    assert path.read_text() == "a,b\n1,2\n"
    append_line(path, "5,6\n")
    assert path.read_text() == "a,b\n1,2\n5,6\n"


def _outside(tmp_path: Path) -> tuple[Path, Path]:
    """A file outside the output folder `tmp_path/out`, and that folder."""
    outside, out = tmp_path / "precious.txt", tmp_path / "out"
    outside.write_text("precious\n")
    out.mkdir()
    return outside, out


def test_a_lock_or_an_append_through_a_symbolic_link_is_refused_naming_it(
        tmp_path: Path) -> None:
    """A link planted in an output folder, to a file outside or to none: the lock and the
    append refuse it, naming it, and neither writes the file outside nor creates one."""
    outside, out = _outside(tmp_path)
    (out / "held.lock").symlink_to(outside)
    (out / "rows.csv").symlink_to(outside)
    (out / "dangling.csv").symlink_to(tmp_path / "created.txt")
    with pytest.raises(ValueError, match=f"{out / 'held.lock'} is a symbolic link"), \
            exclusive_lock(out / "held.lock", "out"):
        pass
    for link in (out / "rows.csv", out / "dangling.csv"):
        with pytest.raises(ValueError, match=f"{link} is a symbolic link"):
            append_line(link, "1,2\n")
    assert outside.read_text() == "precious\n"
    assert not (tmp_path / "created.txt").exists()
    # Cutting a torn line, and the check before work (and of the files a library opens).
    from vprobot.files.atomic import refuse_link, truncate_output

    for link in (out / "rows.csv", out / "dangling.csv"):
        with pytest.raises(ValueError, match=f"{link} is a symbolic link"):
            truncate_output(link, 0)
        with pytest.raises(ValueError, match=f"{link} is a symbolic link"):
            refuse_link(link)
    refuse_link(outside)
    assert outside.read_text() == "precious\n"


def test_an_atomic_write_replaces_a_symbolic_link_and_leaves_its_target(tmp_path: Path) -> None:
    outside, out = _outside(tmp_path)
    (out / "table.csv").symlink_to(outside)
    write_text(out / "table.csv", "a,b\n")
    assert not (out / "table.csv").is_symlink()
    assert (out / "table.csv").read_text() == "a,b\n"
    assert outside.read_text() == "precious\n"


def test_the_lock_file_is_removed_when_its_holder_ends(tmp_path: Path) -> None:
    path = tmp_path / "folder.lock"
    with exclusive_lock(path, "the folder"):
        assert path.read_text() == f"{os.getpid()}\n"
    assert not path.exists()
    with pytest.raises(RuntimeError), exclusive_lock(path, "the folder"):
        raise RuntimeError
    assert not path.exists()


def test_a_lock_taken_on_a_file_its_holder_just_removed_is_taken_again(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The race of removing a lock file: B opens it while A holds it, A ends (removing it and
    letting go), then B locks the removed file. B must take the lock anew at the path, so that
    a third process is refused while B runs."""
    import contextlib
    import fcntl

    path = tmp_path / "folder.lock"
    first = contextlib.ExitStack()
    first.enter_context(exclusive_lock(path, "the folder"))
    real_flock = fcntl.flock

    def first_ends_before_the_lock(descriptor: int, operation: int) -> None:
        first.close()  # only the first call: closing twice does nothing
        real_flock(descriptor, operation)

    monkeypatch.setattr(fcntl, "flock", first_ends_before_the_lock)
    with exclusive_lock(path, "the folder"):
        monkeypatch.setattr(fcntl, "flock", real_flock)
        assert path.read_text() == f"{os.getpid()}\n"
        with pytest.raises(InUseError, match=f"the folder is in use by pid {os.getpid()}"), \
                exclusive_lock(path, "the folder"):
            pass
    assert not path.exists()


def test_a_failed_write_names_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A full disk fails a write with an OSError that names no file: the error names it."""
    def disk_full(*args: object, **kwargs: object) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "write", disk_full)
    with pytest.raises(OSError, match=re.escape(f"No space left on device: "
                                                f"'{tmp_path / 'rows.csv'}'")):
        append_line(tmp_path / "rows.csv", "1,2\n")
    monkeypatch.setattr(Path, "write_text", disk_full)
    with pytest.raises(OSError, match=re.escape(f"No space left on device: "
                                                f"'{tmp_path / 'table.md'}'")):
        write_text(tmp_path / "table.md", "# table\n")
    assert sorted(os.listdir(tmp_path)) == ["rows.csv"]
