"""Viewer benchmark: the page of a 10-view plan, written by `vprobot view --html`, and opened,
drawn and scrubbed in headless Chromium (Debian's, driven by Playwright) without a GPU."""

from __future__ import annotations

import io
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from vprobot.config import Config
from vprobot.episode import PartScene
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.plan import episode_document, write_json
from vprobot.render.demo import ring_inspection

VIEWS = 10
TARGET_WRITE_S = 5.0
TARGET_LOAD_S = 3.0
SEEKS = 10
RUNS = 3
"""Writes and loads timed (the median is the figure)."""
TWO_FRAMES = ("() => new Promise(done => requestAnimationFrame(() => "
              "requestAnimationFrame(done)))")
"""Resolves once the browser has drawn two frames: the state before it is on screen."""
CHROMIUM_ARGS = ("--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", "--disable-quic")
"""Headless Chromium without a GPU (WebGL in SwiftShader) on a machine with no network."""
VIEWPORT_PX = (1280, 720)
TIME_FIELD = "input.mantine-NumberInput-input"
PAUSE_ICON = ".tabler-icon-player-pause-filled"
"""The playback bar's time field and pause button's icon in viser's client (its DOM), which
the benchmark, the browser tests and the README's picture drive."""


def _browser_page(html: Path, duration_s: float) -> dict[str, Any]:
    """Open `html` in headless Chromium: the time until the scene is drawn, and the time of
    one scrub (a time typed into the playback bar, until the browser has drawn it) across the
    recording's `duration_s`."""
    try:
        from playwright.sync_api import sync_playwright  # the test extra's; optional here
    except ImportError:
        raise ValueError("the viewer benchmark drives Chromium with playwright: pip install "
                         "playwright (the test extra)") from None
    executable = shutil.which("chromium")
    if executable is None:
        raise ValueError("the viewer benchmark needs Chromium (Debian: apt-get install chromium)")
    with sync_playwright() as driver:
        browser = driver.chromium.launch(executable_path=executable, args=list(CHROMIUM_ARGS))
        page = browser.new_page(viewport={"width": VIEWPORT_PX[0], "height": VIEWPORT_PX[1]})
        loads = []
        for _ in range(RUNS):
            start = time.perf_counter()
            page.goto(html.as_uri())
            # The playback bar appears once the embedded recording is decoded and its scene
            # built; two animation frames later the browser has drawn it.
            page.locator(TIME_FIELD).wait_for()
            page.evaluate(TWO_FRAMES)
            loads.append(time.perf_counter() - start)
            pixels = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("L"))
            # The cell drawn: the empty canvas is one flat colour behind the caption.
            if pixels.std() <= 20.0:
                raise RuntimeError(f"the page of {html} drew no cell (pixel spread "
                                   f"{pixels.std():.1f})")
        page.get_by_role("button").filter(
            has=page.locator(PAUSE_ICON)).click()
        field = page.locator(TIME_FIELD)
        seeks = []
        for fraction in np.linspace(0.05, 0.95, SEEKS):
            begin = time.perf_counter()
            field.fill(f"{fraction * duration_s:.2f}")
            field.press("Enter")
            page.evaluate(TWO_FRAMES)
            seeks.append(time.perf_counter() - begin)
        browser.close()
    return {"page_load_s_median": statistics.median(loads), "page_load_s_max": max(loads),
            "scrub_frame_s_median": statistics.median(seeks),
            "scrub_frame_s_max": max(seeks)}


def run_viewer_benchmark(config: Config) -> dict[str, Any]:
    """Measure the viewer's targets on a 10-view plan of the bundled motor in `config`'s cell.

    Returns:
        `view_html_s_median` (the whole `vprobot view --html` command, in a new process),
        `page_bytes`, `page_load_s_median` (from opening the file to the cell drawn: the
        playback bar shown and two frames drawn after it), their largest of `RUNS`, the scrub
        times, the targets and whether they are met.
    """
    scene = PartScene.load(config, DEFAULT_MOTOR)
    record = ring_inspection(scene, VIEWS)
    timed = record.timed
    with tempfile.TemporaryDirectory() as folder:
        plan, html = Path(folder) / "plan.json", Path(folder) / "plan.html"
        write_json(plan, episode_document(scene, record))
        writes = []
        for _ in range(RUNS):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "vprobot.cli", "view", str(plan), "--html",
                            str(html)], check=True, capture_output=True)
            writes.append(time.perf_counter() - start)
        cycle_s = 0.0 if timed is None else timed.duration_s
        results: dict[str, Any] = {
            "views": len(record.views), "view_html_s_median": statistics.median(writes),
            "view_html_s_max": max(writes),
            "page_bytes": html.stat().st_size, **_browser_page(html, cycle_s),
            "target_write_s": TARGET_WRITE_S, "target_load_s": TARGET_LOAD_S,
        }
    results["write_met"] = results["view_html_s_median"] <= TARGET_WRITE_S
    results["load_met"] = results["page_load_s_median"] <= TARGET_LOAD_S
    return results
