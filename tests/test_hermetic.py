"""The test fixtures keep every file a test makes inside pytest's temporary folders."""

from __future__ import annotations

from pathlib import Path

import pytest

import vprobot.coverage.ground_truth as gt_module
from vprobot.cli import main
from vprobot.config import load_config
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.parts.loading import load_mesh


def test_a_plan_writes_nothing_into_home_and_caches_into_the_session_folder(
        tmp_path: Path, session_cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`vprobot plan` with HOME an empty folder (and no XDG folders to fall back on) leaves
    HOME empty, writes only its plan into the working folder, and stores its ground truth in
    the session cache of conftest.py, where the default location would be under HOME."""
    home, work = tmp_path / "home", tmp_path / "work"
    home.mkdir()
    work.mkdir()
    monkeypatch.setenv("HOME", str(home))
    for name in ("XDG_CACHE_HOME", "XDG_CONFIG_HOME", "XDG_DATA_HOME"):
        monkeypatch.delenv(name, raising=False)
    assert Path.home() == home
    monkeypatch.chdir(work)
    config = tmp_path / "small.yaml"
    config.write_text("sensor:\n  resolution: [107, 75]\n")
    # Not from memory: the plan reads its ground truth from the disk cache, or writes it there.
    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})

    assert main(["plan", "--config", str(config), "--out", "plan.json", "--no-timing"]) == 0

    assert not list(home.rglob("*"))
    assert sorted(path.name for path in work.iterdir()) == ["plan.json", "plan.png"]
    key = gt_module._cache_key(load_mesh(DEFAULT_MOTOR).mesh, load_config(config))
    assert (session_cache / "ground_truth" / f"{key}.npz").is_file()
