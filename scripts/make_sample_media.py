"""Make the README's sample media: a rollout video and a summary still of the bundled motor.

The inspection is a fixed set of look-at views around the motor (vprobot.render.demo), so the
media need no planner and come out the same on every run. The lowest views reach below the
motor's equator, where the robot cannot go everywhere: the video shows how unreachable requests
look too.

    python scripts/make_sample_media.py [--out-dir docs/media] [--views 8]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from vprobot.config import load_config
from vprobot.episode import PartScene
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import rotation_about_z
from vprobot.render import render_episode
from vprobot.render.demo import ring_inspection
from vprobot.render.summary import render_summary

OBJECT_YAW_RAD = 0.6
"""Turn the motor a little so that its long axis is not parallel to the camera's view."""
MAX_POLAR_DEG = 130.0
TIME_SCALE = 1.5
"""Slightly slower than real time: at the sample's low frame rate moves would look jerky."""


MEDIA_DIR = Path(__file__).resolve().parent.parent / "docs" / "media"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", type=Path, default=MEDIA_DIR)
    parser.add_argument("--views", type=int, default=8)
    parser.add_argument("--width", type=int, default=480)
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--fps", type=float, default=15.0)
    args = parser.parse_args()
    args.out_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    scene = PartScene.load(load_config(), DEFAULT_MOTOR)
    record = ring_inspection(scene, args.views, rotation_about_z(OBJECT_YAW_RAD), MAX_POLAR_DEG)
    video = render_episode(scene, record, args.out_dir / "rollout.mp4", width=args.width,
                           height=args.height, fps=args.fps, time_scale=TIME_SCALE,
                           progress=True)
    summary = render_summary(scene, record, args.out_dir / "summary.png")
    print(f"coverage {100 * record.coverage:.1f} % with "
          f"{sum(view.reachable for view in record.views)}/{len(record.views)} views reached")
    for path in (video.path, summary):
        print(f"{path}: {path.stat().st_size / 1024:.0f} KiB")
    print(f"{video.frames} frames, {video.duration_s:.1f} s of video, made in "
          f"{time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
