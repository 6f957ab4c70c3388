"""Convert the bundled robots (UR5, UR10, Franka Panda) of example-robot-data into assets/robots/.

Re-run after upgrading example-robot-data:

    python scripts/convert_robots.py [--robots panda]

Each robot goes through the same converter as `vprobot robots import`
(vprobot/importers/urdf.py), with the home configuration and cell placement chosen here.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.metadata
import math
from pathlib import Path

from vprobot.importers.urdf import Provenance, convert_urdf
from vprobot.robots.description import ASSUMED_LIMIT_SOURCES

REPO_ROOT = Path(__file__).resolve().parent.parent
OUT_ROOT = REPO_ROOT / "assets" / "robots"

UR_LICENSE = """The robot description (kinematics, limits, meshes) comes from the `ur_description`
package of example-robot-data (https://github.com/Gepetto/example-robot-data), which takes it from
ros-industrial/universal_robot (kinetic-devel) under the BSD license:

Copyright (c) 2013, ROS-Industrial
All rights reserved.

Redistribution and use in source and binary forms, with or without modification, are permitted
provided that the following conditions are met:

1. Redistributions of source code must retain the above copyright notice, this list of
   conditions and the following disclaimer.
2. Redistributions in binary form must reproduce the above copyright notice, this list of
   conditions and the following disclaimer in the documentation and/or other materials provided
   with the distribution.
3. Neither the name of the copyright holder nor the names of its contributors may be used to
   endorse or promote products derived from this software without specific prior written
   permission.

THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS" AND ANY EXPRESS OR
IMPLIED WARRANTIES, INCLUDING, BUT NOT LIMITED TO, THE IMPLIED WARRANTIES OF MERCHANTABILITY AND
FITNESS FOR A PARTICULAR PURPOSE ARE DISCLAIMED. IN NO EVENT SHALL THE COPYRIGHT HOLDER OR
CONTRIBUTORS BE LIABLE FOR ANY DIRECT, INDIRECT, INCIDENTAL, SPECIAL, EXEMPLARY, OR CONSEQUENTIAL
DAMAGES (INCLUDING, BUT NOT LIMITED TO, PROCUREMENT OF SUBSTITUTE GOODS OR SERVICES; LOSS OF USE,
DATA, OR PROFITS; OR BUSINESS INTERRUPTION) HOWEVER CAUSED AND ON ANY THEORY OF LIABILITY, WHETHER
IN CONTRACT, STRICT LIABILITY, OR TORT (INCLUDING NEGLIGENCE OR OTHERWISE) ARISING IN ANY WAY OUT
OF THE USE OF THIS SOFTWARE, EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.

The sensor body, keyframe and scene added by vprobot are under the same license.
"""


@dataclasses.dataclass(frozen=True)
class BundledRobot:
    """One robot of example-robot-data and how vprobot places it in the cell."""

    title: str
    package: str
    urdf: str
    flange: str
    home: tuple[float, ...]
    base_position_m: tuple[float, float, float]
    base_yaw_deg: float = 0.0
    base_tilt_deg: float = 0.0
    license_text: str | None = None
    velocity_limits_rad_s: tuple[float, ...] | None = None
    acceleration_limits_rad_s2: tuple[float, ...] | None = None
    jerk_limits_rad_s3: tuple[float, ...] | None = None
    limit_sources: dict[str, str] | None = None


UR_MANUALS = ("Universal Robots' maximum joint speeds ({manual}, technical specifications; the "
              "same in Universal Robots' ROS 2 description, Universal_Robots_ROS2_Description "
              "config/{name}/joint_limits.yaml): {speeds}. The URDF's are higher.")
UR10_VELOCITY_LIMITS = tuple(math.radians(speed) for speed in (120, 120, 180, 180, 180, 180))
UR5_VELOCITY_LIMITS = (math.radians(180),) * 6


def ur_limit_sources(name: str, manual: str, speeds: str) -> dict[str, str]:
    """Where a UR's limits come from: the maker's speeds, the labelled assumptions."""
    return {"velocity_limits_rad_s": UR_MANUALS.format(manual=manual, name=name, speeds=speeds),
            **ASSUMED_LIMIT_SOURCES}


FRANKA_LIMITS = ("Franka's published limits for the Panda (Franka Control Interface docs, "
                 "'Robot and interface specifications', Limits for Panda; libfranka "
                 "rate_limiting.h kMaxJoint{Velocity,Acceleration,Jerk}): ")
PANDA_LIMIT_SOURCES = {
    "velocity_limits_rad_s": FRANKA_LIMITS + "q_dot_max, as in the URDF.",
    "acceleration_limits_rad_s2": FRANKA_LIMITS + "q_ddot_max.",
    "jerk_limits_rad_s3": FRANKA_LIMITS + "q_dddot_max.",
}

# Homes: the sensor looking toward the motor. Placements: where the arm reaches most of the
# 0.47 m view sphere around the motor at (0.45, 0, 0.75) (`vprobot benchmark kinematics`:
# view_sphere_reachable).
ROBOTS = {
    "ur5": BundledRobot("Universal Robots UR5", "ur_description", "urdf/ur5_robot.urdf", "tool0",
                        (0.0, -1.9, 1.9, -1.57, -1.57, 0.0), (0.0, 0.0, 0.5),
                        license_text=UR_LICENSE, velocity_limits_rad_s=UR5_VELOCITY_LIMITS,
                        limit_sources=ur_limit_sources(
                            "ur5", "UR5/CB3 User Manual",
                            "180 deg/s (pi rad/s) for every joint")),
    "ur10": BundledRobot("Universal Robots UR10", "ur_description", "urdf/ur10_robot.urdf",
                         "tool0", (0.0, -1.9, 1.9, -1.57, -1.57, 0.0), (0.0, 0.0, 0.5),
                         license_text=UR_LICENSE, velocity_limits_rad_s=UR10_VELOCITY_LIMITS,
                         limit_sources=ur_limit_sources(
                             "ur10", "UR10/CB3 User Manual",
                             "120 deg/s (2.0944 rad/s) for base and shoulder, 180 deg/s (pi "
                             "rad/s) for elbow and wrists")),
    # The Panda's 0.855 m reach cannot wrap the far side of the view sphere from the floor
    # (at most 69 % of it from any base position tried); hanging from the ceiling above the
    # motor, it reaches all round except the lowest band and the cap right under its base.
    # Joint 6 at 0.7 rad, not less, keeps the sensor housing 16 mm clear of link 5 at home (at
    # 0.43 it lay 13 mm inside; a flange spacer that clears it costs a third of the reach).
    "panda": BundledRobot("Franka Emika Panda", "panda_description", "urdf/panda.urdf",
                          "panda_link8", (-0.68, 1.57, -1.6, -1.27, -0.49, 0.7, 0.08),
                          (0.5, 0.0, 1.25), base_tilt_deg=180.0,
                          acceleration_limits_rad_s2=(15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
                          jerk_limits_rad_s3=(7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0,
                                              10000.0),
                          limit_sources=PANDA_LIMIT_SOURCES),
}


def example_robot_data_dir() -> Path:
    """The installed example-robot-data `robots` folder."""
    dist = importlib.metadata.distribution("example-robot-data")
    path = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not path.is_dir():
        raise FileNotFoundError(f"example-robot-data's robots not found at {path}")
    return path


def convert(name: str, source: Path) -> None:
    """Convert one bundled robot into assets/robots/<name>."""
    robot = ROBOTS[name]
    package = source / robot.package
    version = importlib.metadata.version("example-robot-data")
    convert_urdf(
        package / robot.urdf, name, robot.flange, OUT_ROOT / name,
        provenance=Provenance(
            title=robot.title,
            source=f"example-robot-data {version}, `robots/{robot.package}/{robot.urdf}`",
            license_text=robot.license_text,
            upstream_readme=package / "README.md"),
        home=robot.home, base_position_m=robot.base_position_m, base_yaw_deg=robot.base_yaw_deg,
        base_tilt_deg=robot.base_tilt_deg,
        package_paths={"example-robot-data": source.parent}, overwrite=True,
        velocity_limits_rad_s=robot.velocity_limits_rad_s,
        acceleration_limits_rad_s2=robot.acceleration_limits_rad_s2,
        jerk_limits_rad_s3=robot.jerk_limits_rad_s3, limit_sources=robot.limit_sources)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    args = parser.parse_args()
    source = example_robot_data_dir()
    for name in args.robots:
        convert(name, source)
        print(f"wrote {OUT_ROOT / name}")


if __name__ == "__main__":
    main()
