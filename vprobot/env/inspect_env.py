"""`vprobot/Inspect-v0`: plan inspection views with the robot in the loop (SPEC sections 6-8).

Each episode places a motor (drawn from the train or test split, or one fixed mesh) on the
fixture, turns it about the vertical by U[-180, 180] deg and tilts it by U[-25, 25] deg about x
or y, puts the robot at `home` and makes the initial acquisition. Each step maps the action to a
requested sensor pose, lets the robot reach it (IK, limits, collisions, joint-space path),
acquires a point cloud there and updates the coverage. An unreachable request uses up a step:
with `unreachable: skip` the robot stays and nothing is acquired; with `nearest` the robot goes
to the closest feasible configuration the IK reached and acquires there.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from vprobot.config import Config, load_config, replace
from vprobot.env.actions import ActionMapping
from vprobot.env.observations import observation_space, resample, robot_state, scaled
from vprobot.env.rewards import Reward, RewardTerms
from vprobot.episode import EpisodeRecord
from vprobot.geometry import Pose
from vprobot.inspection import (
    Inspection,
    MotorScene,
    StepOutcome,
    initial_view_target,
    random_object_rotation,
)
from vprobot.kinematics import TRAVEL_COSTS, SensorTarget, TravelCost
from vprobot.paths import MOTORS_DIR
from vprobot.viewsphere import sphere_directions

RANDOM_INITIAL_TRIES = 50
INITIAL_MAX_POLAR_RAD = np.deg2rad(120.0)


def motor_files(config: Config) -> list[Path]:
    """The mesh files episodes draw from.

    Raises:
        FileNotFoundError: If the split folder holds no STL files or the mesh file is missing.
    """
    env = config.env
    if env.motors == "mesh":
        path = Path(env.mesh)
        if not path.is_file():
            raise FileNotFoundError(f"env.mesh not found: {path}")
        return [path]
    files = sorted((MOTORS_DIR / env.motors).glob("*.stl"))
    if not files:
        raise FileNotFoundError(f"no motors (*.stl) in {MOTORS_DIR / env.motors}")
    return files


class InspectEnv(gym.Env):
    """Inspection planning environment.

    Args:
        config: A `Config`, a YAML path, or None for `configs/default.yaml`.
        render_mode: None or `rgb_array`.
        **env_overrides: Fields of the config's `env` section to change (validated), e.g.
            `action="A_2S0R", reward="R5", state="s_bin"`.

    Raises:
        ConfigError: On an unknown or invalid env field.
        ValueError: On an unsupported render mode.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, config: Config | str | Path | None = None,
                 render_mode: str | None = None, **env_overrides: Any):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if not isinstance(config, Config):
            config = load_config(config)
        if env_overrides:
            config = replace(config, "env", **env_overrides)
        self.config = config
        self.render_mode = render_mode
        self.motor_files = motor_files(config)
        self.actions = ActionMapping(config.env, config.sensor.working_distance_m)
        self.reward_function = Reward(config.env.reward, config.env.travel_cost_floor,
                                      config.env.unreachable_penalty)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (self.actions.size,), dtype=np.float32)
        self.observation_space = observation_space(config.env)
        self.step_limit = (config.env.goal_only_step_cap if self.reward_function.goal_only
                           else config.env.max_acquisitions)
        self._scenes: dict[Path, MotorScene] = {}
        self._renderer = None
        self._renderer_cell = None
        self.inspection: Inspection | None = None
        self._done = True

    def __getstate__(self) -> dict[str, Any]:
        # MuJoCo handles, thread pools and GL contexts do not pickle: a copy is rebuilt from the
        # config and starts from a fresh reset, as a subprocess vector env does.
        return {"config": self.config, "render_mode": self.render_mode}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["config"], state["render_mode"])

    def scene(self, path: Path) -> MotorScene:
        """The (cached) scene of one motor file."""
        if path not in self._scenes:
            env = self.config.env
            scale = env.mesh_scale if env.motors == "mesh" else 1.0
            self._scenes[path] = MotorScene.load(self.config, path, scale, env.resolution)
        return self._scenes[path]

    def _initial_targets(self, center: np.ndarray) -> list[SensorTarget]:
        """The fixed paper pose, or random look-at views drawn from np_random."""
        env, radius = self.config.env, self.config.sensor.working_distance_m
        if env.initial_view == "fixed":
            return [initial_view_target(self.config, center)]
        directions = sphere_directions(4 * RANDOM_INITIAL_TRIES, INITIAL_MAX_POLAR_RAD)
        chosen = self.np_random.choice(len(directions), RANDOM_INITIAL_TRIES, replace=False)
        return [SensorTarget.look_at(center + radius * directions[i], center) for i in chosen]

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Start an episode.

        Args:
            seed: Seeds `self.np_random`, from which everything random is drawn.
            options: `motor` (index into `motor_files`) to choose the motor.

        Raises:
            RuntimeError: If no initial view is reachable.
        """
        super().reset(seed=seed)
        options = options or {}
        index = options.get("motor", int(self.np_random.integers(len(self.motor_files))))
        if not 0 <= index < len(self.motor_files):
            raise ValueError(f"options['motor'] must lie in 0..{len(self.motor_files) - 1}, "
                             f"got {index}")
        self.inspection = Inspection(self.scene(self.motor_files[index]),
                                     random_object_rotation(self.config.env, self.np_random))
        for target in self._initial_targets(self.inspection.center):
            outcome = self.inspection.request(target)
            if outcome.view.reachable:
                break
        else:
            raise RuntimeError("no initial view is reachable; check the cell placement")
        self.steps = 0
        self._done = False
        return self._observation(), self._info(outcome, None)

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Request the view of `action`.

        Raises:
            ValueError: For an action of the wrong shape, NaN or outside [-1, 1].
            RuntimeError: If the episode is over (call `reset`).
        """
        if self._done or self.inspection is None:
            raise RuntimeError("the episode is over: call reset() before step()")
        requested = self.actions.view(action)
        inspection = self.inspection
        pose = Pose(requested.pose.position + inspection.center, requested.pose.rotation)
        roll_free = self.config.kinematics.roll == "free"
        if requested.looks_at_center and roll_free:
            target = SensorTarget.look_at(pose.position, inspection.center)
        else:
            target = SensorTarget(pose, roll_free=roll_free)
        coverage_before = inspection.coverage
        outcome = inspection.request(target, self.config.env.unreachable)
        self.steps += 1
        terminated = inspection.coverage >= self.config.env.coverage_goal
        truncated = not terminated and self.steps >= self.step_limit
        self._done = terminated or truncated
        travel = getattr(outcome.view.travel, self.config.env.travel_cost)
        travel_sum = getattr(inspection.travel_sum, self.config.env.travel_cost)
        terms = self.reward_function.step(
            delta=inspection.coverage - coverage_before,
            remaining_before=1.0 - coverage_before,
            travel=travel,
            reachable=outcome.view.reachable,
            episode_over=self._done,
            goal_reached=terminated,
            final_coverage=inspection.coverage,
            steps=self.steps,
            travel_sum=travel_sum,
        )
        return (self._observation(), float(terms.reward), terminated, truncated,
                self._info(outcome, terms))

    def _observation(self) -> Any:
        inspection = self.inspection
        env = self.config.env
        rotation = inspection.object_pose.rotation
        if env.state == "s_cov":
            cloud = inspection.tracker.accumulated_cloud @ rotation.T
            points = scaled(resample(cloud, env.state_points, self.np_random), env)
        else:
            gt = inspection.scene.ground_truth.points @ rotation.T
            points = np.column_stack([scaled(gt, env), inspection.tracker.covered])
        points = points.astype(np.float32)
        if not env.robot_state:
            return points
        state = robot_state(inspection.sensor_pose(), inspection.center, inspection.q, env)
        return {"points": points, "robot": state}

    def _info(self, outcome: StepOutcome, terms: RewardTerms | None) -> dict[str, Any]:
        inspection = self.inspection
        view = outcome.view
        sensor = inspection.sensor_pose()
        travel: TravelCost = view.travel
        info: dict[str, Any] = {
            "coverage": inspection.coverage,
            "delta_coverage": 0.0 if outcome.coverage is None else outcome.coverage.delta,
            "reachable": view.reachable,
            "reason": view.reason,
            "joints": inspection.q.copy(),
            "sensor_position": sensor.position,
            "sensor_quaternion": sensor.quaternion,
            "acquisitions": len(inspection.tracker.steps),
            "points_acquired": len(view.points_world),
            "motor": str(inspection.scene.mesh.path),
        }
        for name in TRAVEL_COSTS:
            info[f"travel_{name}"] = getattr(travel, name)
            info[f"travel_sum_{name}"] = getattr(inspection.travel_sum, name)
        if terms is not None:
            info["reward_terms"] = dataclasses.asdict(terms)
        return info

    def episode_record(self) -> EpisodeRecord:
        """The episode so far (for rendering and plan export)."""
        if self.inspection is None:
            raise RuntimeError("no episode yet: call reset() first")
        return self.inspection.record()

    def render(self) -> np.ndarray | None:
        """An RGB frame of the cell (`render_mode="rgb_array"`), else None."""
        if self.render_mode != "rgb_array" or self.inspection is None:
            return None
        from vprobot.render.camera import aim_overview
        from vprobot.render.offscreen import OffscreenView

        cell = self.inspection.scene.cell
        if self._renderer is None or self._renderer_cell is not cell:
            self.close()
            self._renderer = OffscreenView(cell.model, 640, 480)
            self._renderer_cell = cell
            aim_overview(self._renderer.camera, cell)
        forward = self.inspection.scene.arm.forward
        forward.set_configuration(self.inspection.q)
        self._renderer.update(forward.data)
        return self._renderer.rgb()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
