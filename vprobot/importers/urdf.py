"""Convert a serial arm's URDF into a vprobot robot folder (MJCF, scene, meshes, description).

One converter serves the bundled robots (`scripts/convert_robots.py`) and users' own arms
(`vprobot robots import`); `CONVERSION_STEPS` says what it does (and goes into every README).
"""

from __future__ import annotations

import dataclasses
import math
import os
import shutil
import uuid
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import cast

import mujoco
import numpy as np
import trimesh

from vprobot.cell.scene import Cell
from vprobot.config import CellConfig, Config
from vprobot.files.schema import Vec3, brief
from vprobot.robots.description import (
    ASSUMED_ACCELERATION_RAD_S2,
    ASSUMED_JERK_RAD_S3,
    ASSUMED_LIMIT_SOURCES,
    DESCRIPTION_FILE,
    GEOM_GROUP_ROBOT,
    SCENE_FILE,
    SENSOR_BODY,
    SENSOR_CAMERA,
    SENSOR_SITE,
    SUPPORTED_DOF,
    RobotDescription,
    hangs_below,
)

CONVERSION_STEPS = """\
1. The chain from the URDF's root to the flange link is found. The base is the parent link of
   its first revolute joint; links above the base, side branches and everything below the flange
   (a gripper) are dropped: vprobot mounts its sensor on the flange.
2. Gazebo and transmission elements and the visuals are dropped (MuJoCo cannot read `.dae`); the
   collision meshes serve as visual and collision geometry (MuJoCo collides their convex hulls).
   `package://` and `file://` mesh paths are resolved; meshes MuJoCo cannot read are converted to
   STL with trimesh.
3. MuJoCo's URDF importer compiles the arm (`fusestatic=false` keeps the flange as a body).
   Continuous joints get limits of +-2 pi.
4. A `sensor_body` is mounted on the flange: the site `sensor` at the optical centre 0.09 m in
   front of the flange and the camera `sensor_camera`. Sensor frame: +z viewing direction, +x
   image right, +y image down. Its housing is the sensor's (`sensor.housing`), which the cell
   adds.
5. Geom groups: 0 environment, 1 object, 2 robot. Robot geoms collide with each other and with
   the cell (contype 1, conaffinity 3); environment geoms only with the robot (2 / 1).
6. Self-collision pairs are excluded only between adjacent links (a link and the one its joint
   turns on, counting links joined by fixed joints as one) and between links in contact in
   every one of 300 configurations sampled uniformly within the joint limits (seeded). The
   sensor body is never excluded against any link. MuJoCo's own parent filter
   is switched off (`<flag filterparent="disable"/>`): every excluded pair is an `<exclude>`
   of the model.
7. A `home` keyframe, and `robot.yaml` with the base, flange, pan joint (the first), roll joint
   (the last), home, the velocity limits (the maker's where given, else the URDF's),
   acceleration and jerk limits (given, or assumptions labelled so: a URDF has none) and the
   base placement in the cell.
"""

ROBOT_BIT, ENVIRONMENT_BIT = 1, 2
"""Collision bits (contype / conaffinity), shared with vprobot.cell.scene."""

SENSOR_MOUNT_OFFSET = 0.09
"""Flange to optical centre along the flange z axis (m); the config's sensor mount overrides it."""
SENSOR_FOVY_DEG = 25.0

SELF_COLLISION_SAMPLES = 300
"""Configurations sampled within the joint limits for the pairs in contact in every one."""
SELF_COLLISION_SEED = 0

DEFAULT_BASE_POSITION_M = (0.0, 0.0, 0.5)
DEFAULT_BASE_YAW_DEG = 0.0
"""Base placement of an imported arm unless given: the cell's UR10 placement."""

MUJOCO_MESH_SUFFIXES = (".stl", ".obj", ".msh")
REVOLUTE_TYPES = ("revolute", "continuous")


@dataclasses.dataclass(frozen=True)
class Provenance:
    """Where a converted robot comes from, for its README and LICENSE.

    Attributes:
        title: Human name of the arm, e.g. "Franka Emika Panda".
        source: Where the URDF comes from (a package and path, or a URL).
        license_text: The license of the description; when None the LICENSE next to the URDF
            (or in a folder above it) is copied, else a note that it is unknown.
        upstream_readme: A README of the source to keep as UPSTREAM_README.md.
    """

    title: str
    source: str
    license_text: str | None = None
    upstream_readme: Path | None = None


def _end_link(joint: ET.Element, end: str, urdf: Path) -> str:
    """The link at one `end` ("parent" or "child") of a URDF joint.

    Raises:
        ValueError: If the joint names no such link.
    """
    element = joint.find(end)
    link = None if element is None else element.get("link")
    if link is None:
        raise ValueError(f"joint {joint.get('name')!r} of {urdf} names no {end} link")
    return link


def _number(joint: ET.Element, attribute: str, default: float, urdf: Path) -> float:
    """A finite number of a joint's `<limit>` attribute (`default` where it is not given).

    Raises:
        ValueError: If it is not a finite number; the message names the joint, the attribute
            and the file.
    """
    limit = joint.find("limit")
    text = None if limit is None else limit.get(attribute)
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise ValueError(f"joint {brief(joint.get('name'))} of {urdf}: <limit {attribute}=...> "
                         f"must be a finite number, got {brief(text)}")
    return value


def _parent_joints(joints: Sequence[ET.Element], urdf: Path) -> dict[str, ET.Element]:
    """The joint above each child link.

    Raises:
        ValueError: If a link is the child of two joints (a URDF is a tree); the message names
            the link and both joints.
    """
    parent_joint: dict[str, ET.Element] = {}
    for joint in joints:
        child = _end_link(joint, "child", urdf)
        if child in parent_joint:
            raise ValueError(f"link {brief(child)} of {urdf} has two parent joints, "
                             f"{brief(parent_joint[child].get('name'))} and "
                             f"{brief(joint.get('name'))}; a URDF is a tree")
        parent_joint[child] = joint
    return parent_joint


class UrdfChain:
    """The serial chain of a URDF from its root to the flange link.

    Args:
        urdf: The URDF file.
        flange: Name of the flange link.

    Raises:
        ValueError: If the file is not a URDF, the flange is not one of its links, a link has
            two parent joints, the joints above the flange form a loop, or the chain holds a
            joint that is neither revolute, continuous nor fixed, or has not 6 or 7 revolute
            joints.
    """

    def __init__(self, urdf: Path, flange: str):
        try:
            self.tree = ET.parse(urdf)
        except (ET.ParseError, OSError) as error:
            raise ValueError(f"cannot read URDF {urdf}: {error}") from None
        root = self.tree.getroot()
        if root.tag != "robot":
            raise ValueError(f"{urdf} is not a URDF (its root element is <{root.tag}>)")
        self.urdf = urdf
        links = [link.get("name") for link in root.findall("link")]
        if flange not in links:
            raise ValueError(f"flange link {flange!r} is not in {urdf}; its links: "
                             f"{', '.join(map(str, links))}")
        parent_joint = _parent_joints(root.findall("joint"), urdf)
        chain: list[ET.Element] = []
        link = flange
        while link in parent_joint:
            joint = parent_joint[link]
            if any(joint is above for above in chain):
                # Each link has one parent here, so the walk came back to where the loop closes.
                loop = chain[:chain.index(joint) + 1]
                raise ValueError(f"the joints above flange {brief(flange)} in {urdf} form a "
                                 f"loop: {', '.join(brief(item.get('name')) for item in loop)}; "
                                 f"a URDF is a tree")
            chain.insert(0, joint)
            link = _end_link(joint, "parent", urdf)
        movable = [joint for joint in chain if joint.get("type") != "fixed"]
        for joint in movable:
            if joint.get("type") not in REVOLUTE_TYPES:
                raise ValueError(f"joint {joint.get('name')!r} of {urdf} is "
                                 f"{joint.get('type')}; vprobot arms have revolute joints only")
        if len(movable) not in SUPPORTED_DOF:
            raise ValueError(f"the chain from {link!r} to {flange!r} in {urdf} has "
                             f"{len(movable)} revolute joints; vprobot supports arms with "
                             f"{' or '.join(map(str, SUPPORTED_DOF))}")
        first = chain.index(movable[0])
        self.flange = flange
        self.joints = chain[first:]
        self.base = _end_link(movable[0], "parent", urdf)
        self.links = [self.base, *(_end_link(joint, "child", urdf) for joint in self.joints)]
        self.revolute = movable

    @property
    def joint_names(self) -> list[str]:
        # URDF requires joint names; MuJoCo's importer rejects a file without them.
        return [joint.get("name", "") for joint in self.revolute]

    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper limits of the revolute joints (continuous ones: +-2 pi)."""
        lower, upper = [], []
        for joint in self.revolute:
            if joint.get("type") == "continuous":
                lower.append(-2.0 * np.pi)
                upper.append(2.0 * np.pi)
            else:
                lower.append(_number(joint, "lower", -2.0 * np.pi, self.urdf))
                upper.append(_number(joint, "upper", 2.0 * np.pi, self.urdf))
        return np.array(lower), np.array(upper)

    def velocity_limits(self) -> list[float]:
        """The URDF's joint velocity limits (rad/s).

        Raises:
            ValueError: If a revolute joint has no positive velocity limit, or one that is not
                a finite number.
        """
        limits = []
        for joint in self.revolute:
            value = _number(joint, "velocity", 0.0, self.urdf)
            if not value > 0:
                raise ValueError(f"joint {joint.get('name')!r} of {self.urdf} has no velocity "
                                 f"limit (<limit velocity=...>), which the travel cost "
                                 f"joint_time needs")
            limits.append(value)
        return limits


def resolve_mesh_path(filename: str, urdf: Path,
                      package_paths: Mapping[str, Path] | None = None) -> Path:
    """The file a URDF mesh reference names.

    `package://NAME/rest` is looked up in `package_paths`, then in the folders of
    `ROS_PACKAGE_PATH`, then in a folder named NAME above the URDF; `file://` and plain paths
    are taken relative to the URDF's folder.

    Raises:
        ValueError: If the file cannot be found; the message names the reference, and the
            files looked for where the package was found.
    """
    if filename.startswith("package://"):
        package, _, rest = filename[len("package://"):].partition("/")
        folders = []
        if package_paths and package in package_paths:
            folders.append(Path(package_paths[package]))
        for root in filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
            folders.append(Path(root) / package)
        folders += [folder for folder in urdf.resolve().parents if folder.name == package]
        for folder in folders:
            if (folder / rest).is_file():
                return folder / rest
        found = [str(folder / rest) for folder in folders if folder.is_dir()]
        if found:
            raise ValueError(f"mesh {filename} of {urdf} not found: package {package!r} has no "
                             f"such file (looked at {', '.join(found)})")
        raise ValueError(f"mesh {filename} of {urdf}: package {package!r} not found; pass "
                         f"--package {package}=FOLDER or set ROS_PACKAGE_PATH")
    path = Path(filename.removeprefix("file://"))
    path = path if path.is_absolute() else urdf.parent / path
    if not path.is_file():
        raise ValueError(f"mesh {filename} of {urdf} not found (looked at {path})")
    return path


def _copy_mesh(source: Path, meshes: Path, stem: str) -> str:
    """Copy (or convert to STL) a mesh into `meshes`; return its new file name."""
    suffix = source.suffix.lower()
    if suffix in MUJOCO_MESH_SUFFIXES:
        name = f"{stem}{suffix}"
        shutil.copy(source, meshes / name)
        return name
    try:
        mesh = trimesh.load(source, force="mesh")
    except Exception as error:  # trimesh raises many kinds for unreadable files
        raise ValueError(f"mesh {source}: MuJoCo reads only {', '.join(MUJOCO_MESH_SUFFIXES)} "
                         f"and trimesh could not convert it ({error})") from None
    name = f"{stem}.stl"
    mesh.export(meshes / name)
    return name


def _prepare_urdf(chain: UrdfChain, meshes: Path,
                  package_paths: Mapping[str, Path] | None) -> ET.ElementTree[ET.Element]:
    """The chain's URDF for MuJoCo's importer, with its meshes copied into `meshes`."""
    root = chain.tree.getroot()
    kept_links, kept_joints = set(chain.links), {id(joint) for joint in chain.joints}
    for element in list(root):
        if element.tag == "link" and element.get("name") in kept_links:
            continue
        if element.tag == "joint" and id(element) in kept_joints:
            continue
        root.remove(element)
    stems: set[str] = set()
    for link in root.findall("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
        for mesh in link.iter("mesh"):
            source = resolve_mesh_path(mesh.get("filename", ""), chain.urdf, package_paths)
            stem = source.stem
            while stem in stems:  # meshes of different folders may share a file name
                stem += "_"
            stems.add(stem)
            mesh.set("filename", _copy_mesh(source, meshes, stem))
    for joint in chain.revolute:
        if joint.get("type") == "continuous":
            # MuJoCo imports continuous joints unlimited; vprobot's IK and seeds need bounds.
            joint.set("type", "revolute")
            limit = joint.find("limit")
            if limit is None:
                limit = ET.SubElement(joint, "limit", {"effort": "0", "velocity": "0"})
            limit.set("lower", str(-2.0 * np.pi))
            limit.set("upper", str(2.0 * np.pi))
    compiler = ET.SubElement(ET.SubElement(root, "mujoco"), "compiler")
    compiler.attrib.update({"meshdir": "meshes", "strippath": "true", "fusestatic": "false",
                            "balanceinertia": "true", "angle": "radian",
                            "discardvisual": "false"})
    return chain.tree


def _add_sensor(spec: mujoco.MjSpec, flange: str) -> None:
    """Mount the sensor body on the flange: `sensor` site, render camera (the cell adds the
    sensor's housing, `vprobot.cell.scene`)."""
    sensor = spec.body(flange).add_body(name=SENSOR_BODY, pos=[0.0, 0.0, SENSOR_MOUNT_OFFSET])
    # Sensor frame: +z views, +x is image right, +y image down
    # (docs/units-and-frames.md#sensor-frame).
    sensor.add_site(name=SENSOR_SITE, size=[0.01, 0.01, 0.01], rgba=[1.0, 0.5, 0.0, 1.0])
    # A MuJoCo camera looks along its -z with +y up: a half turn about x maps it onto the sensor.
    sensor.add_camera(name=SENSOR_CAMERA, quat=[0.0, 1.0, 0.0, 0.0], fovy=SENSOR_FOVY_DEG)


def _style_robot_geoms(spec: mujoco.MjSpec) -> None:
    for geom in spec.geoms:
        geom.group = GEOM_GROUP_ROBOT
        geom.contype = ROBOT_BIT
        geom.conaffinity = ROBOT_BIT | ENVIRONMENT_BIT
        geom.rgba = [0.72, 0.75, 0.80, 1.0]


def _body_pair(model: mujoco.MjModel, body1: int, body2: int) -> tuple[str, str]:
    name1, name2 = sorted((model.body(body1).name, model.body(body2).name))
    return name1, name2


def _adjacent_body_pairs(model: mujoco.MjModel, tool: set[int]) -> set[tuple[str, str]]:
    """Pairs of bodies with geoms on adjacent links, none of them in `tool`: the pairs MuJoCo's
    parent filter skips (a body against those welded to its parent's link; not the base's)."""
    weld = model.body_weldid
    parent_weld = weld[model.body_parentid[weld]]
    bodies = sorted(set(model.geom_bodyid) - tool)
    return {_body_pair(model, child, body) for child in bodies for body in bodies
            if weld[body] != 0 and weld[body] == parent_weld[child]}


def _always_touching_pairs(model: mujoco.MjModel,
                           configurations: np.ndarray) -> set[tuple[str, str]]:
    """Body pairs whose collision geoms touch in every one of `configurations`."""
    data = mujoco.MjData(model)
    always: set[tuple[str, str]] | None = None
    for qpos in configurations:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        touching = {_body_pair(model, model.geom_bodyid[contact.geom1],
                               model.geom_bodyid[contact.geom2])
                    for contact in data.contact[: data.ncon]}
        always = touching if always is None else always & touching
    return always or set()


def _exclude_self_collisions(spec: mujoco.MjSpec, lower: np.ndarray, upper: np.ndarray,
                             flange: str) -> None:
    """Exclude adjacent links and links in contact everywhere (point 6 of `CONVERSION_STEPS`)."""
    # Without MuJoCo's parent filter every skipped pair is an <exclude>: the sensor is checked
    # against the link its flange turns on too, which the filter would have hidden.
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    model = spec.compile()
    flange_id = model.body(flange).id
    tool = {body for body in range(model.nbody)
            if body != flange_id and hangs_below(model, body, flange_id)}
    for body1, body2 in sorted(_adjacent_body_pairs(model, tool)):
        spec.add_exclude(bodyname1=body1, bodyname2=body2)
    model = spec.compile()
    samples = np.random.default_rng(SELF_COLLISION_SEED).uniform(
        lower, upper, size=(SELF_COLLISION_SAMPLES, len(lower)))
    tool_names = {model.body(body).name for body in tool}
    for body1, body2 in sorted(_always_touching_pairs(model, samples)):
        if not tool_names & {body1, body2}:
            spec.add_exclude(bodyname1=body1, bodyname2=body2)


def default_home(chain: UrdfChain) -> np.ndarray:
    """Zero, or the middle of a joint's range where zero lies outside it."""
    lower, upper = chain.limits()
    return np.where((lower <= 0.0) & (upper >= 0.0), 0.0, (lower + upper) / 2.0)


def _license_text(provenance: Provenance, urdf: Path) -> str:
    if provenance.license_text is not None:
        return provenance.license_text
    for folder in list(urdf.resolve().parents)[:4]:
        for name in ("LICENSE", "LICENSE.txt", "LICENSE.md"):
            if (folder / name).is_file():
                return (folder / name).read_text()
    return (f"No license file was found next to {urdf.name}. Check the license of the source "
            f"description ({provenance.source}) before redistributing this folder.\n")


def convert_urdf(
    urdf: str | Path,
    name: str,
    flange: str,
    out_dir: str | Path,
    provenance: Provenance | None = None,
    home: Sequence[float] | None = None,
    base_position_m: Sequence[float] = DEFAULT_BASE_POSITION_M,
    base_yaw_deg: float = DEFAULT_BASE_YAW_DEG,
    base_tilt_deg: float = 0.0,
    package_paths: Mapping[str, Path] | None = None,
    overwrite: bool = False,
    acceleration_limits_rad_s2: Sequence[float] | None = None,
    jerk_limits_rad_s3: Sequence[float] | None = None,
    limit_sources: Mapping[str, str] | None = None,
    velocity_limits_rad_s: Sequence[float] | None = None,
) -> RobotDescription:
    """Convert a serial arm's URDF into the robot folder `out_dir` (see the module docstring).

    The folder is built next to `out_dir` and moved into place only once complete and checked
    (a `Cell` is compiled from it), so a failure leaves nothing behind.

    Args:
        urdf: The URDF file.
        name: The robot's name (also the MJCF's file name).
        flange: The link that carries the sensor.
        out_dir: The robot folder to write.
        provenance: Title, source and license for README and LICENSE.
        home: Home configuration (rad); zero, or mid-range where zero is outside the limits.
        base_position_m: Default base position in the cell.
        base_yaw_deg: Default base rotation about the world z axis.
        base_tilt_deg: Default base rotation about its own y axis after the yaw.
        package_paths: Folders of ROS packages that `package://` mesh paths name.
        overwrite: Replace an existing `out_dir`.
        acceleration_limits_rad_s2: Joint acceleration limits; a URDF has none, so by default
            `ASSUMED_ACCELERATION_RAD_S2` for every joint, labelled an assumption.
        jerk_limits_rad_s3: Joint jerk limits; by default `ASSUMED_JERK_RAD_S3`, likewise.
        limit_sources: Where the limits come from, by `robot.yaml` key, written as comments
            above them (the velocity limits' defaults to the URDF).
        velocity_limits_rad_s: Joint velocity limits, where the maker's differ from the URDF's;
            by default the URDF's.

    Returns:
        The checked description of the new folder.

    Raises:
        ValueError: On an unusable URDF, flange, home or name, or an existing `out_dir`
            without `overwrite`.
    """
    urdf, out_dir = Path(urdf), Path(out_dir)
    if not name or not name.replace("_", "").replace("-", "").isalnum():
        raise ValueError(f"robot name must be letters, digits, '_' or '-', got {name!r}")
    _check_replaceable(out_dir, overwrite)
    chain = UrdfChain(urdf, flange)
    provenance = provenance or Provenance(title=name, source=str(urdf))
    lower, upper = chain.limits()
    home_q = default_home(chain) if home is None else np.asarray(home, dtype=float)
    if home_q.shape != lower.shape or np.any(home_q < lower) or np.any(home_q > upper):
        raise ValueError(f"home {np.round(home_q, 4).tolist()} must have {len(lower)} values "
                         f"within the joint limits {np.round(lower, 4).tolist()} .. "
                         f"{np.round(upper, 4).tolist()}")
    dof = len(lower)
    description = RobotDescription(
        name=name, model=f"{name}.xml", base=chain.base, flange=flange,
        pan_joint=chain.joint_names[0], roll_joint=chain.joint_names[-1],
        home=tuple(float(value) for value in home_q),
        velocity_limits_rad_s=tuple(map(float, (
            chain.velocity_limits() if velocity_limits_rad_s is None
            else velocity_limits_rad_s))),
        acceleration_limits_rad_s2=tuple(map(float, (
            [ASSUMED_ACCELERATION_RAD_S2] * dof if acceleration_limits_rad_s2 is None
            else acceleration_limits_rad_s2))),
        jerk_limits_rad_s3=tuple(map(float, (
            [ASSUMED_JERK_RAD_S3] * dof if jerk_limits_rad_s3 is None
            else jerk_limits_rad_s3))),
        # Three values: reading the folder back (`_check_folder`) checks it.
        base_position_m=cast(Vec3, tuple(float(value) for value in base_position_m)),
        base_yaw_deg=float(base_yaw_deg), base_tilt_deg=float(base_tilt_deg))

    sources = {"velocity_limits_rad_s": f"The URDF's joint velocity limits ({provenance.source}).",
               **ASSUMED_LIMIT_SOURCES, **(limit_sources or {})}

    out_dir.parent.mkdir(parents=True, exist_ok=True)
    # A hidden sibling, so that the finished folder moves into place; made with mkdir (not
    # mkdtemp's 700) so that the robot folder gets the umask's mode like its files.
    building = out_dir.parent / f".{name}.{uuid.uuid4().hex[:8]}.building"
    building.mkdir()
    try:
        try:
            _build_folder(chain, description, sources, provenance, building, package_paths)
            _check_folder(building, urdf)
        except ValueError as error:
            # Messages name the folder the user asked for, not the hidden one being built.
            raise ValueError(str(error).replace(str(building), str(out_dir))) from None
        if out_dir.exists():
            shutil.rmtree(out_dir)
        building.rename(out_dir)
    finally:
        shutil.rmtree(building, ignore_errors=True)
    return RobotDescription.load(out_dir)


def _check_replaceable(out_dir: Path, overwrite: bool) -> None:
    """Refuse an `out_dir` whose contents the import would destroy.

    A missing or empty folder is written; an existing robot folder (one with `robot.yaml`) is
    replaced with `overwrite` only; anything else is refused whatever `overwrite` says.

    Raises:
        ValueError: Naming `out_dir` and what to do instead.
    """
    if not out_dir.exists():
        return
    if not out_dir.is_dir():
        raise ValueError(f"{out_dir} is a file, not a robot folder; choose another --out")
    if not any(out_dir.iterdir()):
        return
    if not (out_dir / DESCRIPTION_FILE).is_file():
        raise ValueError(f"{out_dir} holds files but is no robot folder (no {DESCRIPTION_FILE}); "
                         f"--force replaces only a robot folder, so choose another --out")
    if not overwrite:
        raise ValueError(f"robot folder {out_dir} exists; choose another --out or pass --force "
                         f"to replace it")


def _build_folder(chain: UrdfChain, description: RobotDescription, sources: Mapping[str, str],
                  provenance: Provenance, folder: Path,
                  package_paths: Mapping[str, Path] | None) -> None:
    (folder / "meshes").mkdir()
    # The prepared URDF names its meshes relative to the folder, so MuJoCo reads it from there.
    urdf = folder / f"{description.name}.urdf"
    _prepare_urdf(chain, folder / "meshes", package_paths).write(urdf)
    try:
        spec = mujoco.MjSpec.from_file(str(urdf))
    except ValueError as error:
        raise ValueError(f"MuJoCo cannot compile {chain.urdf}: {error}") from None
    finally:
        urdf.unlink()
    spec.modelname = description.name
    spec.modelfiledir = str(folder)
    spec.compiler.degree = False
    spec.meshdir = "meshes"
    _add_sensor(spec, description.flange)
    _style_robot_geoms(spec)
    spec.add_key(name="home", qpos=list(description.home))
    _exclude_self_collisions(spec, *chain.limits(), chain.flange)
    spec.compile()
    (folder / description.model).write_text(spec.to_xml())
    (folder / SCENE_FILE).write_text(SCENE_TEMPLATE.format(name=description.name,
                                                           model=description.model))
    (folder / "robot.yaml").write_text(description.to_yaml(sources))
    (folder / "LICENSE").write_text(_license_text(provenance, chain.urdf))
    if provenance.upstream_readme is not None:
        shutil.copy(provenance.upstream_readme, folder / "UPSTREAM_README.md")
    (folder / "README.md").write_text(README_TEMPLATE.format(
        title=provenance.title, name=description.name, model=description.model,
        source=provenance.source, flange=description.flange, base=description.base,
        joints=", ".join(chain.joint_names), home=[round(value, 4) for value in description.home],
        steps=CONVERSION_STEPS.rstrip()))



def _check_folder(folder: Path, urdf: Path) -> None:
    """Compile a cell from the folder: loading it checks the description against the model.

    Raises:
        ValueError: If the folder converted from `urdf` does not make a cell.
    """
    try:
        Cell(Config(cell=CellConfig(robot=str(folder))))
    except ValueError as error:
        raise ValueError(f"the robot converted from {urdf} does not make a cell: "
                         f"{error}") from None


SCENE_TEMPLATE = """<mujoco model="{name} inspection cell">
  <!-- Composed by vprobot's URDF converter. vprobot.cell.scene moves the robot base, the pedestal
       and the object to the poses in the config and puts the motor mesh into `object`. -->
  <include file="{model}"/>

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

README_TEMPLATE = """# {title} (vprobot inspection cell)

MJCF model of the {title} carrying a 3D sensor, for vprobot.

## Files
- `{model}`: the arm from `{base}` to its flange `{flange}`, the sensor body and a `home`
  keyframe. Joints: {joints}.
- `scene.xml`: includes `{model}` and adds the floor, the pedestal fixture and the `object` slot
  (a mocap body into which vprobot puts the motor mesh).
- `robot.yaml`: the robot description vprobot reads (base, flange, pan and roll joints, home,
  velocity limits, base placement in the cell).
- `meshes/`: the collision meshes of the source description (used for visuals too).
- `LICENSE`: the license of the source description.

## How it was converted
Converted by vprobot's URDF converter (`vprobot/importers/urdf.py`) from {source}:

{steps}

Home: {home} rad. The sensor mount, base pose and fixture pose in these files are defaults;
vprobot's config overrides them when it builds a scene.
"""
