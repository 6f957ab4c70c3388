"""What a new user meets: every user error is one line on stderr and exit code 2, found before
the long work starts; outputs are portable and reproducible."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest

from vprobot import kinematics
from vprobot.benchmarks import env as env_benchmark
from vprobot.cli import build_parser, main
from vprobot.config import Config, ConfigError, load_config, replace
from vprobot.env.inspect_env import InspectEnv
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.planners import runner

REACH = ["reach", "--position", "0.45", "-0.47", "0.75", "--look-at", "0.45", "0", "0.75"]
UNWRITABLE = "/sys" if not os.access("/sys", os.W_OK) or os.geteuid() == 0 else None


def run(argv: list[str], capsys: pytest.CaptureFixture) -> tuple[int, str]:
    code = main(argv)
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.err


def one_line_error(argv: list[str], capsys: pytest.CaptureFixture, *needles: str) -> str:
    code, err = run(argv, capsys)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0]
    return lines[0]


def test_malformed_yaml_names_the_file_and_line(tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    config = tmp_path / "broken.yaml"
    config.write_text("cell:\n  robot: [ur10\n")
    one_line_error([*REACH, "--config", str(config)], capsys, "broken.yaml", "not valid YAML",
                   "line")


def test_unknown_robot_in_a_config_names_file_and_key(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    config = tmp_path / "cell.yaml"
    config.write_text("cell:\n  robot: ur3\n")
    one_line_error([*REACH, "--config", str(config)], capsys, "cell.yaml", "cell.robot", "'ur3'",
                   "ur10")


def refuse_work(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the work of `plan`, `render`, `reach` and `benchmark env` fail the test if it
    starts: their errors must be found before it."""

    def started(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the work started before the error was found")

    monkeypatch.setattr(runner, "plan_part", started)
    monkeypatch.setattr(kinematics, "RobotArm", started)
    monkeypatch.setattr(env_benchmark, "run_env_benchmark", started)


@pytest.mark.skipif(UNWRITABLE is None, reason="no unwritable folder on this machine")
def test_unwritable_output_folder_is_found_before_planning(
        capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    refuse_work(monkeypatch)
    target = f"{UNWRITABLE}/plan.json"
    line = one_line_error(["plan", "--out", target], capsys, "--out", target, "cannot write")
    assert ".plan.json." not in line  # the user's path, not a hidden temporary file


@pytest.mark.parametrize(
    ("argv", "needles"),
    [
        (["plan", "--out", "plan.json", "--video", "rollout.avi"], ("--video", ".mp4 or .gif")),
        (["plan", "--out", "."], ("--out", "is a folder")),
        (["plan", "--out", ""], ("--out", "empty")),
        (["plan", "--out", "plan.txt"], ("--out", ".json")),
        (["plan", "--out", "plan.json", "--summary", "missing/summary.png"],
         ("--summary", "does not exist")),
        (["render", "--out", "rollout.mp4", "--summary", "s.jpg"], ("--summary", ".png")),
        ([*REACH, "--json", "missing/view.json"], ("--json", "does not exist")),
        (["benchmark", "env", "--json", "x.csv"], ("--json", ".json")),
    ],
)
def test_outputs_are_checked_before_the_work(argv: list[str], needles: tuple[str, ...],
                                             tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    refuse_work(monkeypatch)
    one_line_error(argv, capsys, *needles)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("command", [["evaluate", "--carriers", "free"],
                                     ["motors", "generate", "--count", "1"]])
def test_an_existing_file_is_no_output_folder(command: list[str], tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    existing = tmp_path / "results"
    existing.write_text("not a folder")
    one_line_error([*command, "--out", str(existing)], capsys, "--out", "is a file")


@pytest.mark.parametrize(
    ("argv", "needles"),
    [
        ([*REACH, "--from-joints", "0", "0", "0", "0", "0", "9"], ("--from-joints", "limits")),
        (["plan", "--out", "p.json", "--seed", "-5"], ("--seed", ">= 0")),
        (["plan", "--out", "p.json", "--scale", "0"], ("--scale", "> 0")),
        (["plan", "--out", "p.json", "--views", "0"], ("--views", "in 1..100")),
        (["motors", "generate", "--count", "-1", "--out", "m"], ("--count", "in 1..10000")),
        (["render", "--plan", "p.json", "--out", "v.mp4", "--mesh", "m.stl", "--planner", "hrec"],
         ("--plan", "--mesh", "--planner")),
    ],
)
def test_misleading_input_is_rejected(argv: list[str], needles: tuple[str, ...], tmp_path: Path,
                                      monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    try:
        one_line_error(argv, capsys, *needles)
    except SystemExit as exit_:  # argparse reports option errors itself, also in one line
        assert exit_.code == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1, err
        assert all(needle in err for needle in needles)


def test_unreachable_keeps_exit_code_one_for_reach_only(capsys: pytest.CaptureFixture) -> None:
    code, _ = run(["reach", "--position", "2.5", "0", "0.75", "--look-at", "3", "0", "0.75"],
                  capsys)
    assert code == 1
    code, _ = run([*REACH, "--from-joints", "0"], capsys)
    assert code == 2


def test_config_bounds_and_contradictions() -> None:
    with pytest.raises(ConfigError, match=r"sensor\.resolution must lie in 1\.\.4096"):
        replace(Config(), "sensor", resolution=(100000, 100000))
    with pytest.raises(ConfigError, match=r"env\.resolution"):
        replace(Config(), "env", resolution=(0, 10))
    with pytest.raises(ConfigError, match=r"env\.parts is 'train'"):
        replace(Config(), "env", parts="train", mesh=str(DEFAULT_MOTOR))
    # Naming a mesh in the env means using it.
    env = InspectEnv(mesh=str(DEFAULT_MOTOR))
    assert env.part_files == [DEFAULT_MOTOR]
    assert load_config().env.parts == "train"


def test_the_former_names_of_parts_are_read_with_a_note(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """`env.motors` and `evaluate --motors`, from before any object was called a part, still
    work for a release, saying what they are called now; both names at once are refused."""
    with pytest.warns(FutureWarning, match=r"env\.motors is now called env\.parts"):
        assert replace(Config(), "env", motors="test").env.parts == "test"
    config = tmp_path / "former.yaml"
    config.write_text(f"env:\n  motors: mesh\n  mesh: {DEFAULT_MOTOR}\n")
    with pytest.warns(FutureWarning, match=r"env\.motors is now called env\.parts"):
        assert load_config(config).env.parts == "mesh"
    config.write_text(f"env:\n  motors: mesh\n  parts: mesh\n  mesh: {DEFAULT_MOTOR}\n")
    with pytest.raises(ConfigError, match=r"env\.motors and env\.parts are both set"):
        load_config(config)
    args = build_parser().parse_args(["evaluate", "--motors", str(DEFAULT_MOTOR)])
    assert args.parts == [str(DEFAULT_MOTOR)]
    assert "--motors is now called --parts" in capsys.readouterr().err


def test_plans_are_portable_and_reproducible(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture) -> None:
    work, elsewhere = tmp_path / "work", tmp_path / "elsewhere"
    work.mkdir(), elsewhere.mkdir()
    (work / "motor.stl").write_bytes(DEFAULT_MOTOR.read_bytes())
    monkeypatch.chdir(work)
    # No summary stills: what is compared is the plan JSON, and a still is a render each.
    argv = ["plan", "--mesh", "motor.stl", "--planner", "hrec", "--carrier", "free",
            "--no-summary"]
    assert run([*argv, "--out", "a.json", "--no-timing"], capsys)[0] == 0
    assert run([*argv, "--out", "b.json", "--no-timing"], capsys)[0] == 0
    assert run([*argv, "--out", "timed.json"], capsys)[0] == 0
    assert (work / "a.json").read_bytes() == (work / "b.json").read_bytes()
    timed = json.loads((work / "timed.json").read_text())
    assert set(timed["timing"]) == {"plan_s", "episode_s"}
    assert "timing" not in json.loads((work / "a.json").read_text())
    assert Path(timed["object"]["mesh"]).is_absolute()
    # The plan replays from another folder.
    monkeypatch.chdir(elsewhere)
    code, err = run(["render", "--plan", str(work / "a.json"), "--out", "v.gif", "--width", "64",
                     "--height", "48"], capsys)
    assert code == 0, err
    assert (elsewhere / "v.gif").stat().st_size > 0


def test_commands_that_need_ray_say_how_to_install_it(monkeypatch: pytest.MonkeyPatch,
                                                      tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    one_line_error(["evaluate", "--workers", "2", "--carriers", "free", "--planners", "hrec",
                    "--out", str(tmp_path / "out")], capsys, "needs Ray",
                   'pip install -e ".[cluster]"')


TINY_EVALUATION = ["evaluate", "--planners", "hrec", "--carriers", "free", "--seeds", "0"]
"""A cheap `vprobot evaluate`: one fixed planner, the free sensor, one episode."""


@pytest.mark.parametrize("planted", ["folder.lock", "evaluation_episodes.csv"])
def test_a_symbolic_link_in_the_output_folder_is_refused_and_its_target_kept(
        planted: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """A link planted in the folder, to an episodes table outside (which rows would fit):
    neither the lock's pid nor a row goes into it."""
    from vprobot.evaluation import EPISODE_COLUMNS

    outside, out = tmp_path / "outside.csv", tmp_path / "out"
    outside.write_text(",".join(EPISODE_COLUMNS) + "\n")
    out.mkdir()
    (out / planted).symlink_to(outside)
    one_line_error([*TINY_EVALUATION, "--out", str(out)], capsys,
                   f"{out / planted} is a symbolic link")
    assert outside.read_text() == ",".join(EPISODE_COLUMNS) + "\n"


class Killed(BaseException):
    """Stands in for SIGKILL: nothing of vprobot handles it."""


def test_a_resume_refuses_a_mesh_changed_since_the_evaluation_began(
        tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """The settings record what the part's mesh holds, not only its path: a mesh overwritten
    between a kill and the resume would put rows of two parts in one table."""
    from vprobot import evaluation
    from vprobot.files.paths import MOTORS_DIR

    part, out = tmp_path / "part.stl", tmp_path / "out"
    part.write_bytes(DEFAULT_MOTOR.read_bytes())
    command = [*TINY_EVALUATION, "--parts", str(part), "--out", str(out)]

    def killed(*args: Any) -> None:
        raise Killed

    monkeypatch.setattr(evaluation, "_rows", killed)  # killed as its first episode starts
    with pytest.raises(Killed):
        main(command)
    monkeypatch.undo()
    capsys.readouterr()
    part.write_bytes((MOTORS_DIR / "test" / "motor_001.stl").read_bytes())
    line = one_line_error(command, capsys, f"{part} changed since the evaluation in {out}",
                          "sha256")
    assert not (out / "evaluation_episodes.csv").exists()
    assert "restore the file, or use another --out" in line


@pytest.mark.parametrize("out", ["file", "unwritable"])
def test_the_teacher_folder_is_checked_before_any_rollout(
        out: str, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.training import pretrain

    if out == "unwritable" and UNWRITABLE is None:
        pytest.skip("no unwritable folder on this machine")
    folder = f"{UNWRITABLE}/teacher" if out == "unwritable" else str(tmp_path / "teacher")
    if out == "file":
        Path(folder).write_text("not a folder")
    monkeypatch.setattr(pretrain, "collect", lambda *args, **kwargs: pytest.fail("rolled out"))
    one_line_error(["teacher", "configs/agents/cpu-candidates.yaml", "--out", folder], capsys,
                   f"--out {folder}")


def test_a_garbage_teacher_shard_is_named(tmp_path: Path) -> None:
    from vprobot.training import pretrain

    shard = pretrain._shard_file(tmp_path, 0, 1)
    shard.write_bytes(b"not a shard at all")
    with pytest.raises(ValueError, match=f"cannot read teacher shard {shard}"):
        pretrain.collect(Config(), 1, 0, tmp_path)


def test_a_zero_sensor_mount_names_the_key_and_value_once(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    config = tmp_path / "cell.yaml"
    config.write_text("sensor:\n  mount_quaternion_wxyz: [0, 0, 0, 0]\n")
    one_line_error([*REACH, "--config", str(config)], capsys, "cell.yaml",
                   "sensor.mount_quaternion_wxyz", "(0.0, 0.0, 0.0, 0.0)")


def test_output_into_a_closed_pipe_ends_quietly(monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture) -> None:
    """`vprobot objects list | head`: the reader goes away; no error line."""
    reader, writer = os.pipe()
    os.close(reader)
    with open(writer, "w") as stdout:
        monkeypatch.setattr("sys.stdout", stdout)
        code = main(["objects", "list"])
        monkeypatch.undo()
    assert code == 141
    assert capsys.readouterr().err == ""


def test_a_short_row_in_a_rollout_table_names_the_file_and_line(tmp_path: Path) -> None:
    from vprobot.stop_studies.dataset import COLUMNS, read_dataset

    table = tmp_path / "validation.csv"
    row = ",".join(["0", "motor_000", "motor", "nbv", "0", "1", *["0.5"] * (len(COLUMNS) - 6)])
    table.write_text("\n".join([",".join(COLUMNS), row, row[:20], row]) + "\n")
    with pytest.raises(ValueError, match=f"{table}, line 3: 4 cells where the header has "
                                         f"{len(COLUMNS)} columns"):
        read_dataset(table)
    table.write_text("\n".join([",".join(COLUMNS), row, row.replace("nbv,0,1", "nbv,0,x")]))
    with pytest.raises(ValueError, match=f"{table}, row 2: view is not a number"):
        read_dataset(table)
