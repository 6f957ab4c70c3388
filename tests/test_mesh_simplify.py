"""Tests of planning dense meshes on a simplified copy, and of the stage progress display."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from vprobot.cli import main
from vprobot.files import progress
from vprobot.files.paths import ASSETS_DIR, CACHE_ENV_VAR
from vprobot.parts import loading as mesh_loading
from vprobot.parts.loading import load_mesh
from vprobot.parts.simplify import simplify

CENTRE = np.array([0.3, -0.2, 0.1])
RADIUS = 0.08


def _sphere(path: Path) -> Path:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=RADIUS)  # 20,480 faces
    sphere.apply_translation(CENTRE)
    sphere.export(path)
    return path


def test_dense_mesh_is_planned_on_a_copy_whose_deviation_matches_a_dense_sampling(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mesh_loading, "SIMPLIFY_ABOVE_FACES", 10_000)
    monkeypatch.setattr(mesh_loading, "SIMPLIFIED_FACES", 2_000)
    loaded = load_mesh(_sphere(tmp_path / "sphere.stl"))
    done = loaded.simplification
    assert done is not None
    assert done.faces_before == 20_480
    assert len(loaded.mesh.faces) == done.faces_after <= 2_000
    assert loaded.mesh.is_watertight
    # The file is placed by the original's box, not the copy's.
    np.testing.assert_allclose(loaded.offset, CENTRE, atol=1e-6)
    # Reference: distances from every original vertex to a dense point sampling of the copy
    # bound the distances to its surface from above, to within the sampling's spacing.
    original = trimesh.creation.icosphere(subdivisions=5, radius=RADIUS).vertices
    samples, _ = trimesh.sample.sample_surface_even(loaded.mesh, 400_000, seed=1)
    spacing = float(np.sqrt(loaded.mesh.area / len(samples)))
    nearest, _ = cKDTree(samples).query(original)
    assert nearest.max() - 2 * spacing <= done.max_deviation_m <= nearest.max() + 1e-12
    # A chord of a 2,000-face sphere lies well within 1 % of the radius of the sphere.
    assert 0 < done.mean_deviation_m <= done.max_deviation_m < 0.01 * RADIUS
    assert "simplified from 20,480 to" in done.describe()


def test_meshes_at_or_below_the_limit_are_used_as_they_are(tmp_path: Path) -> None:
    loaded = load_mesh(_sphere(tmp_path / "sphere.stl"))
    assert loaded.simplification is None
    assert len(loaded.mesh.faces) == 20_480


@pytest.mark.parametrize("faces", [3, 20_480, 30_000])
def test_simplify_refuses_a_face_count_it_cannot_reach(faces: int) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5)
    with pytest.raises(ValueError, match=f"below the mesh's 20,480 faces, got {faces}"):
        simplify(sphere, faces)


def test_stages_are_silent_unless_progress_is_shown(
        capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    assert list(progress.stage("counting", 3, items=range(3))) == [0, 1, 2]
    progress.note("a note")
    assert capsys.readouterr().err == ""
    with progress.showing_progress():
        assert list(progress.stage("counting", 3, items=range(3))) == [0, 1, 2]
        progress.note("a note")
    err = capsys.readouterr().err
    assert "counting: 100%" in err and "3/3" in err
    assert err.rstrip().endswith("a note")
    progress.note("after the block")
    assert capsys.readouterr().err == ""


def test_plan_shows_every_long_stage(tmp_path: Path, capsys: pytest.CaptureFixture,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    # With no delay every stage draws its bar, as a CAD part's minute-long stages do.
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    monkeypatch.setenv(CACHE_ENV_VAR, str(tmp_path / "cache"))
    bracket = ASSETS_DIR / "objects" / "bracket.stl"
    assert main(["plan", "--no-summary", "--mesh", str(bracket), "--views", "1", "--out",
                 str(tmp_path / "plan.json")]) == 0
    err = capsys.readouterr().err
    for stage in ("ground truth", "reachability of the candidates", "visibility"):
        assert f"{stage}: 100%" in err
    progress.note("after the command")
    assert capsys.readouterr().err == ""
