"""Draw one acquisition under both sensing models into docs/media/sensing.png (README).

The bundled motor stands in the cell with the Zivid 2+ MR60 preset on the UR10; the robot
reaches one look-at view at the working distance, and the sensor measures from there under
`ideal` and under `structured_light` (docs/sensor.md#sensing). The panels are the camera image:
the ideal frame's depth, the structured-light frame's depth, and which ideal points the
structured-light model lost and why, as `DepthSensor.losses_at` tells the causes apart (the
projector's shadow, the incidence limits, the dropout; docs/sensor.md#sensing) and in the
colours the renderer draws them in. Nothing is random between runs.

    python scripts/make_sensing_picture.py [--resolution 612 512] [--out docs/media/sensing.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import LOSS_CAUSES, Acquisition, DepthSensor, FrameLosses
from vprobot.config import load_config, with_sensor
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import Pose, rotation_about_z
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.kinematics.collision import CollisionChecker
from vprobot.parts.loading import load_mesh
from vprobot.render.markers import LOST_RGBA
from vprobot.sensing import StructuredLight

OUT = Path(__file__).resolve().parent.parent / "docs" / "media" / "sensing.png"
PRESET = "zivid2plus_mr60"
RESOLUTION = (612, 512)
"""A quarter of the Zivid's 2448 x 2048 along each axis, as the sensing study uses."""
OBJECT_YAW_RAD = 0.6
"""Turn the motor a little so that its long axis is not parallel to the camera's view."""
POLAR_DEG = 55.0
"""The view's angle from straight above: the motor's top and one side at once."""
AZIMUTHS_DEG = (120.0, 90.0, 150.0)
"""Azimuths tried in turn, the first one the robot reaches drawn: 120 deg looks at the motor
from the side away from the robot, which hides none of it there."""
CAUSES = ("projector shadow", "beyond an incidence limit", "dropout")
"""The legend's words for `LOSS_CAUSES`, in its order."""
KEPT_COLOUR = "#e4e4e4"


def _reached_view(cell: Cell, rotation: np.ndarray) -> tuple[Pose, np.ndarray, float]:
    """The sensor pose and joints of the first look-at view the robot reaches, and its
    azimuth (degrees)."""
    arm = RobotArm(cell)
    collisions = CollisionChecker(cell, rotation)
    center = cell.object_center
    distance = cell.config.sensor.working_distance_m
    polar = np.deg2rad(POLAR_DEG)
    for azimuth in AZIMUTHS_DEG:
        a = np.deg2rad(azimuth)
        direction = np.array([np.sin(polar) * np.cos(a), np.sin(polar) * np.sin(a),
                              np.cos(polar)])
        target = SensorTarget.look_at(center + distance * direction, center)
        result = arm.reach(target, cell.joints.start, collisions)
        if result.reachable:
            return arm.fk(result.q), result.q, azimuth
    raise RuntimeError(f"the robot reaches none of the azimuths {AZIMUTHS_DEG}")


def _depth_image(acquisition: Acquisition, resolution: tuple[int, int]) -> np.ndarray:
    """The frame's depth along the optical axis per pixel (NaN where nothing was measured)."""
    width, height = resolution
    image = np.full(width * height, np.nan)
    image[acquisition.pixels] = ((acquisition.points_world - acquisition.sensor_pose.position)
                                 @ acquisition.sensor_pose.rotation[:, 2])
    return image.reshape(height, width)


def acquire_frames(resolution: tuple[int, int]
                   ) -> tuple[FrameLosses, Acquisition, float, StructuredLight]:
    """What the picture's view lost to the structured-light model and why, its frame under the
    model, the view's azimuth (degrees) and the preset's model."""
    config = with_sensor(load_config(), PRESET)
    model = config.sensor.sensing_model
    if not isinstance(model, StructuredLight):
        raise ValueError(f"{PRESET} must default to structured light, got {model.name}")
    cell = Cell(config, load_mesh(DEFAULT_MOTOR).mesh)
    rotation = rotation_about_z(OBJECT_YAW_RAD)
    pose, joints, azimuth = _reached_view(cell, rotation)
    sensor = DepthSensor(cell, resolution=resolution, sensing=model)
    return (sensor.losses_at(pose, rotation, joints), sensor.acquire_at(pose, rotation, joints),
            azimuth, model)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, nargs=2, default=RESOLUTION,
                        metavar=("WIDTH", "HEIGHT"))
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    resolution = tuple(args.resolution)
    losses, measured, azimuth, model = acquire_frames(resolution)
    ideal = losses.ideal
    width, height = resolution
    lost = np.full(width * height, np.nan)
    lost[ideal.pixels] = losses.cause + 1  # kept (0) drawn pale, for the motor's outline
    counts = [losses.counts()[cause] for cause in LOSS_CAUSES]

    # The motor fills a part of the frame: the panels show the box around its ideal points.
    rows, columns = np.divmod(ideal.pixels, width)
    margin = 10
    crop = (slice(max(rows.min() - margin, 0), rows.max() + margin + 1),
            slice(max(columns.min() - margin, 0), columns.max() + margin + 1))
    figure, axes = plt.subplots(1, 3, figsize=(15, 4.3))
    depths = [_depth_image(frame, resolution)[crop] for frame in (ideal, measured)]
    low, high = np.nanpercentile(depths[0], [1, 99])
    titles = [f"ideal: {len(ideal):,} points",
              f"structured light: {len(measured):,} points "
              f"({100 * len(measured) / len(ideal):.1f} %)"]
    for ax, depth, title in zip(axes, depths, titles, strict=False):
        shown = ax.imshow(depth, cmap="viridis", vmin=low, vmax=high, interpolation="nearest")
        ax.set_title(title, fontsize=10)
    figure.colorbar(shown, ax=axes[:2], shrink=0.8, label="depth (m)")
    axes[2].imshow(lost.reshape(height, width)[crop],
                   cmap=ListedColormap((KEPT_COLOUR, *(LOST_RGBA[cause] for cause in LOSS_CAUSES))),
                   vmin=-0.5, vmax=3.5,
                   interpolation="nearest")
    axes[2].set_title(f"lost: {len(ideal) - len(measured):,} points (grey: kept)", fontsize=10)
    labels = [f"{cause} ({count:,})" for cause, count in zip(CAUSES, counts, strict=True)]
    axes[2].legend(handles=[plt.Rectangle((0, 0), 1, 1, color=LOST_RGBA[cause])
                            for cause in LOSS_CAUSES], labels=labels,
                   loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    figure.suptitle(f"Bundled motor, Zivid 2+ MR60 preset at {width} x {height}, one view the "
                    f"UR10 reaches (azimuth {azimuth:.0f} deg, {POLAR_DEG:.0f} deg from above); "
                    f"projector {1000 * model.baseline_m:.0f} mm along +x (right)", fontsize=10)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=80, bbox_inches="tight")
    print(f"ideal {len(ideal)} points, structured light {len(measured)}; lost: "
          + ", ".join(f"{cause} {count}" for cause, count in zip(CAUSES, counts, strict=True)))
    print(f"wrote {args.out} ({args.out.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
