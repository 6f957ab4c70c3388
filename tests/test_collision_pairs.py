"""The robots' collision model hides no collision: only adjacent links go unchecked, never the
sensor, and the pairs MuJoCo skips are measured independently (`mj_geomDistance` ignores every
filter) in sampled configurations."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import mujoco
import numpy as np
import pytest

from vprobot.cell.scene import Cell
from vprobot.cli import main
from vprobot.config import load_config, replace
from vprobot.kinematics.collision import CollisionChecker
from vprobot.robots.description import SENSOR_BODY

SAMPLES = 200
OVERLAP_TOLERANCE_M = 0.001
DISTANCE_CAP_M = 0.01
"""`mj_geomDistance` stops looking beyond this distance; only overlaps matter here."""

ROBOT_DATA = Path(str(importlib.metadata.distribution("example-robot-data").locate_file(
    "cmeel.prefix/share/example-robot-data/robots")))


def bundled_cell(robot: str) -> Cell:
    return Cell(replace(load_config(), "cell", robot=robot))


def link(model: mujoco.MjModel, geom: int) -> int:
    """The rigid link a geom moves with: its body's weld body (bodies joined by fixed joints
    are one link)."""
    return int(model.body_weldid[model.geom_bodyid[geom]])


def adjacent(model: mujoco.MjModel, link1: int, link2: int) -> bool:
    """Whether one link turns on the other through a single joint."""
    def parent(body: int) -> int:
        return int(model.body_weldid[model.body_parentid[body]])
    return parent(link1) == link2 or parent(link2) == link1


def skipped(model: mujoco.MjModel, geom1: int, geom2: int) -> bool:
    """Whether MuJoCo's collision detection never looks at this pair of geoms on different
    links: its collision bits, an <exclude> of the bodies, or the parent filter."""
    body1, body2 = sorted((int(model.geom_bodyid[geom1]), int(model.geom_bodyid[geom2])))
    if not (model.geom_contype[geom1] & model.geom_conaffinity[geom2]
            or model.geom_contype[geom2] & model.geom_conaffinity[geom1]):
        return True
    if (body1 << 16) + body2 in set(model.exclude_signature.tolist()):
        return True
    filter_parent = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    link1, link2 = link(model, geom1), link(model, geom2)
    return bool(filter_parent and link1 and link2 and adjacent(model, link1, link2))


def skipped_pairs(model: mujoco.MjModel, geoms: np.ndarray) -> list[tuple[int, int]]:
    """The geom pairs on different links that MuJoCo never collides."""
    return [(g1, g2) for i, g1 in enumerate(geoms) for g2 in geoms[i + 1:]
            if link(model, g1) != link(model, g2) and skipped(model, g1, g2)]


def sensor_geoms(model: mujoco.MjModel, geoms: np.ndarray) -> set[int]:
    return {g for g in geoms if model.body(model.geom_bodyid[g]).name == SENSOR_BODY}


def sampled_configurations(cell: Cell, count: int = SAMPLES) -> np.ndarray:
    return np.random.default_rng(0).uniform(cell.joints.lower, cell.joints.upper,
                                            size=(count, cell.joints.dof))


def distance(model: mujoco.MjModel, data: mujoco.MjData, geom1: int, geom2: int) -> float:
    return float(mujoco.mj_geomDistance(model, data, geom1, geom2, DISTANCE_CAP_M, None))


def names(model: mujoco.MjModel, pair: tuple[int, int]) -> tuple[str, str]:
    return (model.body(model.geom_bodyid[pair[0]]).name,
            model.body(model.geom_bodyid[pair[1]]).name)


@pytest.mark.parametrize("robot", ["ur10", "ur5", "panda"])
def test_no_unchecked_pair_but_adjacent_links_ever_overlaps_by_more_than_1_mm(robot: str) -> None:
    cell = bundled_cell(robot)
    model, data = cell.model, mujoco.MjData(cell.model)
    geoms = cell.robot_geom_ids
    pairs = skipped_pairs(model, geoms)
    assert not [names(model, pair) for pair in pairs
                if sensor_geoms(model, geoms) & set(pair)], "the sensor goes unchecked"
    distal = [pair for pair in pairs
              if not adjacent(model, link(model, pair[0]), link(model, pair[1]))]
    deepest = dict.fromkeys(distal, 0.0)
    for q in sampled_configurations(cell):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for pair in distal:
            deepest[pair] = min(deepest[pair], distance(model, data, *pair))
    assert not {names(model, pair): round(depth, 4) for pair, depth in deepest.items()
                if depth < -OVERLAP_TOLERANCE_M}


def test_the_panda_housing_inside_link5_is_a_collision() -> None:
    # The housing overlaps link 5 in some configurations within the joint limits (about 7 %
    # of uniform samples): each is a collision the checker reports by name.
    cell = bundled_cell("panda")
    model, checker = cell.model, CollisionChecker(cell)
    data = mujoco.MjData(model)
    housing = model.geom("sensor_housing").id
    link5 = next(g for g in cell.robot_geom_ids
                 if model.body(model.geom_bodyid[g]).name == "panda_link5")
    inside = 0
    for q in sampled_configurations(cell):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        if distance(model, data, housing, link5) < -OVERLAP_TOLERANCE_M:
            inside += 1
            assert {"panda_link5", SENSOR_BODY} in map(set, checker.colliding_pairs(q))
    assert inside >= 5


def test_the_panda_starts_with_its_housing_clear_of_every_link() -> None:
    cell = bundled_cell("panda")
    model, data = cell.model, cell.make_data()
    mujoco.mj_kinematics(model, data)
    housing = model.geom("sensor_housing").id
    others = [g for g in cell.robot_geom_ids if link(model, g) != link(model, housing)]
    assert min(distance(model, data, housing, g) for g in others) > 0.005
    assert not CollisionChecker(cell).in_collision(data.qpos.copy())


def test_an_imported_arm_checks_its_sensor_against_every_link(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # At the Panda's zero pose (joint 4 at its limit, joint 6 at 0) the housing lies beside
    # link 5: an import must not exclude that pair, nor let the parent filter skip the link
    # the flange turns on.
    out = tmp_path / "arm"
    code = main(["robots", "import", str(ROBOT_DATA / "panda_description" / "urdf" / "panda.urdf"),
                 "--flange", "panda_link8", "--name", "arm", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    cell = Cell(replace(load_config(), "cell", robot=str(out)))
    geoms = cell.robot_geom_ids
    sensor = sensor_geoms(cell.model, geoms)
    assert sensor and not [names(cell.model, pair) for pair in skipped_pairs(cell.model, geoms)
                           if sensor & set(pair)]
