"""`vprobot view` without a browser: the shapes it draws, its recording, its inputs and errors,
the evaluated plans it replays; and the video's close-up of the part (issue 48).
tests/test_viewer_browser.py opens the pages in Chromium."""

from __future__ import annotations

import csv
import json
import math
import socket
from pathlib import Path

import mujoco
import numpy as np
import pytest

from vprobot.cli import main
from vprobot.config import load_config
from vprobot.evaluation import EPISODES_NAME, plan_path
from vprobot.render import episode_from_plan
from vprobot.render.closeup import PartCloseUp
from vprobot.render.markers import COVERED_RGBA
from vprobot.render.page import PAGE_FPS, geom_surface, plan_page

SHAPES = """
<mujoco><worldbody><body pos="0.3 -0.2 0.1" quat="0.9 0.1 0.3 0.2">
  <geom name="box" type="box" size="0.1 0.2 0.05" pos="0.1 0 0" quat="0.7 0.7 0 0"/>
  <geom name="sphere" type="sphere" size="0.07" pos="0 0.1 0"/>
  <geom name="cylinder" type="cylinder" size="0.05 0.12"/>
  <geom name="capsule" type="capsule" size="0.04 0.1" pos="0 0 0.2"/>
  <geom name="ellipsoid" type="ellipsoid" size="0.03 0.05 0.08" pos="-0.1 0 0"/>
</body></worldbody></mujoco>
"""


@pytest.mark.parametrize(("name", "volume", "tolerance"), [
    ("box", 8 * 0.1 * 0.2 * 0.05, 1e-9),
    # Polygon and icosphere approximations fall short of the curved solids by a little.
    ("sphere", 4 / 3 * math.pi * 0.07 ** 3, 0.03),
    ("cylinder", math.pi * 0.05 ** 2 * 0.24, 0.01),
    ("capsule", math.pi * 0.04 ** 2 * 0.2 + 4 / 3 * math.pi * 0.04 ** 3, 0.02),
    ("ellipsoid", 4 / 3 * math.pi * 0.03 * 0.05 * 0.08, 0.03),
])
def test_each_geom_is_drawn_as_a_closed_surface_of_its_volume_where_mujoco_puts_it(
        name: str, volume: float, tolerance: float) -> None:
    model = mujoco.MjModel.from_xml_string(SHAPES)
    geom = model.geom(name).id
    surface = geom_surface(model, geom)
    assert surface is not None and surface.is_watertight
    assert surface.volume == pytest.approx(volume, rel=tolerance)
    # In the body's frame: the centre of a symmetric solid is the geom's position there.
    np.testing.assert_allclose(surface.center_mass, model.geom_pos[geom], atol=1e-6)


@pytest.fixture(scope="module")
def plans(default_plans: dict[str, Path]) -> dict[str, Path]:
    """A plan of the bundled motor with the UR10 in the loop, and one with a free sensor
    (conftest's `default_plans`, shared with tests/test_viewer_browser.py)."""
    return default_plans


def test_the_page_records_the_robots_timed_cycle(plans: dict[str, Path]) -> None:
    scene, record = episode_from_plan(load_config(), plans["robot"])
    page = plan_page(scene, record, "robot")
    timed = record.timed
    assert timed is not None
    # Sampled at PAGE_FPS, each hold rounded to whole samples.
    slack = (len(record.views) + 2) / PAGE_FPS
    assert page.duration_s == pytest.approx(timed.duration_s, abs=slack)
    assert page.views == len(record.views)
    assert "<script>window.__VISER_EMBED_DATA__=" in page.html
    assert f"cycle time {timed.cycle.total_s:.2f} s" in page.html
    free_scene, free_record = episode_from_plan(load_config(), plans["free"])
    assert plan_page(free_scene, free_record, "free").duration_s == 0.0


def test_view_writes_a_page_and_refuses_bad_input_in_one_line(
        plans: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    page = tmp_path / "plan.html"
    assert main(["view", str(plans["robot"]), "--html", str(page)]) == 0
    assert "views" in capsys.readouterr().out and page.stat().st_size > 100_000
    moved = tmp_path / "moved.json"
    document = json.loads(plans["robot"].read_text())
    moved.write_text(json.dumps({**document, "object": {**document["object"],
                                                        "mesh": "gone.stl"}}))
    (tmp_path / "broken.json").write_text("{not json")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        cases = [
            ([str(moved)], "object mesh gone.stl not found"),
            ([str(tmp_path / "broken.json")], "cannot read plan"),
            ([str(tmp_path / "none.json")], "does not exist"),
            ([str(plans["robot"]), "--port", str(port)], f"cannot serve on 127.0.0.1:{port}"),
            ([str(plans["robot"]), "--html", str(tmp_path / "page.htm")], "must end in .html"),
            ([str(plans["robot"]), "--episode", "0"], "--episode choose an episode of an "
                                                      "evaluation folder"),
            ([str(tmp_path)], "give an evaluation folder with --episode and --planner"),
        ]
        for argv, message in cases:
            assert main(["view", *argv]) == 2, argv
            err = capsys.readouterr().err
            assert message in err and err.count("\n") == 1, (argv, err)
    with pytest.raises(SystemExit):
        main(["view", str(plans["robot"]), "--port", "70000"])
    assert "a port in 0..65535" in capsys.readouterr().err
    assert sorted(path.name for path in tmp_path.iterdir()) == ["broken.json", "moved.json",
                                                               "plan.html"]


def test_an_evaluation_keeps_each_episodes_plan_which_replays_to_its_row(
        serial_evaluation: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    with (serial_evaluation / EPISODES_NAME).open(newline="") as stream:
        rows = list(csv.DictReader(stream))
    config = load_config()
    for row in rows:
        path = plan_path(serial_evaluation, int(row["episode"]), row["carrier"], row["planner"])
        document = json.loads(path.read_text())
        assert document["planner"] == row["planner"] and "ground_truth" not in document
    # The replay acquires every view again and scores it anew: the row's coverage.
    for row in rows[:2]:
        path = plan_path(serial_evaluation, int(row["episode"]), row["carrier"], row["planner"])
        _, record = episode_from_plan(config, path)
        assert 100.0 * record.coverage == pytest.approx(float(row["coverage_pct"]), abs=1e-9)
    row = rows[0]
    page = tmp_path / "episode.html"
    assert main(["view", str(serial_evaluation), "--episode", row["episode"], "--planner",
                 row["planner"], "--carrier", row["carrier"], "--html", str(page)]) == 0
    assert page.stat().st_size > 100_000
    capsys.readouterr()
    assert main(["view", str(serial_evaluation), "--episode", "0", "--planner", "bscp"]) == 2
    assert ("has no plan of planner 'bscp' on episode 0 (robot); its planners there: hrec, "
            "random2") in capsys.readouterr().err


def test_the_videos_close_up_shows_the_part_large_and_greens_what_the_views_so_far_covered(
        plans: dict[str, Path]) -> None:
    scene, record = episode_from_plan(load_config(), plans["robot"])
    data = scene.cell.make_data()
    scene.cell.place_object(data, record.object_pose.rotation)
    close_up = PartCloseUp(scene.cell, data, record, 160)
    try:
        green = np.round(255 * COVERED_RGBA[:3]).astype(int)

        def covered_pixels(views: int) -> int:
            image = close_up.render(views).astype(int)
            return int(np.count_nonzero(np.all(np.abs(image - green) < 40, axis=2)))

        before, after = covered_pixels(0), covered_pixels(len(record.views))
        background = close_up.render(0)[0, 0]
        part = np.any(close_up.render(0) != background, axis=2)
        rows, columns = np.nonzero(part)
    finally:
        close_up.close()
    assert before == 0 and after > 0
    # The part, not the cell: its silhouette spans most of the picture.
    assert np.ptp(rows) > 0.6 * 160 or np.ptp(columns) > 0.6 * 160
