"""Convert the UR5 and UR10 URDFs of example-robot-data into MJCF folders under assets/robots/.

Re-run after upgrading example-robot-data:

    python scripts/convert_robots.py

For each robot this writes `assets/robots/<name>/` with `<name>.xml` (the arm, its flange frame
`tool0` and the sensor), `scene.xml` (arm + floor + pedestal fixture + object slot), `meshes/`
(the collision STLs, also used for visuals), `LICENSE` and `README.md`. The steps are described in
the README template at the bottom of this file.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import shutil
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

ROBOTS = ("ur5", "ur10")
REPO_ROOT = Path(__file__).resolve().parent.parent
OUT_ROOT = REPO_ROOT / "assets" / "robots"

# Frames of the ROS description that MuJoCo does not need: `world` is MuJoCo's own world body,
# `base` only rotates base_link by 180 deg for the UR controller, `ee_link` duplicates tool0.
DROPPED_LINKS = ("world", "base", "ee_link")

# Collision bits (contype / conaffinity), shared with vprobot.scene: the robot collides with
# itself and with the environment; the environment never with itself.
ROBOT_BIT, ENVIRONMENT_BIT = 1, 2
GEOM_GROUP_ROBOT = 2

# A structured-light sensor housing (about 200 x 60 x 80 mm), the optical centre at its front.
SENSOR_HALF_SIZE = (0.10, 0.03, 0.04)
SENSOR_MOUNT_OFFSET = 0.09  # flange to optical centre along the flange z axis (m)
SENSOR_FOVY_DEG = 25.0

# Home: elbow up, sensor looking forward and down toward the fixture.
HOME_QPOS = (0.0, -1.9, 1.9, -1.57, -1.57, 0.0)


def example_robot_data_dir() -> Path:
    """Return the installed example-robot-data `ur_description` folder."""
    dist = importlib.metadata.distribution("example-robot-data")
    relative = "cmeel.prefix/share/example-robot-data/robots/ur_description"
    path = Path(str(dist.locate_file(relative)))
    if not path.is_dir():
        raise FileNotFoundError(f"example-robot-data's ur_description not found at {path}")
    return path


def joint_velocity_limits(tree: ET.ElementTree) -> list[float]:
    """Velocity limits (rad/s) of the revolute joints, in chain order."""
    return [
        float(joint.find("limit").get("velocity"))
        for joint in tree.getroot().findall("joint")
        if joint.get("type") == "revolute"
    ]


def clean_urdf(urdf_path: Path) -> ET.ElementTree:
    """Strip ROS-only elements and point every mesh at `<link>.stl` (collision mesh)."""
    tree = ET.parse(urdf_path)
    root = tree.getroot()
    for tag in ("gazebo", "transmission"):
        for element in root.findall(tag):
            root.remove(element)
    for link in root.findall("link"):
        if link.get("name") in DROPPED_LINKS:
            root.remove(link)
            continue
        # MuJoCo cannot read the .dae visuals: the collision mesh serves as visual too.
        for visual in link.findall("visual"):
            link.remove(visual)
        for mesh in link.iter("mesh"):
            mesh.set("filename", Path(mesh.get("filename", "")).name)
    for joint in root.findall("joint"):
        parent = joint.find("parent").get("link")
        child = joint.find("child").get("link")
        if parent in DROPPED_LINKS or child in DROPPED_LINKS:
            root.remove(joint)
    compiler = ET.SubElement(ET.SubElement(root, "mujoco"), "compiler")
    compiler.attrib.update(
        {"meshdir": "meshes", "fusestatic": "false", "balanceinertia": "true", "angle": "radian"}
    )
    return tree


def add_sensor(spec: mujoco.MjSpec) -> None:
    """Mount the sensor body on tool0: housing geom, `sensor` site, render camera."""
    flange = spec.body("tool0")
    sensor = flange.add_body(name="sensor_body", pos=[0.0, 0.0, SENSOR_MOUNT_OFFSET])
    sensor.add_geom(
        name="sensor_housing",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(SENSOR_HALF_SIZE),
        pos=[0.0, 0.0, -SENSOR_HALF_SIZE[2]],
        mass=0.8,
        rgba=[0.15, 0.15, 0.18, 1.0],
        group=GEOM_GROUP_ROBOT,
        contype=ROBOT_BIT,
        conaffinity=ROBOT_BIT | ENVIRONMENT_BIT,
    )
    # Sensor frame: +z views, +x is image right, +y image down (SPEC section 3).
    sensor.add_site(name="sensor", size=[0.01, 0.01, 0.01], rgba=[1.0, 0.5, 0.0, 1.0])
    # A MuJoCo camera looks along its -z with +y up: a half turn about x maps it onto the sensor.
    sensor.add_camera(name="sensor_camera", quat=[0.0, 1.0, 0.0, 0.0], fovy=SENSOR_FOVY_DEG)


def style_robot_geoms(spec: mujoco.MjSpec) -> None:
    for geom in spec.geoms:
        if geom.name == "sensor_housing":
            continue
        geom.group = GEOM_GROUP_ROBOT
        geom.contype = ROBOT_BIT
        geom.conaffinity = ROBOT_BIT | ENVIRONMENT_BIT
        geom.rgba = [0.72, 0.75, 0.80, 1.0]


def touching_body_pairs(model: mujoco.MjModel, configurations: list[np.ndarray]) -> set[tuple]:
    """Body pairs whose collision geoms touch in any of the given configurations."""
    data = mujoco.MjData(model)
    pairs = set()
    for qpos in configurations:
        data.qpos[:] = qpos
        mujoco.mj_forward(model, data)
        for contact in data.contact[: data.ncon]:
            bodies = sorted(
                (model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2])
            )
            pairs.add(tuple(model.body(b).name for b in bodies))
    return pairs


def convert(name: str, source: Path, out_dir: Path) -> None:
    """Convert one robot into `out_dir`."""
    if out_dir.exists():
        shutil.rmtree(out_dir)
    (out_dir / "meshes").mkdir(parents=True)
    for stl in sorted((source / "meshes" / name / "collision").glob("*.stl")):
        shutil.copy(stl, out_dir / "meshes" / stl.name)
    shutil.copy(source / "README.md", out_dir / "UPSTREAM_README.md")

    with tempfile.TemporaryDirectory() as tmp:
        urdf = Path(tmp) / f"{name}.urdf"
        tree = clean_urdf(source / "urdf" / f"{name}_robot.urdf")
        tree.write(urdf)
        shutil.copytree(out_dir / "meshes", Path(tmp) / "meshes")
        spec = mujoco.MjSpec.from_file(str(urdf))

    spec.modelname = name
    spec.modelfiledir = str(out_dir)
    spec.compiler.degree = False
    spec.meshdir = "meshes"
    add_sensor(spec)
    style_robot_geoms(spec)
    spec.add_key(name="home", qpos=list(HOME_QPOS))
    # MuJoCo has no joint velocity limit; the travel cost `joint_time` needs the URDF's.
    spec.add_numeric(name="joint_velocity_limits", data=joint_velocity_limits(tree))
    model = spec.compile()

    # Convex hulls of neighbouring links overlap by construction at the zero and home poses;
    # such pairs are excluded so that self-collision means a real fold-over of the arm.
    for body1, body2 in sorted(touching_body_pairs(model, [np.zeros(6), np.array(HOME_QPOS)])):
        spec.add_exclude(bodyname1=body1, bodyname2=body2)
    spec.compile()
    (out_dir / f"{name}.xml").write_text(spec.to_xml())
    (out_dir / "scene.xml").write_text(SCENE_TEMPLATE.format(name=name))
    (out_dir / "LICENSE").write_text(LICENSE_TEXT)
    (out_dir / "README.md").write_text(README_TEMPLATE.format(name=name, NAME=name.upper()))


SCENE_TEMPLATE = """<mujoco model="{name} inspection cell">
  <!-- Composed by scripts/convert_robots.py. vprobot.scene moves the robot base, the pedestal
       and the object to the poses in the config and puts the motor mesh into `object`. -->
  <include file="{name}.xml"/>

  <statistic center="0.6 0 0.5" extent="1.2"/>

  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="150" elevation="-25" offwidth="1280" offheight="960"/>
  </visual>

  <asset>
    <texture type="2d" name="floor" builtin="checker" mark="edge" rgb1="0.32 0.34 0.37"
      rgb2="0.26 0.28 0.30" markrgb="0.5 0.5 0.5" width="300" height="300"/>
    <material name="floor" texture="floor" texuniform="true" texrepeat="5 5" reflectance="0.1"/>
  </asset>

  <worldbody>
    <light pos="0.6 0 2.5" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="3 3 0.05" material="floor" group="0"
      contype="2" conaffinity="1"/>
    <!-- A slim pedestal so that the sensor can look at the motor from below its equator. The
         body frame is the top of the fixture plate; vprobot raises it to the object's underside
         (the column reaches down through the floor). -->
    <body name="fixture" mocap="true" pos="0.75 0 0.41">
      <geom name="fixture_plate" type="box" pos="0 0 -0.01" size="0.06 0.04 0.01"
        rgba="0.35 0.37 0.4 1" group="0" contype="2" conaffinity="1"/>
      <geom name="pedestal" type="cylinder" fromto="0 0 -2 0 0 -0.02" size="0.035"
        rgba="0.45 0.47 0.5 1" group="0" contype="2" conaffinity="1"/>
    </body>
    <body name="object" mocap="true" pos="0.75 0 0.47">
      <site name="object_center" size="0.005"/>
    </body>
  </worldbody>
</mujoco>
"""

LICENSE_TEXT = """The robot description (kinematics, limits, meshes) comes from the `ur_description`
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

README_TEMPLATE = """# {NAME} (vprobot inspection cell)

MJCF model of the Universal Robots {NAME} carrying a 3D sensor, for vprobot.

## Files
- `{name}.xml`: the arm, its flange frame `tool0`, the sensor body and a `home` keyframe.
- `scene.xml`: includes `{name}.xml` and adds the floor, the pedestal fixture and the `object`
  slot (a mocap body into which vprobot puts the motor mesh).
- `meshes/`: the collision STLs of the upstream description (used for visuals too).
- `LICENSE`, `UPSTREAM_README.md`: the upstream license and README.

## How it was converted
Generated by `python scripts/convert_robots.py` from example-robot-data's
`robots/ur_description/urdf/{name}_robot.urdf` (the unlimited-joint variant, limits +-2 pi except
the elbow at +-pi):
1. Gazebo and transmission elements are removed; the ROS frames `world`, `base` and `ee_link` are
   dropped (MuJoCo has its own world body, `base` only rotates base_link by 180 degrees, `ee_link`
   duplicates `tool0`). `tool0`, the flange frame of the UR controller, is kept as a body.
2. The `.dae` visuals are dropped (MuJoCo cannot read them); the collision STLs serve as visual and
   collision geometry (MuJoCo collides meshes by their convex hulls).
3. MuJoCo's URDF importer compiles it (`fusestatic=false` keeps `tool0`).
4. A `sensor_body` is mounted on `tool0`: a box housing (200 x 60 x 80 mm), the site `sensor` at
   the optical centre 0.09 m in front of the flange, and the camera `sensor_camera`. Sensor frame:
   +z is the viewing direction, +x image right, +y image down. The camera is turned half a turn
   about x because a MuJoCo camera looks along its own -z.
5. Geom groups: 0 environment, 1 object, 2 robot links and sensor housing. Collision bits: robot
   geoms contype 1 / conaffinity 3, environment and object contype 2 / conaffinity 1, so the robot
   collides with itself and the cell, the cell never with itself.
6. Body pairs whose convex hulls already touch at the zero or home configuration are excluded
   from self-collision, so that a self-collision means a real fold-over of the arm.
7. A `home` keyframe: {home}.
8. The URDF joint velocity limits (rad/s) are kept as the numeric `joint_velocity_limits`.

The mount offset, base pose and fixture pose in these files are defaults; vprobot's config
overrides them when it builds a scene.
""".replace("{home}", str(HOME_QPOS))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=ROBOTS)
    args = parser.parse_args()
    source = example_robot_data_dir()
    for name in args.robots:
        convert(name, source, OUT_ROOT / name)
        print(f"wrote {OUT_ROOT / name}")


if __name__ == "__main__":
    main()
