"""The ground-truth cache key covers the robot folder: its scene (floor, fixture plate, pedestal)
and its own base placement (the stand) occlude, so an edited `robot.yaml` or scene must not
reuse a GT built for the old one (raising the UR10's base 0.3 m leaves 117 of the 120 views
measuring the motor instead of 120)."""

from __future__ import annotations

import shutil
from pathlib import Path

import trimesh

from vprobot.config import Config, replace
from vprobot.coverage import ground_truth as gt_module
from vprobot.files.paths import ROBOTS_DIR


def test_ground_truth_key_changes_with_the_robot_folders_placement_and_scene(
        tmp_path: Path) -> None:
    folder = tmp_path / "ur10"
    shutil.copytree(ROBOTS_DIR / "ur10", folder)
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    config = replace(Config(), "cell", robot=str(folder))

    def key() -> str:
        return gt_module._cache_key(box, config)

    first = key()
    description = folder / "robot.yaml"
    description.write_text(description.read_text().replace(
        "base_position_m: [0.0, 0.0, 0.5]", "base_position_m: [0.0, 0.0, 0.8]"))
    raised = key()
    scene = folder / "scene.xml"
    scene.write_text(scene.read_text().replace('size="0.035"', 'size="0.05"'))
    assert len({first, raised, key()}) == 3



def test_ground_truth_key_ignores_the_acquisition_time() -> None:
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    slower = replace(Config(), "sensor", acquisition_time_s=2.0)
    assert gt_module._cache_key(box, slower) == gt_module._cache_key(box, Config())
