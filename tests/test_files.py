"""Tests of atomic output: all or nothing, and no temporaries left behind by killed writers."""

from __future__ import annotations

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

from vprobot.files import append_line, atomic_output, remove_stale_temporaries


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
    from vprobot.files import atomic_output

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
