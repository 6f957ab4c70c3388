"""Typed configuration: YAML files in `configs/` validated into frozen dataclasses.

Every section is a dataclass whose field names carry their units where they could be ambiguous
(`_m` metres, `_deg` degrees, `_rad` radians, `_s` seconds). Loading is strict: an unknown key,
a value of the wrong type or length, or a value outside its allowed set is a `ConfigError` that
names the key and what is allowed.
"""

from __future__ import annotations

import dataclasses
import json
import numbers
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from vprobot.config.cell import (
    PartConfig,
    ProgramConfig,
    SafetyConfig,
    Solid,
    StaticObject,
    check_static_objects,
    with_cell_file,
)
from vprobot.extensions.registry import Registry
from vprobot.files.paths import (
    BUNDLED_EPISODE_LISTS,
    DEFAULT_CONFIG,
    SENSORS_DIR,
    available_sensors,
    bundled_or_path,
)
from vprobot.files.schema import (
    FORMERLY,
    RESOLVE,
    ConfigError,
    Quat,
    Vec3,
    brief,
    check_within,
    from_mapping,
    read_yaml,
    with_current_keys,
)
from vprobot.files.schema import parse_yaml as parse_yaml  # re-exported: the config's YAML reader
from vprobot.geometry.poses import is_rotation_quaternion
from vprobot.parts.splits import Split, split_file
from vprobot.rewards import REWARDS
from vprobot.robots import load_robot
from vprobot.sensing import SENSING_MODELS, SensingModel, StructuredLight, check_sensing


@dataclasses.dataclass(frozen=True)
class CellConfig:
    """The inspection cell: the robot and where it stands, what else is in the cell, where the
    part sits, where the robot starts, the safety margins and the programs' I/O
    (docs/your-cell.md). A config names a cell file instead with `cell: NAME` (a bundled cell
    of `configs/cells/` or a file's path).

    Attributes:
        robot: A bundled robot (`ur10`, `ur5`, `panda`) or the path of a robot folder (one
            written by `vprobot robots import`).
        robot_base_position_m: Position of the robot base in the world (a stand fills the gap
            down to the floor); None takes the robot's own placement from its `robot.yaml`.
        robot_base_yaw_deg: Rotation of the robot base about the world z axis; None takes the
            robot's own.
        robot_base_tilt_deg: Rotation of the robot base about its own y axis after the yaw:
            0 stands on the floor, 90 hangs on a wall, 180 hangs from the ceiling; None takes
            the robot's own.
        robot_stand: Whether a column carries the base down to the floor (`true`, the bundled
            cells) or the cell's static objects do (a table, say).
        start_joints_rad: The configuration the robot starts from and every program first moves
            to; None: the robot's `home`.
        object_center_m: Where the centre of an episode's part (its bounding box) is placed
            (world frame); episodes of training and evaluation turn the part about it at random.
        part: The part as it really sits, which `vprobot plan` plans; None: the episode's part
            (the bundled motor or `--mesh`) at `object_center_m` with a random pose.
        fixture: `auto`: a 120 x 80 mm plate on a pedestal under the part; `none`: the static
            objects hold it.
        static_objects: The cell's static collision objects (table, fixture, guarding, walls).
        safety: Clearance and joint-limit margins and the speed scale.
        program: How the exported programs trigger the sensor and wait for it.
    """

    robot: str = "ur10"
    robot_base_position_m: Vec3 | None = None
    robot_base_yaw_deg: float | None = None
    robot_base_tilt_deg: float | None = None
    robot_stand: bool = True
    start_joints_rad: tuple[float, ...] | None = None
    object_center_m: Vec3 = (0.45, 0.0, 0.75)
    part: PartConfig | None = None
    fixture: Literal["auto", "none"] = "auto"
    static_objects: tuple[StaticObject, ...] = ()
    safety: SafetyConfig = dataclasses.field(default_factory=SafetyConfig)
    program: ProgramConfig = dataclasses.field(default_factory=ProgramConfig)

    def __post_init__(self) -> None:
        try:
            robot = load_robot(self.robot)
        except ValueError as error:
            raise ConfigError(f"cell.robot: {error}") from None
        if self.start_joints_rad is not None and len(self.start_joints_rad) != robot.dof:
            raise ConfigError(f"cell.start_joints_rad has {len(self.start_joints_rad)} values; "
                              f"robot {robot.name} has {robot.dof} joints")
        check_static_objects(self.static_objects)


def check_registered(name: str, registry: Registry[Any], key: str) -> None:
    """Raise ConfigError unless `registry` has an entry `name` (the message lists them)."""
    if name not in registry:
        raise ConfigError(f"{key} must be one of {list(registry)}, got {brief(name)}")


MAX_RAYS_PER_AXIS = 4096
"""Largest sensor resolution along either image axis. A `DepthSensor` keeps 60 bytes per ray
(unit direction, distance scale, two depth buffers, MuJoCo's ray distance and geom id; 64 under
the structured-light model, which also keeps each pixel's triangle): about
0.3 GB for a Zivid 2+ frame (2448 x 2048) and 1.0 GB at this cap (4096 x 4096, 16.8 million rays),
plus the scan conversion's working arrays, which grow with the pixels the object covers. Real 3D
sensors stay below the cap; the `sensors/` presets give their own resolutions."""


MAX_FOV_DEG = 120.0
"""Widest opening angle along either image axis. The widest real depth cameras reach it (Azure
Kinect's wide mode: 120 x 120 deg; industrial 3D sensors stay near 50). A pinhole grid spreads
its rays evenly over +-tan(fov / 2), which grows without bound towards 180 deg (1.7 at 120 deg,
1146 at 179.9 deg): the rays then miss the object, and a plan finds no view."""


MAX_RANGE_M = 10.0
"""Farthest a sensor may measure (`far_m`, and so the working distance). The longest-range
structured-light and time-of-flight cameras measure to about 5 m, and the cell is 2 m across; the
occupancy update samples every ray half a voxel apart out to `far_m` (20,000 samples per ray at
10 m and 1 mm voxels), so a range of kilometres would take gigabytes."""

MAX_ACQUISITION_TIME_S = 60.0
"""Longest a sensor may stand still at a view (`acquisition_time_s`). Captures take 0.1 to a few
seconds; trajectories are sampled over the cycle time, so hours per view would take gigabytes."""


def check_resolution(resolution: tuple[int, int], key: str) -> None:
    """Raise ConfigError unless `resolution` is two integers in 1..MAX_RAYS_PER_AXIS."""
    values = tuple(resolution)
    if len(values) != 2 or not all(isinstance(rays, numbers.Integral)
                                   and 1 <= rays <= MAX_RAYS_PER_AXIS for rays in values):
        raise ConfigError(f"{key} must lie in 1..{MAX_RAYS_PER_AXIS} rays per axis, as two "
                          f"integers (width, height), got {brief(resolution)}")


def check_sensor(resolution: tuple[int, int], fov_deg: tuple[float, float], near_m: float,
                 far_m: float, working_distance_m: float) -> None:
    """The one check of a sensor's geometry, for `SensorConfig` and `SensorModel` alike.

    Raises:
        ConfigError: If the resolution is not two integers in 1..MAX_RAYS_PER_AXIS, an opening
            angle is not in (0, MAX_FOV_DEG] degrees, the range is not 0 <= near < far <=
            MAX_RANGE_M, or the working distance is not in (near_m, far_m].
    """
    check_resolution(resolution, "sensor.resolution")
    angles = tuple(fov_deg)
    if len(angles) != 2 or not all(0.0 < angle <= MAX_FOV_DEG for angle in angles):
        raise ConfigError(f"sensor.fov_deg must be two opening angles in (0, {MAX_FOV_DEG:g}] "
                          f"degrees, got {brief(list(angles))}")
    if not 0.0 <= near_m < far_m <= MAX_RANGE_M:
        raise ConfigError(f"sensor needs 0 <= near_m < far_m <= {MAX_RANGE_M:g} m, got "
                          f"near_m={brief(near_m)}, far_m={brief(far_m)}")
    if not near_m < working_distance_m <= far_m:
        # Views look at the object's centre from this distance: outside the range the
        # sensor measures nothing of the object's near side.
        raise ConfigError(f"sensor.working_distance_m must lie in (near_m, far_m] = "
                          f"({near_m:g}, {far_m:g}], got {working_distance_m:g}")


DEFAULT_HOUSING = Solid(shape="box", size_m=(0.2, 0.06, 0.08), position_m=(0.0, 0.0, -0.04))
"""The paper sensor's housing (an assumption: the paper gives none): 200 x 60 x 80 mm behind
the optical centre."""
MAX_PAYLOAD_KG = 35.0
"""Heaviest sensor: above the payload of every arm vprobot bundles, and of most 6-axis cobots."""


@dataclasses.dataclass(frozen=True)
class SensorConfig:
    """The 3D sensor (paper Table 4) and how it is mounted on the flange.

    Attributes:
        resolution: Rays along image x and y.
        fov_deg: Full opening angles along image x and y.
        near_m: Hits closer than this are dropped.
        far_m: Hits farther than this are dropped.
        working_distance_m: Optimal distance to the object's centre.
        mount_position_m: Optical centre in the flange frame (`tool0`).
        mount_quaternion_wxyz: Sensor frame orientation in the flange frame.
        sensing: How the rays' hits become points: a name in
            `vprobot.sensing.SENSING_MODELS`, `ideal` or `structured_light` (which needs
            `structured_light`).
        structured_light: The device's structured-light figures (baseline, incidence limits,
            noise, dropout); None where the sensor has none (the paper's).
        acquisition_time_s: How long the robot stands still at a view while the sensor
            acquires (s), a part of the cycle time (`vprobot.kinematics.trajectory`).
        housing: The sensor's housing, a collision shape in the sensor frame (origin at the
            optical centre, +z the viewing direction).
        mass_kg: The sensor's mass with its mount, the payload the programs set.
    """

    resolution: tuple[int, int] = (430, 300)
    fov_deg: tuple[float, float] = (27.0, 25.0)
    near_m: float = 0.30
    far_m: float = 0.50
    working_distance_m: float = 0.47
    mount_position_m: Vec3 = (0.0, 0.0, 0.09)
    mount_quaternion_wxyz: Quat = (1.0, 0.0, 0.0, 0.0)
    sensing: str = "ideal"
    structured_light: StructuredLight | None = None
    acquisition_time_s: float = 0.5
    housing: Solid = DEFAULT_HOUSING
    mass_kg: float = 0.8

    def __post_init__(self) -> None:
        check_within("sensor.mass_kg", self.mass_kg, 0.0, MAX_PAYLOAD_KG, "kg")
        check_sensor(self.resolution, self.fov_deg, self.near_m, self.far_m,
                     self.working_distance_m)
        check_sensing(self)
        if not is_rotation_quaternion(self.mount_quaternion_wxyz):
            raise ConfigError(f"sensor.mount_quaternion_wxyz must be a non-zero, finite "
                              f"quaternion (w, x, y, z), got {brief(self.mount_quaternion_wxyz)}")
        check_within("sensor.acquisition_time_s", self.acquisition_time_s, 0.0,
                     MAX_ACQUISITION_TIME_S, "s")

    @property
    def sensing_model(self) -> SensingModel:
        """The sensing model in use, as this sensor configures it (`IDEAL`, the sensor's
        `StructuredLight` figures, ...)."""
        return SENSING_MODELS[self.sensing].of_sensor(self)


SENSOR_MOUNT_KEYS = ("mount_position_m", "mount_quaternion_wxyz")
"""How the sensor sits on the flange: the cell's business, kept when `--sensor` swaps devices."""


def _preset_mapping(name: Any, key: str) -> dict[str, Any]:
    """The keys of preset `name` as written in its file: a bundled preset's name or the path
    of a preset file of one's own (`sensors/<name>.yaml`'s keys, anywhere)."""
    presets = available_sensors()
    try:
        path = bundled_or_path(name, {preset: SENSORS_DIR / f"{preset}.yaml"
                                      for preset in presets}, "sensor preset", "YAML file")
    except (ValueError, TypeError):
        raise ConfigError(f"{key} must name a sensor preset, one of {presets}, or a preset's "
                          f"YAML file, got {brief(name)}") from None
    data = read_yaml(path) or {}
    if not isinstance(data, Mapping) or "preset" in data:
        raise ConfigError(f"{path}: a sensor preset must be a mapping of sensor keys (no "
                          f"'preset' of its own)")
    return dict(data)


def _sensor_mapping(value: Any, key: str) -> Any:
    """A `sensor` section with its preset resolved: `NAME`, or a mapping that may name
    `preset: NAME` and override single keys of it; anything else is left to the schema."""
    if isinstance(value, str):
        return _preset_mapping(value, key)
    if isinstance(value, Mapping) and "preset" in value:
        overrides = {name: item for name, item in value.items() if name != "preset"}
        return {**_preset_mapping(value["preset"], f"{key}.preset"), **overrides}
    return value


def sensor_preset(name: str) -> SensorConfig:
    """The sensor of preset `name` with the default mount.

    Raises:
        ConfigError: If no preset has that name (the message lists the presets).
    """
    return from_mapping(SensorConfig, _preset_mapping(name, "sensor"), "sensor")


def with_sensing(config: Config, name: str) -> Config:
    """`config` with the sensor's sensing model `name` (one of `SENSING_MODELS`).

    Raises:
        ConfigError: If the name is unknown, or the sensor has no figures for that model.
    """
    return replace(config, "sensor", sensing=name)


def with_sensor(config: Config, name: str) -> Config:
    """`config` with the sensor of preset `name`, mounted where the config's sensor was.

    Raises:
        ConfigError: If no preset has that name.
    """
    mount = {key: getattr(config.sensor, key) for key in SENSOR_MOUNT_KEYS}
    return dataclasses.replace(config, sensor=dataclasses.replace(sensor_preset(name), **mount))


MIN_PATH_STEP_RAD = 1e-4
"""Finest resolution of the paths' collision checks (`path_max_joint_step_rad`): a tenth of a
millimetre at a metre from the joint. A move is checked at (its travel / the step)
configurations, all held at once: at 1e-9 rad a 1 rad move takes 48 GB."""


@dataclasses.dataclass(frozen=True)
class KinematicsConfig:
    """Inverse kinematics, collision and path settings.

    Attributes:
        position_tolerance_m: IK converged when the sensor is this close to the target.
        orientation_tolerance_deg: ... and its orientation (or viewing axis) this close.
        max_iterations: Iterations of one IK attempt.
        restarts: Extra IK attempts from other seeds when the warm start fails.
        max_step_rad: Largest joint change of one IK iteration (a trust region).
        damping: Levenberg-Marquardt damping of the IK least squares.
        path_max_joint_step_rad: Joint-space paths are collision-checked at this resolution.
        path_planner: `rrt_connect`: a move whose straight joint-space line collides goes around
            on a path planned by OMPL's RRT-Connect; `line`: only the straight line (such a
            move fails).
        path_planning_checks: RRT-Connect's budget per move in collision checks: a move
            without a path found within it fails (`path_not_found`). It ends a search at the
            same point on every machine (about 0.2 s on the 2-core reference machine), so runs
            repeat exactly.
        path_planning_time_s: A cap per move on top, in the planning thread's CPU time (not
            the wall clock, so a loaded machine does not change the plans), for a slower machine
            (a search it ends may end elsewhere on another machine).
        roll: `free` leaves the rotation about the optical axis to the IK; `fixed` demands it.
        seed: Seed of the restart configurations (deterministic verdicts).
    """

    position_tolerance_m: float = 0.001
    orientation_tolerance_deg: float = 0.5
    max_iterations: int = 60
    restarts: int = 8
    max_step_rad: float = 0.5
    damping: float = 1e-3
    path_max_joint_step_rad: float = 0.05
    path_planner: Literal["line", "rrt_connect"] = "rrt_connect"
    path_planning_checks: int = 20000
    path_planning_time_s: float = 1.0
    roll: Literal["free", "fixed"] = "free"
    seed: int = 0

    def __post_init__(self) -> None:
        positive = {
            "position_tolerance_m": self.position_tolerance_m,
            "orientation_tolerance_deg": self.orientation_tolerance_deg,
            "max_iterations": self.max_iterations,
            "max_step_rad": self.max_step_rad,
            "path_planning_checks": self.path_planning_checks,
            "path_planning_time_s": self.path_planning_time_s,
        }
        for name, value in positive.items():
            if not value > 0:
                raise ConfigError(f"kinematics.{name} must be > 0, got {value}")
        if not self.path_max_joint_step_rad >= MIN_PATH_STEP_RAD:
            raise ConfigError(f"kinematics.path_max_joint_step_rad must be >= "
                              f"{MIN_PATH_STEP_RAD:g} rad, got {self.path_max_joint_step_rad:g}")
        if self.restarts < 0 or self.damping < 0:
            raise ConfigError(
                f"kinematics.restarts and damping must be >= 0, got {self.restarts}, "
                f"{self.damping}"
            )


ActionName = Literal[
    "A_2S0R", "A_3S0R", "A_2S2R", "A_2S2R_lim", "A_3S2R", "A_3S2R_lim", "A_3C0R", "A_3C2R",
    "A_view",
]
TravelCostName = Literal["joint_time", "joint_path", "cartesian", "paper", "cycle_time"]
Selection = Literal["coverage", "goal_then_views", "goal_then_cycle"]
"""How a run's evaluations choose its best model (`AgentConfig.select`)."""
ROBOT_TRAVEL_COSTS = ("joint_time", "joint_path", "cycle_time")
"""Travel costs that exist only with a robot (joint space)."""


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """The inspection environment (docs/states-actions-rewards.md; paper Tables 1-4).

    Attributes:
        carrier: `robot` (the robot must reach every view) or `free` (the paper's free-flying
            sensor: every request is executed; travel is `cartesian` or `paper` only).
        state: `s_cov` (acquired cloud, model-free), `s_bin` (GT cloud + covered flag) or
            `s_grid` (per band candidate features from an occupancy grid, model-free; needs
            action `A_view`).
        robot_state: Add the sensor pose and joints as a second observation entry.
        action: Action variant (docs/states-actions-rewards.md#actions), or `A_view`
            (choose one of the band candidates; not with `stop_action`).
        position_mapping: `npk` (no prior knowledge: r in radius_range_m, x/y/z in
            +-cartesian_range_m) or `wpk` (r = working distance, Cartesian points kept at
            wpk_distance_range_m from the centre).
        radius_range_m: npk radius range of the spherical actions.
        cartesian_range_m: npk half-range of the Cartesian actions.
        wpk_distance_range_m: wpk distance range of the Cartesian actions.
        deviation_limit_deg: Largest deviation of the `_lim` actions from looking at the centre.
        reward: Reward R1-R14 (docs/states-actions-rewards.md#rewards): a name in
            `vprobot.rewards.REWARDS`.
        travel_cost: Which travel cost k_t the rewards use.
        travel_cost_floor: Lower bound of k_t and k_cum in divisions.
        unreachable_penalty: Added to the reward of an unreachable request.
        unreachable: `skip` (robot stays, nothing acquired) or `nearest` (acquire from the
            closest feasible pose the IK reached).
        initial_view: `fixed` (initial_phi_rad, initial_theta_rad at the working distance) or
            `random` (a random reachable view).
        coverage_goal: Episodes terminate at this coverage.
        max_acquisitions: Episodes are truncated after this many acquisitions (initial excluded).
        goal_only_step_cap: Safety cap of the steps of R13/R14 episodes (which end at the goal).
        stop_action: The agent also decides when to stop: one more action component, > 0
            stops. The episode then does not end at the goal; stopping pays +stop_reward at or
            above the coverage goal and -stop_reward below it, as does never stopping.
        stop_reward: Size of the stop decision's reward.
        object_yaw_range_deg: Object rotation about the vertical, uniform in +-this.
        object_tilt_range_deg: Tilt about x or y, uniform in +-this.
        parts: What episodes draw their part from: the bundled training or test motors
            (`train`, `test`), or `mesh` for one file (formerly `motors`).
        objects: What training draws from when parts is `train`: `motors` (the bundled
            training motors) and/or training families of the split (`vprobot.parts.splits`), e.g.
            `[motors, flange, housing]`; every source is drawn equally often.
        split: Version of that split (`configs/splits/v<N>.yaml`), which also sets the
            validation list: 1 (the committed tables) or 2 (adds the `procedural` family).
        mesh: Mesh file used when parts is `mesh`.
        mesh_scale: Scale applied to that mesh file (e.g. 0.001 for millimetres).
        resolution: Sensor resolution used in the environment; None keeps the sensor's.
        state_scale_m: Object-frame coordinates are divided by this in observations.
        state_points: Points in the state (paper: 2048).
    """

    carrier: Literal["robot", "free"] = "robot"
    state: Literal["s_cov", "s_bin", "s_grid"] = "s_cov"
    robot_state: bool = False
    action: ActionName = "A_3S2R_lim"
    position_mapping: Literal["npk", "wpk"] = "npk"
    radius_range_m: tuple[float, float] = (0.0, 1.0)
    cartesian_range_m: float = 1.0
    wpk_distance_range_m: tuple[float, float] = (0.20, 0.50)
    deviation_limit_deg: float = 10.0
    reward: str = "R2"
    travel_cost: TravelCostName = "joint_time"
    travel_cost_floor: float = 1e-3
    unreachable_penalty: float = 0.0
    unreachable: Literal["skip", "nearest"] = "skip"
    initial_view: Literal["fixed", "random"] = "fixed"
    initial_phi_rad: float = 1.42
    initial_theta_rad: float = 0.71
    coverage_goal: float = 0.90
    max_acquisitions: int = 10
    goal_only_step_cap: int = 50
    stop_action: bool = False
    stop_reward: float = 1.0
    object_yaw_range_deg: float = 180.0
    object_tilt_range_deg: float = 25.0
    parts: Literal["train", "test", "mesh"] = dataclasses.field(
        default="train", metadata={FORMERLY: "motors"})
    objects: tuple[str, ...] = ("motors",)
    split: int = 1
    mesh: str | None = None
    mesh_scale: float = 1.0
    resolution: tuple[int, int] | None = None
    state_scale_m: float = 0.25
    state_points: int = 2048

    def __post_init__(self) -> None:
        check_registered(self.reward, REWARDS, "env.reward")
        if self.parts == "mesh" and self.mesh is None:
            raise ConfigError("env.mesh must name a mesh file when env.parts is 'mesh'")
        try:
            split_file(self.split)
        except ValueError as error:
            raise ConfigError(f"env.split: {error}") from None
        if self.objects != ("motors",):
            if self.parts != "train":
                raise ConfigError(f"env.objects {list(self.objects)} applies to training "
                                  f"(env.parts: train), not to env.parts {self.parts!r}")
            try:
                Split.bundled(self.split).check_sources(self.objects)
            except ValueError as error:
                raise ConfigError(str(error)) from None
        if self.parts != "mesh" and self.mesh is not None:
            raise ConfigError(f"env.mesh is set ({brief(self.mesh)}) but env.parts is "
                              f"{self.parts!r}, which would ignore it; set env.parts to 'mesh' "
                              f"or drop env.mesh")
        if self.resolution is not None:
            check_resolution(self.resolution, "env.resolution")
        if not 0.0 < self.coverage_goal <= 1.0:
            raise ConfigError(f"env.coverage_goal must lie in (0, 1], got {self.coverage_goal}")
        for name in ("max_acquisitions", "goal_only_step_cap", "state_points"):
            if getattr(self, name) < 1:
                raise ConfigError(f"env.{name} must be >= 1, got {getattr(self, name)}")
        for name in ("travel_cost_floor", "state_scale_m", "cartesian_range_m", "mesh_scale"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"env.{name} must be > 0, got {getattr(self, name)}")
        low, high = self.wpk_distance_range_m
        if not 0.0 < low <= high:
            raise ConfigError(f"env.wpk_distance_range_m must satisfy 0 < low <= high, got "
                              f"{self.wpk_distance_range_m}")
        if (self.carrier == "free" and self.travel_cost in ROBOT_TRAVEL_COSTS
                and REWARDS[self.reward].uses_travel):
            raise ConfigError(f"env.travel_cost {self.travel_cost!r} needs the robot, but "
                              f"env.carrier is 'free' and env.reward {self.reward} uses the "
                              f"travel cost; use 'cartesian' or 'paper'")
        if self.state == "s_grid" and self.action != "A_view":
            raise ConfigError(f"env.state 's_grid' describes the band candidates of env.action "
                              f"'A_view', not env.action {self.action!r}; set env.action to "
                              f"'A_view' or env.state to 's_cov' or 's_bin'")
        if self.action == "A_view" and self.stop_action:
            raise ConfigError("env.action 'A_view' has no stop decision yet: set "
                              "env.stop_action to false or choose a continuous env.action")
        if not 0.0 <= self.radius_range_m[0] <= self.radius_range_m[1]:
            raise ConfigError(f"env.radius_range_m must satisfy 0 <= low <= high, got "
                              f"{self.radius_range_m}")


@dataclasses.dataclass(frozen=True)
class AgentConfig:
    """A reinforcement-learning agent and how it is trained (`vprobot train`, docs/agents.md).

    The defaults are the paper's Table 4 (`configs/agents/paper.yaml`);
    `configs/agents/cpu.yaml` is the profile that trains on a small CPU.

    Attributes:
        algorithm: `sac` (off-policy, replay buffer), `ppo` (on-policy) or `dqn` (off-policy,
            a Q-value per candidate view: needs `encoder: candidates` and an env whose action
            is a choice among candidate views, `vprobot.agents.candidate_q`).
        encoder: A name in `vprobot.agents.encoders.ENCODERS`: a point-cloud feature
            extractor, `pcn`, `pointnet` or `sphere` (CPU budget); or `candidates`, the
            Q-network of `dqn` (one shared MLP per candidate row). Checked, with the algorithm
            it serves, where the agent is built or loaded (`vprobot.agents.encoders.
            check_encoder`), not here: the encoders' modules import torch, a config does not.
        encoder_settings: The encoders' own settings by encoder name, each the keys of the
            dataclass the encoder declares beside its network
            (`vprobot.agents.encoders.Encoder.settings`), checked with the encoder
            (`check_encoder`); `agent.encoder`'s are used, keys left out keep their defaults.
            `pcn` and `pointnet`: `scale` multiplies their widths (1: published sizes);
            `sphere`: `bins`, the polar and azimuth bins of its direction map, and `features`,
            the size of its encoding.
        net_arch: Hidden layers of the regression MLP after the encoder (actor and critics);
            with `candidates`, of the MLP applied to every candidate row (the first width is
            also that of the row embedding the pooled context is taken from).
        learning_rate: Initial learning rate.
        learning_rate_schedule: `linear` decays it to 0 over `total_steps`; `constant` keeps it.
        gamma: Discount factor; 0 learns the immediate reward only (a contextual bandit).
        batch_size: Minibatch of a gradient step.
        buffer_size: Replay buffer transitions (SAC, DQN).
        learning_starts: Env steps before the first SAC or DQN update (DQN explores uniformly
            over the allowed candidates until then).
        train_freq: Env steps between SAC or DQN updates.
        gradient_steps: Gradient steps per SAC or DQN update.
        target_update_interval: Env steps between copies of the DQN Q-network into its target.
        exploration_fraction: Share of `total_steps` over which DQN's epsilon (the probability
            of a uniformly drawn allowed candidate) falls from its initial to its final value.
        exploration_initial_eps: DQN's epsilon at the start.
        exploration_final_eps: DQN's epsilon after the exploration fraction.
        pretrain_episodes: With `dqn`: episodes of the model-based teacher whose states the
            Q-network is fitted to before RL (`vprobot.training.pretrain`; 0: none).
        pretrain_epochs: Passes over those states.
        pretrain_target: What the network is fitted to: `values`, the teacher's value of every
            candidate (least squares, a Q-function); `cover`, whether each candidate is in
            some smallest remaining cover (`CandidateTeacher.views_to_goal`; binary
            cross-entropy on logits, members weighted `COVER_POSITIVE_WEIGHT`), the scores of a
            plan's members; `views`, the candidate's value minus its views to the goal beyond
            the state's fewest (least squares). See `vprobot.training.pretrain.fit_labels`.
            With `cover` and `views` the network also has the head of the views left, fitted
            to the state's fewest views to the goal (`CandidateQNetwork.views_left`).
        teacher_seed: The seed the teacher's episodes are drawn from (None: the run's seed);
            runs that share it and `teacher_dir` share the teacher's states.
        teacher_dir: The folder the teacher's states are kept in, shard by shard (None: the
            run's `teacher/`); relative to where the command runs.
        rollout_agent: A trained agent (a bundled name, a run folder or a model file) whose
            greedy choices drive the teacher's episodes in place of the teacher's best (one
            time in five a random allowed one, as before): the teacher then labels the states
            the agent itself visits (DAgger). None: the teacher's own choices.
        more_teacher_dirs: Teacher folders whose states are fitted too, beside `teacher_dir`'s
            (made by `vprobot teacher` in the same cell, sensor, kinematics and env, e.g. with
            another `rollout_agent`); relative to where the command runs.
        n_steps: Env steps per PPO rollout (per env).
        n_epochs: PPO epochs per rollout.
        total_steps: Env steps of a training run.
        n_envs: Environments stepped in parallel (subprocesses when more than one).
        eval_freq: Env steps between evaluations on the validation episodes of what the run
            trains on (`vprobot.episode.specs.validation_episodes`): they select the best model.
        eval_episodes: How many of those episodes an evaluation runs (None: all).
        select: Which evaluation's model is the best: `coverage` (the highest mean coverage,
            fewer acquisitions breaking ties) or `goal_then_views` (the most episodes at the
            coverage goal, then the fewest acquisitions, then the highest coverage: once every
            episode reaches the goal, coverage first favours more views) or `goal_then_cycle`
            (the cell's terms: the most episodes at the goal, then the fewest requests, failed
            ones included, then the shortest cycle time, then the highest coverage).
        test_lists: Bundled episode lists a finished run's best model is scored on, once
            (`vprobot.training.train.score_test_lists`; None: none); never during training.
        checkpoint_freq: Env steps between checkpoints (with the replay buffer).
        torch_threads: Threads of torch in the training process.
        device: `cpu`, `cuda` or `auto` (cuda when present).
    """

    algorithm: Literal["sac", "ppo", "dqn"] = "sac"
    encoder: str = "pcn"
    # Left out of the hash (a dict has none); equal configs still hash equally.
    encoder_settings: dict[str, Any] = dataclasses.field(default_factory=dict, hash=False)
    net_arch: tuple[int, int] = (128, 64)
    learning_rate: float = 7.8e-5
    learning_rate_schedule: Literal["constant", "linear"] = "linear"
    gamma: float = 0.9
    batch_size: int = 256
    buffer_size: int = 75_000
    learning_starts: int = 1_000
    train_freq: int = 1
    gradient_steps: int = 1
    target_update_interval: int = 1_000
    exploration_fraction: float = 0.2
    exploration_initial_eps: float = 1.0
    exploration_final_eps: float = 0.05
    pretrain_episodes: int = 0
    pretrain_epochs: int = 20
    pretrain_target: Literal["values", "cover", "views"] = "values"
    teacher_seed: int | None = None
    teacher_dir: str | None = None
    rollout_agent: str | None = None
    more_teacher_dirs: tuple[str, ...] | None = None
    n_steps: int = 1_024
    n_epochs: int = 10
    total_steps: int = 75_000
    n_envs: int = 1
    eval_freq: int = 5_000
    eval_episodes: int | None = None
    select: Selection = "coverage"
    test_lists: tuple[str, ...] | None = ("test-v1", "families-test-v1", "shapes-v1")
    checkpoint_freq: int = 5_000
    torch_threads: int = 1
    device: Literal["cpu", "cuda", "auto"] = "cpu"

    def __post_init__(self) -> None:
        for name in ("batch_size", "buffer_size", "train_freq",
                     "gradient_steps", "target_update_interval", "n_steps", "n_epochs",
                     "total_steps", "n_envs", "pretrain_epochs",
                     "eval_freq", "checkpoint_freq", "torch_threads"):
            if getattr(self, name) < 1:
                raise ConfigError(f"agent.{name} must be >= 1, got {getattr(self, name)}")
        unknown = [name for name in self.test_lists or () if name not in BUNDLED_EPISODE_LISTS]
        if unknown:
            raise ConfigError(f"agent.test_lists must name bundled episode lists "
                              f"({', '.join(BUNDLED_EPISODE_LISTS)}), got {brief(unknown[0])}")
        if self.eval_episodes is not None and self.eval_episodes < 1:
            raise ConfigError(f"agent.eval_episodes must be >= 1 (or null for all), got "
                              f"{self.eval_episodes}")
        if min(self.net_arch) < 1:
            raise ConfigError(f"agent.net_arch must be positive widths, got {brief(self.net_arch)}")
        if self.learning_starts < 0:
            raise ConfigError(f"agent.learning_starts must be >= 0, got {self.learning_starts}")
        if not self.learning_rate > 0:
            raise ConfigError(f"agent.learning_rate must be > 0, got {self.learning_rate}")
        if not 0.0 <= self.gamma <= 1.0:
            raise ConfigError(f"agent.gamma must lie in [0, 1], got {self.gamma}")
        if not 0.0 < self.exploration_fraction <= 1.0:
            raise ConfigError(f"agent.exploration_fraction must lie in (0, 1], got "
                              f"{self.exploration_fraction}")
        if self.pretrain_episodes < 0:
            raise ConfigError(f"agent.pretrain_episodes must be >= 0, got "
                              f"{self.pretrain_episodes}")
        if self.teacher_seed is not None and self.teacher_seed < 0:
            raise ConfigError(f"agent.teacher_seed must be >= 0 (or null for the run's seed), "
                              f"got {self.teacher_seed}")
        if self.pretrain_episodes and self.algorithm != "dqn":
            raise ConfigError(f"agent.pretrain_episodes fits a candidate Q-network: it needs "
                              f"agent.algorithm dqn, got {self.algorithm!r}")
        if not 0.0 <= self.exploration_final_eps <= self.exploration_initial_eps <= 1.0:
            raise ConfigError(f"agent needs 0 <= exploration_final_eps <= "
                              f"exploration_initial_eps <= 1, got "
                              f"{self.exploration_final_eps}, {self.exploration_initial_eps}")


_FORMER_ENCODER_KEYS = {"encoder_scale": ("scale", ("pcn", "pointnet"), 1.0),
                        "sphere_bins": ("bins", ("sphere",), [8, 16]),
                        "sphere_features": ("features", ("sphere",), 128)}
"""The `agent` keys of the encoders' settings before the encoders owned them: each the key it
became under the name of each encoder that reads it in `agent.encoder_settings`, and its
default then (the encoders' default now: a value equal to it sets nothing)."""


def _agent_mapping(value: Any, key: str) -> Any:
    """An `agent` section with the former keys of the encoders' settings moved into
    `encoder_settings`, with a `FutureWarning`: configs and runs written before stay usable for
    one release."""
    if not isinstance(value, Mapping) or not set(value) & set(_FORMER_ENCODER_KEYS):
        return value
    former = [name for name in _FORMER_ENCODER_KEYS if name in value]
    warnings.warn(f"{', '.join(f'{key}.{name}' for name in former)}: an encoder's settings are "
                  f"now keys of {key}.encoder_settings.<encoder> (pcn and pointnet: scale; "
                  f"sphere: bins, features); the old keys will not be read after the next "
                  f"release", FutureWarning, stacklevel=2)
    settings = {name: dict(given) for name, given in (value.get("encoder_settings") or {}).items()}
    for name in former:
        setting, readers, default = _FORMER_ENCODER_KEYS[name]
        given = list(value[name]) if isinstance(value[name], list | tuple) else value[name]
        for reader in readers if given != default else ():
            settings.setdefault(reader, {})[setting] = value[name]
    return {**{name: item for name, item in value.items() if name not in _FORMER_ENCODER_KEYS},
            "encoder_settings": settings}


@dataclasses.dataclass(frozen=True)
class Config:
    """The whole vprobot configuration."""

    cell: CellConfig = dataclasses.field(default_factory=CellConfig)
    sensor: SensorConfig = dataclasses.field(default_factory=SensorConfig,
                                             metadata={RESOLVE: _sensor_mapping})
    kinematics: KinematicsConfig = dataclasses.field(default_factory=KinematicsConfig)
    env: EnvConfig = dataclasses.field(default_factory=EnvConfig)
    agent: AgentConfig = dataclasses.field(default_factory=AgentConfig,
                                           metadata={RESOLVE: _agent_mapping})


def replace(config: Config, section: str, **changes: Any) -> Config:
    """Return a copy of `config` with fields of one section changed (validated); a dotted name
    (`encoder_settings.pcn.scale`) changes one key inside a mapping field."""
    current = dataclasses.asdict(getattr(config, section))
    for name, value in with_current_keys(type(getattr(config, section)), changes,
                                         section).items():
        _set_key(current, name, value, section)
    # What a file's section goes through first (the former keys of the agent's encoder) too.
    resolve = next(field.metadata.get(RESOLVE) for field in dataclasses.fields(Config)
                   if field.name == section)
    mapping = resolve(current, section) if resolve is not None else current
    return dataclasses.replace(config, **{section: from_mapping(
        type(getattr(config, section)), mapping, section)})


def _set_key(mapping: dict[str, Any], name: str, value: Any, key: str) -> None:
    """Set `mapping[name]`, or with a dotted name the key inside the nested mappings (made
    where missing)."""
    outer, dot, inner = name.partition(".")
    if not dot:
        mapping[name] = value
        return
    nested = mapping.get(outer)
    if nested is None:
        nested = {}
    elif not isinstance(nested, dict):
        raise ConfigError(f"{key}.{name}: {key}.{outer} is {brief(nested)}, not a mapping of keys")
    mapping[outer] = nested = dict(nested)
    _set_key(nested, inner, value, f"{key}.{outer}")


def config_document(config: Config) -> dict[str, Any]:
    """The config as plain YAML and JSON data (tuples as lists)."""
    return json.loads(json.dumps(dataclasses.asdict(config)))


def load_config(path: str | Path | None = None) -> Config:
    """Load a YAML config; `None` gives `configs/default.yaml`.

    Raises:
        FileNotFoundError: If the file does not exist.
        ConfigError: If it does not match the schema.
    """
    path = Path(path) if path is not None else DEFAULT_CONFIG
    if not path.is_file():
        raise FileNotFoundError(f"config file not found: {path}")
    data = read_yaml(path) or {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: the top level must be a mapping of sections")
    try:
        return from_mapping(Config, with_cell_file(data, path))
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None
