"""Make the viewer's picture in the README and docs/viewer.md: `vprobot view`'s page of a plan of
the bundled motor in the realistic cell, opened in headless Chromium (Debian's, driven by
Playwright, as the browser tests do), paused halfway through the cycle.

    python scripts/make_viewer_picture.py [--out docs/media/viewer.png]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

from vprobot.benchmarks.viewer import CHROMIUM_ARGS, PAUSE_ICON, TIME_FIELD
from vprobot.cli import main as vprobot
from vprobot.files.paths import CONFIGS_DIR

MEDIA_DIR = Path(__file__).resolve().parent.parent / "docs" / "media"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=MEDIA_DIR / "viewer.png")
    args = parser.parse_args()
    executable = shutil.which("chromium")
    if executable is None:
        raise SystemExit("needs Chromium (Debian: apt-get install chromium)")
    with tempfile.TemporaryDirectory() as folder:
        plan, page_file = Path(folder) / "plan.json", Path(folder) / "plan.html"
        assert vprobot(["plan", "--config", str(CONFIGS_DIR / "cell_real.yaml"), "--out",
                        str(plan), "--no-summary"]) == 0
        assert vprobot(["view", str(plan), "--html", str(page_file)]) == 0
        with sync_playwright() as driver:
            browser = driver.chromium.launch(executable_path=executable,
                                             args=list(CHROMIUM_ARGS))
            page = browser.new_page(viewport={"width": 1200, "height": 720})
            page.goto(page_file.as_uri())
            field = page.locator(TIME_FIELD)
            field.wait_for()
            page.get_by_role("button").filter(
                has=page.locator(PAUSE_ICON)).click()
            field.fill("5")
            field.press("Enter")
            # The software-rendering notice of a browser without a GPU is not the viewer's.
            page.locator(".mantine-Notification-closeButton").click()
            page.get_by_role("button", name="Show scene tree").click()
            page.wait_for_timeout(1500)
            page.screenshot(path=str(args.out))
            browser.close()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
