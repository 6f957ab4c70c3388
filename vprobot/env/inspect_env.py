"""`vprobot/Inspect-v0`: plan inspection views with the robot in the loop
(docs/states-actions-rewards.md).

Each episode places a part (a motor drawn from the train or test split, or one fixed mesh) on the
fixture, turns it about the vertical by U[-180, 180] deg and tilts it by U[-25, 25] deg about x
or y, puts the robot at `home` and makes the initial acquisition; all of it is an episode spec
(`vprobot.episode.EpisodeSpec`) drawn from `np_random`, or passed with
`reset(options={"episode": spec})` to run a fixed evaluation episode. Each step maps the action
to a requested sensor pose and executes it through the episode's carrier: with `carrier: robot`
the robot must reach it (IK, limits, collisions, joint-space path) and an unreachable request
uses up a step (`unreachable: skip`: the robot stays and nothing is acquired; `nearest`: the
robot goes to the closest feasible configuration the IK reached and acquires there); with
`carrier: free` the sensor flies to every requested pose, as in the paper.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import gymnasium as gym
import numpy as np

from vprobot.compute.native_memory import release_freed_memory
from vprobot.config import Config, load_config, replace
from vprobot.coverage.ground_truth import ground_truth
from vprobot.env.actions import ActionMapping
from vprobot.env.observations import Observer, observation_space
from vprobot.env.rewards import Reward, RewardTerms, step_limit
from vprobot.episode import (
    Episode,
    EpisodeRecord,
    EpisodeSpec,
    PartScene,
    ViewRecord,
    sample_episode,
)
from vprobot.files.paths import MOTORS_DIR
from vprobot.kinematics import TRAVEL_COSTS
from vprobot.parts.generated import generated_path, is_generated
from vprobot.parts.loading import load_mesh
from vprobot.parts.splits import Split

if TYPE_CHECKING:
    from vprobot.cell.scene import Cell
    from vprobot.render.offscreen import OffscreenView

SCENES_KEPT = 16
"""Scenes an env keeps loaded, the most recently used (each holds a compiled cell, about 14 MB):
on the family mix nearly every episode draws a new instance, so a larger cache mostly held
memory (64 kept about 0.9 GB per env process; a two-env training took about 8 GB in all), and a
scene loads again in about 0.1 s. An evicted scene's freed C-heap memory is returned to the
system (`vprobot.compute.native_memory`)."""
SEED_BOUND = 2**31
"""Episode specs drawn by the env carry a seed below this, drawn from np_random."""


def part_files(config: Config) -> list[str | Path]:
    """The objects episodes draw from: mesh files, or generated objects' names (made when an
    episode first draws them, `vprobot.parts.generated`).

    Raises:
        FileNotFoundError: If the split folder holds no STL files or the mesh file is missing.
    """
    env = config.env
    if env.parts == "mesh":
        assert env.mesh is not None  # EnvConfig requires it for parts "mesh"
        path = Path(env.mesh)
        if not path.is_file():
            raise FileNotFoundError(f"env.mesh not found: {path}")
        return [path]
    if env.parts == "train":
        return Split.bundled(env.split).training_objects(env.objects)
    files: list[str | Path] = sorted((MOTORS_DIR / env.parts).glob("*.stl"))
    if not files:
        raise FileNotFoundError(f"no motors (*.stl) in {MOTORS_DIR / env.parts}")
    return files


def build_training_objects(config: Config, progress: bool = True) -> int:
    """Build every object a config trains on and its ground truth, once (both are cached), so
    that training does not pay for them while it runs. Returns the number of objects.

    Raises:
        ValueError: For a source the split does not train on (`Split.check_sources`).
    """
    from tqdm import tqdm

    env = config.env
    scale = env.mesh_scale if env.parts == "mesh" else 1.0  # as the env's episodes draw them
    names = list(dict.fromkeys(part_files(config)))
    for name in tqdm(names, desc="objects", unit="object", disable=not progress):
        path = generated_path(str(name)) if is_generated(str(name)) else name
        ground_truth(load_mesh(path, scale).mesh, config)
    return len(names)


class InspectEnv(gym.Env):
    """Inspection planning environment (docs/states-actions-rewards.md; the paper's Tables 1-4).

    ## Observation
    | state | content |
    |---|---|
    | `s_cov` | (state_points, 3): the accumulated acquired cloud P_cov, resampled (model-free) |
    | `s_bin` | (state_points, 4): GT points plus a 0/1 "covered" column (needs the model) |
    | `s_grid` | Dict `candidates` (K, 19; 22 structured light), `mask` (K,); K = 128 (`A_view`) |
    | `robot_state` | adds a Dict entry `robot` (15,): sensor position, its x and z axes, joints |

    Coordinates are object-centred (world-aligned axes), divided by `state_scale_m`.

    `s_grid` (`env.grid_state`) keeps the episode's occupancy grid, as `nbv` does, and gives one
    row per band candidate, in the order of the `A_view` actions:

    | column | feature | range |
    |---|---|---|
    | 0-2 | gains `unknown`, `frontier`, `rear_side` / (rays x a ray's largest gain) | [0, 1] |
    | 3-5 | the same / the largest of an offered candidate (1: `nbv`'s pick) | [0, 1] |
    | 6-8 | the candidate's direction from the centre (object frame, world axes) | [-1, 1] |
    | 9 | cosine to the closest earlier request, taken or failed (-1: none) | [-1, 1] |
    | 10 | cosine to the sensor's current direction (how far the move is) | [-1, 1] |
    | 11 | 1 if the sensor is at the candidate (within 1 deg) | {0, 1} |
    | 12 | 1 if the carrier failed to reach the candidate earlier in the episode | {0, 1} |
    | 13 | 1 if the robot reaches it (screened once per episode; always 1 free-flying) | {0, 1} |
    | 14 | largest joint move to its screened configuration / pi (0 free-flying) | [0, 1] |
    | 15 | requests used of the budget (the step limit) | [0, 1] |
    | 16-18 | shares of the grid's voxels occupied, free, unknown | [0, 1] |
    | 19 | under structured light: the revisit gain (`ViewGains.revisits`) / rays | [0, 1] |
    | 20 | the same / the largest of an offered candidate | [0, 1] |
    | 21 | the share of the known surface the reachable candidates would still measure | [0, 1) |

    The gains are what the candidate's sensor would measure (`ViewGains.scores`): under
    structured light only what its projector lights within both incidence limits, otherwise
    what the camera sees. Columns 15-18 and 21 are the same on every row. `mask` is 1 where the
    candidate may be requested: reachable, not within 10 deg (`views.EXCLUDE_DEG`) of an
    earlier request, taken or failed, and not failed; if that leaves none, every candidate that
    did not fail is unmasked.

    ## Action
    Box [-1, 1]^n of the `action` variant: A_2S0R (2), A_3S0R (3), A_2S2R (4), A_2S2R_lim (4),
    A_3S2R (5), A_3S2R_lim (5, paper default), A_3C0R (3), A_3C2R (5); see `env.actions`.
    `A_view` is Discrete(K): action k requests band candidate k, the look-at view at the working
    distance that `nbv` requests (not with `stop_action`).

    ## Reward
    R1-R8 dense (coverage gain, remaining coverage, travel cost k_t: `env.travel_cost`, one of
    joint_time, joint_path, cartesian, paper, cycle_time), R9-R14 sparse at the last
    step (final coverage, steps T, k_cum over the steps; the approach to the initial view is not
    a step); `unreachable_penalty` is added to an unreachable request. `info["reward_terms"]`
    holds the terms.

    ## Episode end
    `terminated` when coverage >= `coverage_goal` (0.90); `truncated` after `max_acquisitions`
    (10) requests, or `goal_only_step_cap` for R13/R14, which end only at the goal.

    ## Info
    coverage, delta_coverage, reachable, reason, carrier, joints, sensor_position,
    sensor_quaternion, acquisitions, reachable_share (of the views requested so far),
    points_acquired, part, episode_seed, travel_<cost>,
    travel_sum_<cost> (k_cum), approach_<cost> for cost in joint_time, joint_path, cartesian,
    paper and cycle_time, and reward_terms (after a step); on the episode's last step also
    cycle_time: the cell's cycle time of the part (approach, moves, acquisitions, return home;
    None without a robot or a path home).

    Args:
        config: A `Config`, a YAML path, or None for `configs/default.yaml`.
        render_mode: None or `rgb_array`.
        **env_overrides: Fields of the config's `env` section to change (validated), e.g.
            `action="A_2S0R", reward="R5", state="s_bin"`.

    Raises:
        ConfigError: On an unknown or invalid env field.
        ValueError: On an unsupported render mode.
    """

    # gymnasium annotates `metadata` as an instance variable; it is read from the class.
    metadata: ClassVar[dict[str, Any]] = {  # type: ignore[misc]
        "render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, config: Config | str | Path | None = None,
                 render_mode: str | None = None, **env_overrides: Any):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if not isinstance(config, Config):
            config = load_config(config)
        if "mesh" in env_overrides and env_overrides["mesh"] is not None:
            # Naming a mesh means training on it, unless parts says otherwise (then an error).
            env_overrides.setdefault("parts", "mesh")
        if env_overrides:
            config = replace(config, "env", **env_overrides)
        self.config = config
        self.render_mode = render_mode
        self.part_files = part_files(config)
        self.actions = ActionMapping(config.env, config.sensor.working_distance_m)
        self.reward_function = Reward(config.env.reward, config.env.travel_cost_floor,
                                      config.env.unreachable_penalty)
        self.action_space = self.actions.space
        self.observation_space = observation_space(config)
        self.observer = Observer(config, config.env.resolution)
        self.step_limit = step_limit(config.env)
        self._scenes: dict[tuple[Path, float], PartScene] = {}
        self._renderer: OffscreenView | None = None
        self._renderer_cell: Cell | None = None
        self._renderer_data: Any = None  # the renderer's mujoco.MjData
        self.episode: Episode | None = None
        self.spec_of_episode: EpisodeSpec | None = None
        self._done = True

    def __getstate__(self) -> dict[str, Any]:
        # MuJoCo handles, thread pools and GL contexts do not pickle: a copy is rebuilt from the
        # config and starts from a fresh reset, as a subprocess vector env does.
        return {"config": self.config, "render_mode": self.render_mode}

    def __setstate__(self, state: dict[str, Any]) -> None:
        type(self).__init__(self, state["config"], state["render_mode"])

    def scene(self, path: str | Path, scale: float = 1.0) -> PartScene:
        """The (cached) scene of one part file; the `SCENES_KEPT` latest stay loaded."""
        key = (Path(path), scale)
        if key in self._scenes:
            self._scenes[key] = self._scenes.pop(key)
        else:
            if len(self._scenes) >= SCENES_KEPT:
                del self._scenes[next(iter(self._scenes))]
                # The evicted scene's native memory would otherwise stay in glibc's heaps,
                # fragmented: an env process grew ~100 MB a minute on the family mix.
                release_freed_memory()
            self._scenes[key] = PartScene.load(self.config, path, scale,
                                                self.config.env.resolution)
        return self._scenes[key]

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Start an episode.

        Args:
            seed: Seeds `self.np_random`, from which everything random is drawn.
            options: `episode`: an `EpisodeSpec` (or its dict form) to run instead of a drawn
                one; `part`: index into `part_files` of the part to draw an episode for.

        Raises:
            ValueError: For a bad spec or part index.
            ValueError: If no initial view is reachable.
        """
        super().reset(seed=seed)
        options = options or {}
        spec = options.get("episode")
        if spec is None:
            env = self.config.env
            spec = sample_episode(env, self.part_files, self.np_random,
                                  seed=int(self.np_random.integers(SEED_BOUND)),
                                  part=options.get("part"),
                                  scale=env.mesh_scale if env.parts == "mesh" else 1.0)
        elif isinstance(spec, Mapping):
            spec = EpisodeSpec.from_dict(spec)
        elif not isinstance(spec, EpisodeSpec):
            raise ValueError(f"options['episode'] must be an EpisodeSpec or its dict, got "
                             f"{type(spec).__name__}")
        self.spec_of_episode = spec
        self.observer.reset()
        scene = self.scene(spec.part_path, spec.scale)
        self.episode = Episode.from_spec(scene, spec, self.config.env.carrier,
                                         self.config.env.unreachable)
        view = self.episode.begin(spec.initial_requests(
            self.episode.center, self.config.sensor.working_distance_m))
        self.steps = 0
        self._done = False
        return self._observation(), self._info(view, 0.0, None)

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Request the view of `action`.

        Raises:
            ValueError: For an action of the wrong shape, NaN or outside [-1, 1].
            RuntimeError: If the episode is over (call `reset`).
        """
        if self._done or self.episode is None:
            raise RuntimeError("the episode is over: call reset() before step()")
        episode, env = self.episode, self.config.env
        if self.actions.stops(action):
            return self._stop(episode)
        request = self.observer.request(self.actions, action, episode.center,
                                        self.config.kinematics.roll == "free")
        coverage_before = episode.coverage
        view = episode.request(request)
        self.steps += 1
        # An agent that decides when to stop is not stopped at the goal.
        terminated = episode.coverage >= env.coverage_goal and not env.stop_action
        truncated = not terminated and self.steps >= self.step_limit
        self._done = terminated or truncated
        travel_cost = env.travel_cost
        terms = self.reward_function.step(
            delta=episode.coverage - coverage_before,
            remaining_before=1.0 - coverage_before,
            travel=getattr(view.travel, travel_cost),
            reachable=view.reachable,
            episode_over=self._done,
            goal_reached=terminated,
            final_coverage=episode.coverage,
            steps=self.steps,
            travel_sum=getattr(episode.travel_sum, travel_cost),
        )
        if truncated and env.stop_action:
            terms = dataclasses.replace(terms, reward=terms.reward - env.stop_reward,
                                        stop=-env.stop_reward)
        return (self._observation(), float(terms.reward), terminated, truncated,
                self._info(view, episode.coverage - coverage_before, terms))

    def _stop(self, episode: Episode) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The agent stops: +stop_reward at or above the coverage goal, -stop_reward below."""
        env = self.config.env
        self.steps += 1
        self._done = True
        reward = env.stop_reward if episode.coverage >= env.coverage_goal else -env.stop_reward
        terms = RewardTerms(reward, 0.0, 1.0 - episode.coverage, 0.0, 0.0, stop=reward)
        return self._observation(), reward, True, False, self._info(None, 0.0, terms)

    def _observation(self) -> Any:
        return self.observer.observe(self.current_episode(), self.np_random)

    def _info(self, view: ViewRecord | None, delta: float,
              terms: RewardTerms | None) -> dict[str, Any]:
        """The step's info; `view` is None for a stop decision (no view was requested)."""
        episode, spec = self.current_episode(), self.spec_of_episode
        assert spec is not None  # reset sets it with the episode
        sensor = episode.sensor_pose()
        approach, travel_sum = episode.approach, episode.travel_sum
        info: dict[str, Any] = {
            "coverage": episode.coverage,
            "delta_coverage": delta,
            "stopped": view is None,
            "reachable": view is None or view.reachable,
            "reason": "stopped" if view is None else view.reason,
            "carrier": episode.carrier.name,
            "joints": episode.q.copy(),
            "sensor_position": sensor.position,
            "sensor_quaternion": sensor.quaternion,
            "acquisitions": len(episode.tracker.steps),
            "reachable_share": sum(v.reachable for v in episode.views) / len(episode.views),
            "points_acquired": 0 if view is None else len(view.points_world),
            "part": str(episode.scene.mesh.path),
            "episode_seed": spec.seed,
        }
        travel = view.travel if view is not None and terms is not None else None
        for name in TRAVEL_COSTS:
            info[f"travel_{name}"] = 0.0 if travel is None else getattr(travel, name)
            info[f"travel_sum_{name}"] = getattr(travel_sum, name)
            info[f"approach_{name}"] = getattr(approach, name)
        if terms is not None:
            info["reward_terms"] = dataclasses.asdict(terms)
        if self._done:
            # At the end only: the cycle closes with the way home, a path to plan.
            cycle = episode.record().cycle
            info["cycle_time"] = None if cycle is None else cycle.total_s
        return info

    def current_episode(self) -> Episode:
        """The episode in progress.

        Raises:
            RuntimeError: Before the first `reset`.
        """
        if self.episode is None:
            raise RuntimeError("no episode yet: call reset() first")
        return self.episode

    def episode_record(self) -> EpisodeRecord:
        """The episode so far (for rendering and plan export)."""
        return self.current_episode().record()

    def render(self) -> np.ndarray | None:
        """An RGB frame of the cell (`render_mode="rgb_array"`), else None."""
        if self.render_mode != "rgb_array" or self.episode is None:
            return None
        # Imported here: the offscreen renderer (OpenGL, imageio) loads only for rgb_array frames.
        from vprobot.render.camera import aim_overview
        from vprobot.render.offscreen import OffscreenView

        cell = self.episode.scene.cell
        if self._renderer is None or self._renderer_cell is not cell:
            self.close()
            self._renderer = OffscreenView(cell.model, 640, 480)
            self._renderer_cell = cell
            self._renderer_data = cell.make_data()
            aim_overview(self._renderer.camera, cell)
        self._renderer_data.qpos[:] = self.episode.q
        cell.place_object(self._renderer_data, self.episode.object_pose.rotation)
        self._renderer.update(self._renderer_data)
        return self._renderer.rgb()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
