"""Issue 30's user errors and messages of the command line: each is one line naming what is
wrong and what is allowed (exit code 2), found before the long work."""

from __future__ import annotations

import argparse
import json
import socket
import time
from pathlib import Path

import pytest

from vprobot.cli import build_parser, main
from vprobot.config import Config, parse_yaml
from vprobot.episode import seeded_episode
from vprobot.files.paths import DEFAULT_MOTOR, PROFILES_DIR
from vprobot.kinematics import FAILURE_REASONS, OUT_OF_REACH
from vprobot.stopping.rules import stop_names


def _closed_port() -> int:
    """A local port nothing listens on (bound once, then released)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_a_cluster_address_where_nothing_listens_is_one_line_at_once(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    ray = pytest.importorskip("ray")
    address = f"127.0.0.1:{_closed_port()}"
    study = tmp_path / "study.yaml"
    study.write_text("profile: cpu.yaml\nsteps: 100\nseeds: [0]\ngrid:\n  agent.algorithm: [sac]\n")
    start = time.monotonic()
    code = main(["sweep", str(study), "--out", str(tmp_path / "out"), "--address", address])
    elapsed = time.monotonic() - start
    err = capsys.readouterr().err
    assert code == 2 and elapsed < 30, (code, elapsed, err)
    (line,) = err.splitlines()
    assert line.startswith(f"vprobot sweep: error: cannot reach the Ray cluster at {address}")
    assert not ray.is_initialized()


@pytest.mark.parametrize(("field", "value"), [
    ("object_quaternion", {"w": 1, "x": 0, "y": 0, "z": 0}),
    ("initial_views", {"phi": 1.42, "theta": 0.71}),
    ("initial_views", [[1.42, 0.71], [1.0]]),
    ("object_quaternion", "1 0 0 0"),
])
def test_a_malformed_episode_field_names_the_episode_and_the_field(
        field: str, value: object, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    spec = seeded_episode(Config().env, DEFAULT_MOTOR, 0).as_dict()
    episodes = tmp_path / "episodes.json"
    episodes.write_text(json.dumps({"version": 1, "episodes": [spec, {**spec, field: value}]}))
    code = main(["evaluate", "--episodes", str(episodes), "--planners", "uniform2",
                 "--out", str(tmp_path / "out")])
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2
    assert line.startswith(f"vprobot evaluate: error: {episodes} episodes[1]: episode spec "
                           f"{field} must be"), line


def test_a_key_given_twice_in_a_yaml_file_is_refused_with_its_lines(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    config = tmp_path / "twice.yaml"
    config.write_text("cell:\n  robot: ur5\nsensor:\n  near_m: 0.3\n  far_m: 0.5\n"
                      "  near_m: 0.35\n")
    code = main(["cell", "--config", str(config), "--candidates", "10"])
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2
    assert line == (f"vprobot cell: error: {config}: not valid YAML (line 6): key 'near_m' is "
                    f"given twice (first on line 4)")


def test_a_yaml_merge_key_may_still_be_overridden() -> None:
    assert parse_yaml("base: &base {near_m: 0.3}\nsensor:\n  <<: *base\n  near_m: 0.35\n",
                      "merge.yaml")["sensor"] == {"near_m": 0.35}


def test_unknown_test_lists_are_refused_with_the_profile_before_training(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "seeds"
    code = main(["train", str(PROFILES_DIR / "cpu.yaml"), "--seeds", "0", "--out", str(out),
                 "--set", "agent.test_lists=[test-v1, bogus]"])
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2 and not out.exists()
    assert line == ("vprobot train: error: agent.test_lists must name bundled episode lists "
                    "(test-v1, shapes-v1, families-test-v1, validation-v1, validation-v2, "
                    "validation-v3), got 'bogus'")


def test_teacher_needs_a_folder_and_a_profile_with_a_teacher(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    candidates = str(PROFILES_DIR / "cpu-candidates.yaml")
    assert main(["teacher", candidates]) == 2
    assert main(["teacher", str(PROFILES_DIR / "cpu.yaml"), "--out", str(tmp_path / "t")]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "vprobot teacher: error: give --out FOLDER, or a profile with agent.teacher_dir (the "
        "folder its runs read the teacher's states from)",
        f"vprobot teacher: error: {PROFILES_DIR / 'cpu.yaml'} has no teacher: its "
        f"agent.pretrain_episodes is 0"]
    assert not (tmp_path / "t").exists()


@pytest.mark.parametrize(("argv", "expected"), [
    (["plan", "--planner", "agent", "--views", "1000000"],
     "vprobot plan: error: argument --views: must be an integer in 1..100, got '1000000', which "
     "is too large"),
    (["evaluate", "--planners", "agent1000"],
     "vprobot evaluate: error: the view count of 'agent1000' must lie in 1..100, got 1000"),
    (["plan", "--planner", "uniform1000"],
     "vprobot plan: error: the view count k of uniform<k> must lie in 1..100, got 1000"),
    (["motors", "generate", "--count", "99999999999999999999"],
     "vprobot motors generate: error: argument --count: must be an integer in 1..10000, got "
     "'99999999999999999999', which is too large"),
    (["plan", "--stop", "views:²"],
     "vprobot plan: error: argument --stop: bad stop rule 'views:²': N must be an integer >= 1; "
     f"allowed: {', '.join(stop_names())}"),
], ids=["views", "agent-count", "uniform-count", "count", "stop-views-superscript"])
def test_out_of_range_counts_say_what_is_allowed(argv: list[str], expected: str, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture) -> None:
    try:
        code = main([*argv, "--out", str(tmp_path / ("out.json" if argv[0] == "plan" else "out"))])
    except SystemExit as exit_:  # argparse's errors
        code = exit_.code
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2 and line == expected


@pytest.mark.parametrize(("scale", "shown"), [("1e308", "1e+308"), ("1e-320", "9.99989e-321")])
def test_a_scale_that_overflows_or_underflows_the_mesh_is_named_by_the_size_check(
        scale: str, shown: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code = main(["plan", "--scale", scale, "--out", str(tmp_path / "plan.json")])
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2
    assert line.startswith(f"vprobot plan: error: {DEFAULT_MOTOR}: largest side is ")
    assert f" m with --scale {shown}, outside the allowed 0.01 .. 5 m; set --scale" in line


def test_a_folder_given_as_the_mesh_is_said_to_be_a_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code = main(["plan", "--mesh", str(tmp_path), "--out", str(tmp_path / "plan.json")])
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2
    assert line == (f"vprobot plan: error: {tmp_path} is a folder, not a mesh file trimesh can "
                    f"read (STL, OBJ, PLY, ...)")


def test_a_table_that_is_not_utf8_is_named(tmp_path: Path,
                                           capsys: pytest.CaptureFixture) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "monitor.csv").write_bytes(b'#{"t_start": 0}\nr,l,t\n\xff\xfe,1,2\n')
    code = main(["curves", str(run), "--out", str(tmp_path / "curves.png")])
    (line,) = capsys.readouterr().err.splitlines()
    assert code == 2
    assert line == (f"vprobot curves: error: {run / 'monitor.csv'} is not UTF-8 text (byte 22 "
                    f"is b'\\xff'): not a file vprobot wrote, or a damaged one")


def test_cell_prints_a_table_of_the_failure_reasons_only(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    report = tmp_path / "cell.json"
    assert main(["cell", "--robot", "ur5", "--candidates", "60", "--json", str(report)]) == 0
    lines = capsys.readouterr().out.splitlines()
    start = lines.index("unreachable, by reason (docs/cell-and-robots.md#reachability)")
    rows = [line.split() for line in lines[start + 1:] if not line.startswith("wrote")]
    document = json.loads(report.read_text())
    unreachable = round((1 - document["fraction"]) * 60)
    assert unreachable > 0 and "{" not in "\n".join(lines)
    assert {reason for reason, *_ in rows} <= set(FAILURE_REASONS) | {OUT_OF_REACH}
    assert sum(int(count) for _, count, _ in rows) == unreachable
    assert document["reasons"] == {reason: int(count) for reason, count, _ in rows}


def _without_help(parser: argparse.ArgumentParser, command: str) -> list[str]:
    """The arguments of a parser and its subcommands that --help shows without a text."""
    missing = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                missing += _without_help(sub, f"{command} {name}")
        elif action.help is None:
            missing.append(f"{command} {'/'.join(action.option_strings) or action.dest}")
    return missing


def test_every_option_and_argument_has_help() -> None:
    assert _without_help(build_parser(), "vprobot") == []
