"""The `vprobot` command line: reach verdicts, plan JSON, clear errors."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from dh_reference import quaternion_matrix, rotation_difference, world_sensor

from vprobot.cli import main
from vprobot.config import Config
from vprobot.files.paths import available_robots
from vprobot.kinematics import trajectory
from vprobot.planners.base import counted_planners


def test_reach_writes_the_plan_json(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "view.json"
    code = main(["reach", "--position", "0.45", "-0.47", "0.75", "--look-at", "0.45", "0", "0.75",
                 "--json", str(out)])
    assert code == 0
    assert "REACHABLE" in capsys.readouterr().out
    plan = json.loads(out.read_text())
    robot = plan["robot"]
    assert robot["name"] == "ur10"
    assert robot["sensor_mount"]["parent"] == "tool0"
    assert len(robot["joint_names"]) == 6
    (view,) = plan["views"]
    assert view["reachable"] is True and view["reason"] is None
    # The exported joints reproduce the exported sensor pose (independent FK: the published DH
    # parameters, base and mount from the config).
    pose = world_sensor(np.array(view["joints"]), Config())
    assert np.linalg.norm(pose[:3, 3] - view["position"]) <= 1e-3
    assert rotation_difference(pose[:3, :3], quaternion_matrix(view["quaternion"])) <= 1e-3
    assert np.linalg.norm(pose[:3, 3] - [0.45, -0.47, 0.75]) <= 1e-3
    # ... and it looks at the requested point.
    offset = np.array([0.45, 0.0, 0.75]) - pose[:3, 3]
    assert np.cross(pose[:3, 2], offset / np.linalg.norm(offset)) == pytest.approx(0, abs=1e-2)


def test_unreachable_view_is_reported(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "far.json"
    code = main(["reach", "--position", "2.5", "0", "0.75", "--look-at", "3", "0", "0.75",
                 "--robot", "ur5", "--json", str(out)])
    assert code == 1
    # Farther from the shoulder than the arm reaches: said so, not "did not converge" after no
    # attempt.
    verdict, detail, _ = capsys.readouterr().out.splitlines()
    assert verdict.endswith("UNREACHABLE (out_of_reach)")
    assert detail.startswith("  out of the robot's reach: the sensor position lies ")
    assert "no IK attempt" in detail and "0 attempt(s)" not in detail
    (view,) = json.loads(out.read_text())["views"]
    assert view == {**view, "reachable": False, "reason": "out_of_reach", "joints": None}


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["reach", "--position", "nan", "0", "0", "--look-at", "1", "0", "0"], "finite"),
        (["reach", "--position", "0", "0", "1", "--look-at", "1", "0", "0", "--from-joints", "0"],
         "shape"),
        (["reach", "--position", "0", "0", "1", "--look-at", "1", "0", "0", "--config", "no.yaml"],
         "no.yaml"),
    ],
)
def test_bad_input_is_a_clear_error(argv: list[str], message: str,
                                    capsys: pytest.CaptureFixture) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_bad_output_path_leaves_nothing(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "missing" / "view.json"
    code = main(["reach", "--position", "0.45", "-0.47", "0.75", "--look-at", "0.45", "0", "0.75",
                 "--json", str(out)])
    assert code == 2
    assert "does not exist" in capsys.readouterr().err
    assert not out.parent.exists()


def test_unknown_robot_is_one_line_listing_the_bundled_ones(capsys: pytest.CaptureFixture) -> None:
    code = main(["reach", "--position", "0", "0", "1", "--look-at", "1", "0", "0", "--robot",
                 "kuka"])
    error = capsys.readouterr().err
    assert code == 2 and len(error.strip().splitlines()) == 1
    assert "unknown robot 'kuka'" in error and f"({', '.join(available_robots())})" in error
    assert "ur10" in available_robots()


def _count_calls(monkeypatch: pytest.MonkeyPatch, function: Callable[..., Any]) -> list[int]:
    """Count the calls of `function` wherever it is reached: the module that defines it and
    every loaded module that imported it by name (modules imported later take the counter
    from the defining module)."""
    calls = [0]

    def counting(*args: Any, **kwargs: Any) -> Any:
        calls[0] += 1
        return function(*args, **kwargs)

    for module in list(sys.modules.values()):
        if getattr(module, function.__name__, None) is function:
            monkeypatch.setattr(module, function.__name__, counting)
    return calls


def test_plan_writes_json_and_a_small_video_timing_each_move_once(
        tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """`plan` with its summary still and a video times each move of the cycle once, when the
    episode executes it: the plan JSON, the summary and the video read the record's timing."""
    moves = _count_calls(monkeypatch, trajectory.time_move)
    segments = _count_calls(monkeypatch, trajectory.time_segment)
    plan, video = tmp_path / "plan.json", tmp_path / "rollout.gif"
    code = main(["plan", "--out", str(plan), "--video", str(video), "--width", "96",
                 "--height", "72"])
    assert code == 0
    document = json.loads(plan.read_text())
    # The cycle's moves as the plan states them: the approach and the moves between views
    # (a view's corners; null where the robot stayed), and the way back to the start.
    executed = [view["waypoints"] for view in document["views"]
                if view["waypoints"] is not None] + [document["return"]["waypoints"]]
    assert len(executed) >= 3 and moves[0] == len(executed)
    # ... and no segment is timed outside them (a corner pair is one segment).
    assert segments[0] == sum(len(corners) - 1 for corners in executed)
    out = capsys.readouterr().out
    assert "goal 90% reached" in out
    assert document["coverage"] >= 0.9
    assert all(view["reachable"] for view in document["views"])
    assert video.stat().st_size > 0
    # The summary still beside the plan, unasked (--no-summary leaves it out).
    assert plan.with_suffix(".png").stat().st_size > 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["plan", "--out", "/nonexistent/plan.json"], "folder /nonexistent does not exist"),
        (["plan", "--out", "plan.json", "--mesh", "missing.stl"], "mesh file not found"),
        (["plan", "--out", "plan.json", "--planner", "hrec", "--views", "3"],
         f"a fixed number of views applies to {', '.join(counted_planners())} only, not to "
         f"'hrec'"),
        (["render", "--plan", "missing.json", "--out", "video.mp4"], "missing.json"),
    ],
)
def test_planning_errors_are_clear(argv: list[str], message: str, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch,
                                   capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["train", "--steps", "0", "--out", "run"],
         "vprobot train: error: argument --steps: must be an integer >= 1, got '0'"),
        (["robots", "import", "arm.urdf", "--name", "arm"],
         "vprobot robots import: error: the following arguments are required: --flange"),
    ],
)
def test_option_errors_are_one_line_without_usage(argv: list[str], line: str,
                                                  capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith(line), err


@pytest.mark.parametrize(
    ("argv", "wanted", "unwanted"),
    [
        (["plan", "--planner", "agent7", "--out", "p.json"], "--planner agent --views 7",
         "--planner bscp"),
        (["render", "--planner", "dijkstra", "--out", "v.gif"],
         f"a fixed number of views ({', '.join(counted_planners())}) goes in --views",
         "bscp<N>"),
    ],
)
def test_planner_hints_name_forms_that_plan_accepts(argv: list[str], wanted: str, unwanted: str,
                                                    capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit):
        main(argv)
    err = capsys.readouterr().err
    assert wanted in err and unwanted not in err, err


def test_evaluate_lists_the_planners_with_a_view_count(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture) -> None:
    assert main(["evaluate", "--planners", "dijkstra", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert " / ".join(f"{name}<N>" for name in counted_planners()) in err and "bscp<N>" in err


def test_a_warning_is_one_line_in_the_commands_name(monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture) -> None:
    import warnings

    from vprobot.cli import cell

    def warns(args: object) -> int:
        warnings.warn("the cache is not writable", RuntimeWarning, stacklevel=2)
        return 0

    monkeypatch.setattr(cell, "command_sensors", warns)
    assert main(["sensors"]) == 0
    assert capsys.readouterr().err == "vprobot sensors: warning: the cache is not writable\n"


HEAVY_MODULES = ("mujoco", "torch", "stable_baselines3", "trimesh", "ray", "scipy.spatial")
"""What the parser must not import: each costs from a tenth of a second to seconds."""


def _heavy_modules_after(code: str) -> list[str]:
    """The heavy modules that `code` loads in a fresh interpreter."""
    check = (f"import json, sys\n{code}\n"
             f"print(json.dumps(sorted(sys.modules)))")
    child = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True,
                           check=True)
    loaded = json.loads(child.stdout.splitlines()[-1])
    return [name for name in HEAVY_MODULES if name in loaded]


def test_building_the_parser_imports_no_heavy_module() -> None:
    assert _heavy_modules_after("from vprobot.cli import build_parser\nbuild_parser()") == []


def test_help_and_an_unknown_command_import_no_heavy_module() -> None:
    # plan and evaluate list the planners and stop rules, export the formats: from their
    # registries' declarations.
    for argv in (["--help"], ["cell", "--help"], ["plan", "--help"], ["evaluate", "--help"],
                 ["export", "--help"], ["evalute"]):
        code = (f"from vprobot.cli import main\ntry:\n    main({argv!r})\n"
                f"except SystemExit:\n    pass")
        assert _heavy_modules_after(code) == [], argv


def test_the_command_runs_as_python_m_vprobot_cli() -> None:
    done = subprocess.run([sys.executable, "-m", "vprobot.cli", "evalute"], capture_output=True,
                          text=True)
    assert done.returncode == 2
    assert done.stderr.startswith("vprobot: error: argument command: invalid choice: 'evalute'")


def test_help_names_the_registered_planners_and_stop_rules(
        capsys: pytest.CaptureFixture) -> None:
    from vprobot.planners.base import counted_planners, planner_names
    from vprobot.stopping.rules import stop_names

    with pytest.raises(SystemExit):
        main(["plan", "--help"])
    text = " ".join(capsys.readouterr().out.split())  # as one line, whatever the wrapping
    assert f"--planner PLANNER {', '.join(planner_names())}: agent is" in text
    assert f"fixed number of views ({', '.join(counted_planners())})" in text
    assert f"when to stop: {', '.join(stop_names())}; agent: the agent's learned stop" in text
    assert "goal: the simulator's stop at the coverage goal" in text


def test_stop_study_and_error_run_with_the_studys_defaults(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.stop_studies import report, study

    given: dict[str, tuple[object, ...]] = {}

    def stop_study(config: Config, out: str, *args: object) -> None:
        given["study"] = args
        Path(out).mkdir()
        (Path(out) / "study.md").write_text("")

    def score_estimate(config: Config, out: str, *args: object) -> None:
        given["error"] = args
        Path(out).mkdir()
        (Path(out) / "error.md").write_text("")

    monkeypatch.setattr(study, "stop_study", stop_study)
    monkeypatch.setattr(report, "score_estimate", score_estimate)
    assert main(["stop", "study", "--out", str(tmp_path / "study")]) == 0
    assert main(["stop", "error", "--out", str(tmp_path / "error")]) == 0
    lists = ["test-v1", "families-test-v1", "shapes-v1"]
    rules = ["goal", "estimate", "confident", "grid", "views:5", "agent"]
    assert given["study"] == (lists, ["agent", "nbv", "agent:cpu-stop"], rules, None, 1)
    assert given["error"] == (lists, None, None)


def test_cli_benchmark_times_each_command_in_a_fresh_process(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.benchmarks import cli as suite

    results = suite.run_cli_benchmark(runs=1)
    assert set(results) == {"runs", "python_s", *(f"{name}_s" for name in suite.COMMANDS)}
    assert all(results[key] > 0 for key in results)  # no timing asserted: machines differ
    with pytest.raises(ValueError, match="runs must be >= 1, got 0"):
        suite.run_cli_benchmark(runs=0)
    # A command that fails (here: a typo expected to succeed) gives no figure.
    monkeypatch.setattr(suite, "COMMANDS", {"typo": (("evalute",), 0)})
    with pytest.raises(RuntimeError, match="vprobot evalute exited with 2, not 0: vprobot: "
                                           "error: argument command: invalid choice"):
        suite.run_cli_benchmark(runs=1)
