"""Output paths, checked before any long work starts: one place for every command.

A check names the option and the path and says what is wrong, so that a mistyped output fails in
a second instead of after minutes of planning, rendering or evaluating.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import overload

VIDEO_SUFFIXES = (".mp4", ".gif")
"""What a video output may be: the renderer writes these, and the commands check for them."""


def _check_writable_folder(folder: Path, option: str, path: Path) -> None:
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as error:
        raise ValueError(f"{option} {path}: cannot write into folder {folder} "
                         f"({error.strerror or error})") from None


@overload
def check_output_file(path: str | Path, option: str, suffixes: Sequence[str]) -> Path: ...


@overload
def check_output_file(path: str | Path | None, option: str,
                      suffixes: Sequence[str]) -> Path | None: ...


def check_output_file(path: str | Path | None, option: str,
                      suffixes: Sequence[str]) -> Path | None:
    """Check a file the command will write; None passes (the output is optional).

    Args:
        path: The path as given.
        option: The option's name for messages, e.g. `--video`.
        suffixes: Allowed file endings, e.g. (".mp4", ".gif").

    Raises:
        ValueError: For an empty path, a folder, another ending, a missing or unwritable folder.
    """
    if path is None:
        return None
    if not str(path).strip():
        raise ValueError(f"{option} is empty; give a file name such as output{suffixes[0]}")
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{option} {path} is a folder; give a file name such as "
                         f"{path / ('output' + suffixes[0])}")
    if path.suffix.lower() not in suffixes:
        raise ValueError(f"{option} {path} must end in {' or '.join(suffixes)}, not "
                         f"{path.suffix or 'nothing'!r}")
    folder = path.parent
    if not folder.is_dir():
        raise ValueError(f"{option} {path}: folder {folder} does not exist")
    _check_writable_folder(folder, option, path)
    return path


def check_output_folder(path: str | Path, option: str) -> Path:
    """Check a folder the command will write into (created later, with its parents, if missing).

    Raises:
        ValueError: For an empty path, an existing file, or a folder that cannot be written.
    """
    if not str(path).strip():
        raise ValueError(f"{option} is empty; give a folder name")
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {path} is a file, not a folder")
    existing = path
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise ValueError(f"{option} {path}: {existing} is a file, not a folder")
    _check_writable_folder(existing, option, path)
    return path
