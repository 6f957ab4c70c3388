"""Shared test setup: vprobot's caches (ground truth, generated objects) go into one temporary
folder per test session, shared by every test and by the processes they start, never into
the user's ~/.cache. Tests that need a cache of their own set `VPROBOT_CACHE_DIR` themselves.
Expensive results that several test modules compare against are made once per session here."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import SERIAL_EVALUATION

from vprobot.paths import CACHE_ENV_VAR


@pytest.fixture(scope="session", autouse=True)
def session_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    folder = tmp_path_factory.mktemp("vprobot-cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(CACHE_ENV_VAR, str(folder))
        yield folder


@pytest.fixture(scope="session")
def serial_evaluation(session_cache: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder of the tables of `SERIAL_EVALUATION`, run in this process."""
    from vprobot.cli import main

    folder = tmp_path_factory.mktemp("serial-evaluation")
    assert main([*SERIAL_EVALUATION, "--out", str(folder)]) == 0
    return folder
