"""Trained agents as planners: end to end through plan / evaluate, model-free, clear errors."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from dh_reference import quaternion_matrix, rotation_difference, world_sensor
from helpers import SmokeRuns

from vprobot.agents.trained import BUNDLED_AGENT, BUNDLED_AGENTS, load_agent
from vprobot.cli import main
from vprobot.config import Config
from vprobot.files.paths import AGENTS_DIR, OBJECTS_DIR
from vprobot.planners.agent import AgentPlanner
from vprobot.planners.runner import plan_part

CONFIG = Config()


@pytest.fixture(scope="module")
def run(smoke_runs: SmokeRuns) -> Path:
    """A run directory of a few training steps (the session's SAC smoke run)."""
    return smoke_runs("sac", "sphere", False)[2]


def test_bundled_agent_plans_a_part_of_no_training_family_end_to_end() -> None:
    # The pipe tee is no motor and of no generated family: the agent never saw its like.
    assert (BUNDLED_AGENT / "model.zip").stat().st_size <= 20 * 1024**2
    _, record, document, text = plan_part(CONFIG, OBJECTS_DIR / "pipe_tee.stl",
                                           planner="agent", seed=0)
    assert "agent on pipe_tee.stl" in text
    assert len(document["views"]) == len(record.views) >= 2
    for view in document["views"]:
        if view["reachable"]:
            pose = world_sensor(np.array(view["joints"]), CONFIG)
            assert np.linalg.norm(pose[:3, 3] - view["position"]) <= 1e-3
            assert rotation_difference(pose[:3, :3],
                                       quaternion_matrix(view["quaternion"])) <= 1e-3
    assert document["coverage"] == pytest.approx(record.coverage)


def test_agent_is_handed_acquired_points_only(run: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    planner = AgentPlanner(run)
    handed: list[np.ndarray] = []
    predict = planner.agent.model.predict

    def recording(observation: np.ndarray, **kwargs: object) -> tuple:
        handed.append(np.array(observation))
        return predict(observation, **kwargs)

    monkeypatch.setattr(planner.agent.model, "predict", recording)
    from vprobot.episode import Episode, PartScene
    from vprobot.files.paths import DEFAULT_MOTOR

    scene = PartScene.load(CONFIG, DEFAULT_MOTOR, resolution=(107, 75))
    episode = Episode(scene, np.eye(3))
    planner.reset(episode, np.random.default_rng(0))
    episode.begin(planner_initial(episode))
    scale = planner.agent.config.env.state_scale_m
    for _ in range(3):
        acquired = np.clip(episode.tracker.accumulated_cloud @ episode.object_pose.rotation.T
                           / scale, -4, 4).astype(np.float32)
        episode.request(planner.next_view(episode))
        rows = set(map(tuple, handed[-1]))
        assert handed[-1].shape[1] == 3
        assert rows <= set(map(tuple, acquired))
        gt = (episode.tracker.gt_points @ episode.object_pose.rotation.T / scale).astype(
            np.float32)
        assert not rows & set(map(tuple, gt))


def test_a_decision_runs_the_network_on_one_thread_and_leaves_torchs_threads_as_they_were(
        run: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import torch

    from vprobot.episode import Episode, PartScene
    from vprobot.files.paths import DEFAULT_MOTOR

    planner = AgentPlanner(run)
    predict = planner.agent.model.predict
    threads: list[int] = []

    def counting(observation: np.ndarray, **kwargs: object) -> tuple:
        threads.append(torch.get_num_threads())
        return predict(observation, **kwargs)

    monkeypatch.setattr(planner.agent.model, "predict", counting)
    episode = Episode(PartScene.load(CONFIG, DEFAULT_MOTOR, resolution=(107, 75)), np.eye(3))
    planner.reset(episode, np.random.default_rng(0))
    episode.begin(planner_initial(episode))
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        episode.request(planner.next_view(episode))
        assert (threads, torch.get_num_threads()) == ([1], 2)
    finally:
        torch.set_num_threads(before)


def planner_initial(episode: object) -> list:
    from vprobot.episode import seeded_episode
    from vprobot.files.paths import DEFAULT_MOTOR

    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0)
    return spec.initial_requests(episode.center, CONFIG.sensor.working_distance_m)


def test_a_run_directory_gives_its_best_model(run: Path) -> None:
    assert load_agent(run).path == run / "best_model.zip"
    checkpoint = run / "checkpoints" / json.loads((run / "checkpoint.json").read_text())["model"]
    assert load_agent(checkpoint).path == checkpoint  # its run's config.yaml is found above


def test_bundled_agents_load_by_name_and_the_default_is_the_generalist() -> None:
    assert {"generalist", "generalist-real", "cpu", "cpu-stop"} <= set(BUNDLED_AGENTS)
    assert BUNDLED_AGENT == AGENTS_DIR / "generalist"
    motors_only = load_agent("cpu")
    assert motors_only.path == (AGENTS_DIR / "cpu" / "model.zip").resolve()
    assert motors_only.config.env.state == "s_cov"
    assert load_agent().config.env.action == "A_view"


def test_missing_or_corrupt_agents_are_clear_errors(run: Path, tmp_path: Path) -> None:
    with pytest.raises(ValueError,
                       match=r"does not exist .*bundled agent: cpu, cpu-stop, generalist"):
        load_agent(tmp_path / "nowhere")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match=r"no best_model\.zip"):
        load_agent(empty)
    corrupt = tmp_path / "corrupt"
    corrupt.mkdir()
    shutil.copy(run / "config.yaml", corrupt / "config.yaml")
    (corrupt / "best_model.zip").write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(ValueError, match="cannot be loaded"):
        load_agent(corrupt)
    lone = tmp_path / "lone.zip"
    shutil.copy(run / "best_model.zip", lone)
    with pytest.raises(ValueError, match=r"no config\.yaml"):
        load_agent(lone)


def test_cli_plans_with_an_agent_for_a_fixed_view_count(run: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture) -> None:
    plan = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--planner", f"agent:{run}", "--views", "3", "--out",
                 str(plan)]) == 0
    assert len(json.loads(plan.read_text())["views"]) == 3
    assert main(["plan", "--planner", f"agent:{tmp_path / 'nothing'}", "--out",
                 str(plan)]) == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.parametrize("written", ["./cpu", "cpu/"])
def test_an_explicit_path_named_like_a_bundled_agent_is_the_path(
        written: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A local run folder `cpu` holding (a copy of) the generalist: `./cpu` is that folder, only
    # the bare name `cpu` is the bundled motors-only agent.
    shutil.copytree(AGENTS_DIR / "generalist", tmp_path / "cpu")
    monkeypatch.chdir(tmp_path)
    local = load_agent(written)
    assert local.path == (tmp_path / "cpu" / "model.zip").resolve()
    assert local.config.env.action == "A_view"
    assert load_agent("cpu").path == (AGENTS_DIR / "cpu" / "model.zip").resolve()


@pytest.mark.parametrize(("text", "shown"), [("", "NoneType (an empty file)"),
                                             ("- a\n- b\n", "list")])
def test_a_run_whose_config_is_empty_or_no_mapping_names_the_file(
        text: str, shown: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    run = tmp_path / "run"
    shutil.copytree(AGENTS_DIR / "generalist", run)
    (run / "config.yaml").write_text(text)
    code = main(["plan", "--no-summary", "--planner", f"agent:{run}", "--out",
                 str(tmp_path / "plan.json")])
    note, line = capsys.readouterr().err.splitlines()
    assert code == 2 and note == f"loading agent {run} ..."
    assert line == (f"vprobot plan: error: {run / 'config.yaml'}: a run's config must be a "
                    f"mapping of config sections, as `vprobot train` writes it; got {shown}")


def test_an_agent_planner_says_it_is_loading_before_the_slow_load(
        capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.agents import trained
    from vprobot.files.progress import showing_progress

    said_before: list[str] = []

    def recording_load(source: str) -> trained.TrainedAgent:
        said_before.append(capsys.readouterr().err)
        return load_agent(source)

    monkeypatch.setattr(trained, "load_agent", recording_load)
    with showing_progress():
        AgentPlanner("cpu")
    assert said_before == ["loading agent cpu ...\n"]
    assert capsys.readouterr().err == ""


def test_an_evaluation_of_an_agent_says_it_is_loading_before_the_first_episode(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """`evaluate` checks its planners (loading the agent: seconds) before the first episode;
    with its progress shown, that load is announced instead of a silent start."""
    from vprobot.episode import episode_list
    from vprobot.evaluation import evaluate
    from vprobot.files.paths import DEFAULT_MOTOR

    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    evaluate(CONFIG, ["agent:cpu"], specs, tmp_path, progress=True, carriers=["free"])
    assert capsys.readouterr().err.startswith("loading agent cpu ...\n")


def test_the_bundled_agent_plans_a_part_of_no_family_end_to_end_in_the_realistic_cell(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from vprobot.files.paths import CONFIGS_DIR

    plan = tmp_path / "plan.json"
    code = main(["plan", "--no-summary", "--config", str(CONFIGS_DIR / "cell_real.yaml"),
                 "--planner", "agent",
                 "--mesh", str(OBJECTS_DIR / "pipe_tee.stl"), "--out", str(plan)])
    assert code == 0, capsys.readouterr().err
    document = json.loads(plan.read_text())
    views = document["views"]
    # The initial view and at least one the agent chose, each reached by the robot.
    assert len(views) >= 2 and all(view["reachable"] for view in views)
    assert all(len(view["joints"]) == 6 for view in views)
    assert document["planner"] == "agent" and document["sensor"]["sensing"] == "structured_light"


def test_the_default_agent_is_the_bundled_generalist_trained_with_the_runs_sensor() -> None:
    from vprobot.config import load_config, replace, with_sensor
    from vprobot.files.paths import CONFIGS_DIR
    from vprobot.planners.runner import make_planner

    real = load_config(CONFIGS_DIR / "cell_real.yaml")
    for config, name in ((CONFIG, "generalist"), (real, "generalist-real")):
        planner = make_planner("agent", config)
        assert isinstance(planner, AgentPlanner)
        assert planner.agent.path == (AGENTS_DIR / name / "model.zip").resolve()
        assert planner.agent.config.sensor.sensing == config.sensor.sensing
    with pytest.raises(ValueError, match=r"no bundled agent was trained with this run's sensor "
                                         r"\(2448 x 2048 rays, .*, structured_light sensing\); "
                                         r"the bundled ones were: generalist-real: 612 x 512 "
                                         r"rays, .*; generalist: 430 x 300 rays, .*; train one "
                                         r"for it and give agent:PATH"):
        make_planner("agent", with_sensor(CONFIG, "zivid2plus_mr60"))
    with pytest.raises(ValueError, match="no bundled agent was trained"):
        make_planner("agent", replace(real, "sensor", sensing="ideal"))


def test_an_agent_asked_to_plan_with_another_sensor_says_which_it_was_trained_with() -> None:
    """The agent's observations are built from its training sensor's frames (430 x 300 rays for
    the bundled ones); another sensor's frames used to index past that grid (an IndexError deep
    in the occupancy grid). Now the planner is refused, naming both sensors; so is the same
    sensor under another sensing model, which changes what each view measures."""
    from vprobot.config import replace, sensor_preset, with_sensor
    from vprobot.planners.runner import make_planner

    with pytest.raises(ValueError, match=r"agent cpu was trained with the sensor 430 x 300 rays, "
                                         r"27 x 25 deg, 0.3-0.5 m, ideal sensing and plans only "
                                         r"with it; this run's sensor is 2448 x 2048 rays"):
        make_planner("agent:cpu", with_sensor(CONFIG, "zivid2plus_mr60"))
    with pytest.raises(ValueError, match=r"agent cpu was trained with the sensor 430 x 300 rays, "
                                         r"27 x 25 deg, 0.3-0.5 m, ideal sensing and plans only "
                                         r"with it; this run's sensor is 430 x 300 rays, 27 x 25 "
                                         r"deg, 0.3-0.5 m, structured_light sensing"):
        make_planner("agent:cpu", replace(CONFIG, "sensor", sensing="structured_light",
                                          structured_light=dataclasses.asdict(sensor_preset(
                                              "zivid2plus_mr60").structured_light)))
    assert isinstance(make_planner("agent:cpu", CONFIG), AgentPlanner)


def test_an_s_grid_agent_refuses_a_cell_whose_grid_is_not_the_one_it_was_trained_in() -> None:
    """The agent's state reads an occupancy grid placed by the cell (where it puts the object,
    how large an object it takes); the planner used to place it silently by the agent's own
    cell. Another cell is refused, naming both grids; an `s_cov` agent reads no grid and plans
    in it."""
    from vprobot.config import replace
    from vprobot.planners.runner import make_planner

    moved = replace(CONFIG, "cell", object_center_m=(0.5, 0.0, 0.75))
    with pytest.raises(ValueError, match=r"agent generalist reads the occupancy grid of the cell "
                                         r"it was trained in, a cube about \(0.45, 0, 0.75\) m "
                                         r"with a half edge of 0.189 m; this run's cell gives a "
                                         r"cube about \(0.5, 0, 0.75\) m .*cell.object_center_m"):
        make_planner("agent:generalist", moved)
    assert isinstance(make_planner("agent:cpu", moved), AgentPlanner)


def test_agent_k_takes_the_nearest_of_the_k_best_scored_allowed_candidates() -> None:
    """`agent~K`: checked against a brute-force pick over the scores on made-up states (some
    candidates masked, joint moves drawn); `agent~1` is the greedy policy's choice. An agent
    that does not choose among candidate views refuses it, naming its action."""
    import torch

    from vprobot.env.grid_state import FEATURES
    from vprobot.planners.runner import make_planner

    planner = make_planner("agent~4:generalist", CONFIG)
    greedy = make_planner("agent~1:generalist", CONFIG)
    assert isinstance(planner, AgentPlanner) and isinstance(greedy, AgentPlanner)
    assert (planner.nearest, greedy.nearest) == (4, 1)
    space = planner.agent.model.observation_space
    rng = np.random.default_rng(0)
    for _ in range(20):
        observation = {key: rng.uniform(box.low, box.high).astype(np.float32)
                       for key, box in space.spaces.items()}
        observation["mask"] = (rng.random(observation["mask"].shape) < 0.5).astype(np.float32)
        with torch.no_grad():
            scores = planner.agent.model.policy.q_net(
                {key: torch.as_tensor(value)[None] for key, value in observation.items()})[0]
        allowed = [int(index) for index in np.flatnonzero(observation["mask"])]
        ranked = sorted(allowed, key=lambda index: -float(scores[index]))[:4]
        moves = {index: observation["candidates"][index, FEATURES.index("joint_move")]
                 for index in ranked}
        nearest = min(moves.values())
        assert planner.nearest_of_best(observation) == next(
            index for index in ranked if moves[index] == nearest)
        action, _ = greedy.agent.model.predict(observation, deterministic=True)
        assert greedy.nearest_of_best(observation) == int(action) == ranked[0]
    with pytest.raises(ValueError, match=r"agent~3 takes the nearest of an agent's best-scored "
                                         r"candidate views; agent cpu acts with env.action "
                                         r"A_2S0R, not A_view"):
        make_planner("agent~3:cpu", CONFIG)
