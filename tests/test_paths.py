"""The one name-or-path resolver."""

from __future__ import annotations

from pathlib import Path

import pytest

from vprobot.files.paths import bundled_or_path


def test_bundled_name_then_existing_path_then_a_clear_error(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    bundled_file = tmp_path / "bundled.yaml"
    own = tmp_path / "own.yaml"
    own.write_text("")
    (tmp_path / "folder").mkdir()
    monkeypatch.chdir(tmp_path)
    # A local file of the bundled name does not shadow the bundled one.
    (tmp_path / "cpu").write_text("")
    bundled = {"cpu": bundled_file, "gpu": bundled_file}
    assert bundled_or_path("cpu", bundled, "profile") == bundled_file
    assert bundled_or_path(str(own), bundled, "profile") == own
    assert bundled_or_path("folder", bundled, "robot", "robot folder") == Path("folder")
    with pytest.raises(ValueError, match=r"unknown robot 'own\.yaml': neither a bundled robot "
                                         r"\(cpu, gpu\) nor a robot folder"):
        bundled_or_path("own.yaml", bundled, "robot", "robot folder")
    with pytest.raises(ValueError, match=r"unknown profile 'folder': .* nor a file"):
        bundled_or_path("folder", bundled, "profile")
