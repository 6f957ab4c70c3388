"""`vprobot view`'s pages in a real browser: Debian's Chromium, driven by Playwright (.ci/run
installs Chromium; on a machine without it these tests are skipped, except under CI, where they
fail). Headless Chromium without a GPU draws WebGL with SwiftShader."""

from __future__ import annotations

import io
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vprobot.benchmarks.viewer import CHROMIUM_ARGS, PAUSE_ICON, TIME_FIELD, TWO_FRAMES
from vprobot.cli import main
from vprobot.config import load_config
from vprobot.episode import EpisodeRecord, PartScene
from vprobot.render import episode_from_plan

playwright = pytest.importorskip("playwright.sync_api")

VIEWPORT = {"width": 800, "height": 600}


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    executable = shutil.which("chromium")
    if executable is None:
        message = "no Chromium on this machine (Debian: apt-get install chromium)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    with playwright.sync_playwright() as driver:
        launched = driver.chromium.launch(executable_path=executable, args=list(CHROMIUM_ARGS),
                                          headless=True)
        yield launched
        launched.close()


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory, default_plans: dict[str, Path]
          ) -> dict[str, Path]:
    """Plans of the bundled motor (the UR10 in the loop; a free sensor: conftest's
    `default_plans`, shared with tests/test_viewer.py) and their pages."""
    folder = tmp_path_factory.mktemp("pages")
    made = {}
    for carrier in ("robot", "free"):
        plan = default_plans[carrier]
        assert main(["view", str(plan), "--html", str(folder / f"{carrier}.html")]) == 0
        made[carrier], made[f"{carrier}.html"] = plan, folder / f"{carrier}.html"
    return made


class Opened:
    """A page open in the browser, with what it logged and asked for."""

    def __init__(self, browser: object, url: str):
        self.page = browser.new_page(viewport=VIEWPORT)  # type: ignore[attr-defined]
        self.errors: list[str] = []
        self.requests: list[str] = []
        self.page.on("console", lambda message: self.errors.append(message.text)
                     if message.type == "error" else None)
        self.page.on("pageerror", lambda error: self.errors.append(str(error)))
        self.page.on("request", lambda request: self.requests.append(request.url))
        self.nodes: list[str] = []
        self.page.goto(url)
        self.page.wait_for_selector("canvas")

    def pause(self) -> None:
        """Stop the playback: a playing recording redraws every frame, which in software
        takes the browser's time (a screenshot waits seconds for a still frame)."""
        self.page.get_by_role("button").filter(
            has=self.page.locator(PAUSE_ICON)).click()

    def canvas(self) -> np.ndarray:
        # A screenshot of the page, cut to the canvas: an element's screenshot first waits for
        # the element to hold still, seconds in a redrawing WebGL page.
        box = self.page.locator("canvas").first.bounding_box()
        assert box is not None
        png = self.page.screenshot(clip=box)
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)

    def scene_nodes(self, *expand: str) -> list[str]:
        """The names in the page's scene tree, with the nodes `expand` opened."""
        self.page.get_by_role("button", name="Show scene tree").click()
        panel = self.page.locator("[data-playback-scene-tree]")
        panel.locator('[data-scene-node="/views"]').wait_for()
        for node in expand:
            # The row's first part is its caret.
            panel.locator(f'[data-scene-node="{node}"] > div').first.click()
        panel.locator(f'[data-scene-node^="{expand[-1]}/"]').first.wait_for()
        return panel.locator("[data-scene-node]").evaluate_all(
            "rows => rows.map(row => row.dataset.sceneNode)")

    def at_time(self, seconds: float) -> np.ndarray:
        """The canvas with the playback at `seconds` (typed into the playback bar's field)."""
        field = self.page.locator(TIME_FIELD)
        field.fill(f"{seconds}")
        field.press("Enter")
        self.drawn()
        return self.canvas()

    def settle(self) -> None:
        """Move the mouse off the controls and wait for the tooltips it raised to go (a tooltip
        that fades in between two screenshots is a change in them)."""
        self.page.mouse.move(1, 1)
        self.page.wait_for_timeout(1000)
        self.drawn()

    def drawn(self) -> None:
        """Wait until the browser has drawn what changed (two animation frames later)."""
        self.page.evaluate(TWO_FRAMES)


BLOCK_PX = 8
"""Pictures are compared by blocks of this many pixels a side: now and then the whole picture
shifts by under a pixel between two screenshots (the edges of still objects change), which a
block's mean does not show, while a link that moves changes whole blocks."""


def _changed_blocks(first: np.ndarray, second: np.ndarray) -> int:
    """Blocks of `BLOCK_PX` whose mean colour differs by more than 30 (of 765) between two
    pictures."""
    def means(picture: np.ndarray) -> np.ndarray:
        rows, columns = (size // BLOCK_PX * BLOCK_PX for size in picture.shape[:2])
        return picture[:rows, :columns].reshape(
            rows // BLOCK_PX, BLOCK_PX, columns // BLOCK_PX, BLOCK_PX, 3).mean(axis=(1, 3))

    return int(np.count_nonzero(np.abs(means(first) - means(second)).sum(axis=2) > 30))


@pytest.fixture(scope="module")
def robot_page(browser: object, pages: dict[str, Path]) -> Iterator[Opened]:
    """The robot plan's page, opened once for the tests below (a load costs seconds in
    software), paused, its scene tree open with the cell, the robot and the views expanded."""
    opened = Opened(browser, pages["robot.html"].as_uri())
    opened.pause()
    opened.nodes = opened.scene_nodes("/cell", "/robot", "/views")
    opened.settle()
    yield opened
    opened.page.close()


@pytest.fixture(scope="module")
def robot_episode(pages: dict[str, Path]) -> tuple[PartScene, EpisodeRecord]:
    return episode_from_plan(load_config(), pages["robot"])


def test_the_page_loads_offline_without_console_errors_and_draws(
        robot_page: Opened, pages: dict[str, Path]) -> None:
    assert robot_page.errors == []
    # Self-contained: the page itself is all it asks for.
    assert robot_page.requests == [pages["robot.html"].as_uri()]
    pixels = robot_page.canvas()
    colours = np.unique(pixels.reshape(-1, 3), axis=0)
    assert len(colours) > 100 and pixels.std() > 10
    assert "cycle time" in robot_page.page.locator("#vprobot-caption").inner_text()


def test_the_scene_holds_the_robot_the_part_and_one_frustum_per_view(
        robot_page: Opened, robot_episode: tuple[PartScene, EpisodeRecord]) -> None:
    scene, record = robot_episode
    model = scene.cell.model
    # Every body that carries one of the robot's joints, and the sensor.
    moved = {model.body(model.jnt_bodyid[joint]).name for joint in range(model.njnt)}
    assert {f"/robot/{name}" for name in (*moved, "sensor_body")} <= set(robot_page.nodes)
    assert "/cell/object" in robot_page.nodes
    views = [node for node in robot_page.nodes if re.fullmatch(r"/views/\d+", node)]
    assert views == [f"/views/{number}" for number in range(1, len(record.views) + 1)]


def test_moving_the_slider_moves_the_robot_and_nothing_else(
        robot_page: Opened, robot_episode: tuple[PartScene, EpisodeRecord]) -> None:
    _, record = robot_episode
    timed = record.timed
    assert timed is not None
    # Halfway through the approach to the first view the arm is on its way.
    moving = timed.acquisitions[0].start_s / 2.0
    start, again = robot_page.at_time(0.0), robot_page.at_time(0.0)
    halfway = robot_page.at_time(moving)
    assert _changed_blocks(start, again) == 0
    assert _changed_blocks(start, halfway) > 20
    # With the robot hidden the same two times look alike: what moved was the robot.
    robot_page.page.locator('[data-scene-node="/robot"] .tabler-icon-eye').first.click()
    robot_page.settle()
    assert _changed_blocks(robot_page.at_time(0.0), robot_page.at_time(moving)) == 0


def test_a_free_flying_plan_shows_the_sensor_poses_only(
        browser: object, pages: dict[str, Path]) -> None:
    _, record = episode_from_plan(load_config(), pages["free"])
    opened = Opened(browser, pages["free.html"].as_uri())
    nodes = opened.scene_nodes("/views")
    assert not any(node.startswith("/robot") for node in nodes)
    assert len([node for node in nodes if re.fullmatch(r"/views/\d+", node)]) == len(
        record.views)
    assert opened.errors == []
    opened.page.close()


def test_view_serves_the_page_on_the_loopback_address_it_prints(
        browser: object, pages: dict[str, Path]) -> None:
    server = subprocess.Popen([sys.executable, "-m", "vprobot.cli", "view", str(pages["robot"]),
                               "--port", "0"], stdout=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None
        line = server.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:\d+/", line)
        assert url is not None, line
        opened = Opened(browser, url.group())
        opened.pause()
        assert opened.errors == [] and opened.canvas().std() > 10
        opened.page.close()
    finally:
        server.terminate()
        server.wait(timeout=30)
