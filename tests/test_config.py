"""Config files load into typed dataclasses; bad keys and values are named in the error."""

from __future__ import annotations

from pathlib import Path

import pytest

from vprobot.cli import main
from vprobot.config import Config, ConfigError, from_mapping, load_config, replace
from vprobot.files.paths import CONFIGS_DIR
from vprobot.files.schema import read_yaml


@pytest.mark.parametrize("path", sorted(CONFIGS_DIR.glob("*.yaml")), ids=lambda p: p.name)
def test_bundled_configs_load(path: Path) -> None:
    assert isinstance(load_config(path), Config)


def test_default_file_matches_the_dataclass_defaults() -> None:
    assert load_config() == Config()


def test_unknown_key_names_key_and_allowed_keys() -> None:
    with pytest.raises(ConfigError, match=r"unknown key 'robt' in section 'cell'.*robot"):
        from_mapping(Config, {"cell": {"robt": "ur5"}})
    with pytest.raises(ConfigError, match=r"unknown key 'sensors' in the top level.*sensor"):
        from_mapping(Config, {"sensors": {}})


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"sensor": {"resolution": [430]}}, r"sensor.resolution must be a list of 2 values"),
        ({"sensor": {"near_m": "far"}}, r"sensor.near_m must be a number"),
        ({"sensor": {"near_m": 0.6}}, r"near_m < far_m"),
        ({"sensor": {"fov_deg": [179.9, 25.0]}},
         r"sensor\.fov_deg must be two opening angles in \(0, 120\] degrees, got \[179\.9, 25"),
        ({"sensor": {"fov_deg": [27.0, 0.0]}}, r"sensor\.fov_deg .* \(0, 120\]"),
        ({"sensor": {"working_distance_m": 0.8}},
         r"sensor\.working_distance_m must lie in \(near_m, far_m\] = \(0\.3, 0\.5\], got 0\.8"),
        ({"sensor": {"acquisition_time_s": -0.1}},
         r"sensor\.acquisition_time_s must lie in \[0, 60\] s, got -0\.1"),
        ({"sensor": {"far_m": 20.0}}, r"0 <= near_m < far_m <= 10 m, got .* far_m=20\.0"),
        # A name the system cannot look up (too long) is quoted cut short.
        ({"cell": {"robot": "r" * 10_000}},
         r"^cell\.robot: unknown robot 'r{37}\.\.\.r{38}': neither a bundled robot \(.*\) nor a "
         r"robot folder$"),
        ({"kinematics": {"roll": "loose"}}, r"kinematics.roll must be one of \['free', 'fixed'\]"),
        ({"kinematics": {"restarts": 1.5}}, r"kinematics.restarts must be an integer"),
        ({"kinematics": {"max_step_rad": -1.0}}, r"kinematics.max_step_rad must be > 0"),
        ({"cell": {"object_center_m": [0.0, 0.0, float("nan")]}}, r"must be finite"),
        ({"cell": "ur5"}, r"cell must be a mapping"),
    ],
)
def test_bad_values_are_named(data: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        from_mapping(Config, data)


def test_load_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"missing\.yaml"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("cell:\n  robot: ur5\n  speed: 3\n")
    with pytest.raises(ConfigError, match=r"bad\.yaml: unknown key 'speed'"):
        load_config(bad)
    listed = tmp_path / "list.yaml"
    listed.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match=r"mapping"):
        load_config(listed)


def test_replace_validates() -> None:
    config = replace(Config(), "cell", robot="ur5")
    assert config.cell.robot == "ur5"
    with pytest.raises(ConfigError, match="unknown key"):
        replace(Config(), "cell", colour="red")


def test_an_unusable_opening_angle_is_refused_by_plan(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    config = tmp_path / "wide.yaml"
    config.write_text("sensor:\n  fov_deg: [179.9, 25]\n")
    assert main(["plan", "--config", str(config), "--out", str(tmp_path / "p.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "wide.yaml" in err and "sensor.fov_deg" in err and "(0, 120]" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["wide.yaml"]


def test_every_yaml_reader_names_the_file_and_line_of_a_syntax_error(tmp_path: Path) -> None:
    from vprobot.parts.splits import Split
    from vprobot.robots import RobotDescription
    from vprobot.training.sweep import read_study
    from vprobot.training.train import parse_overrides

    # Line 3 opens a flow sequence that never closes.
    broken = "a: 1\nb: 2\nc: [1, 2\nd: 4\n"
    (tmp_path / "robot.yaml").write_text(broken)
    for name in ("config.yaml", "study.yaml", "split.yaml"):
        (tmp_path / name).write_text(broken)
    readers = [(load_config, "config.yaml"), (read_study, "study.yaml"),
               (Split.load, "split.yaml"), (lambda path: RobotDescription.load(path.parent),
                                            "robot.yaml")]
    for reader, name in readers:
        with pytest.raises(ValueError, match=rf"{name}.*not valid YAML \(line \d\)"):
            reader(tmp_path / name)
    with pytest.raises(ConfigError, match=r"override 'env\.mesh=\[a': not valid YAML"):
        parse_overrides(["env.mesh=[a"])


def test_a_yaml_file_read_again_is_a_document_of_its_own_and_a_changed_one_is_read_anew(
        tmp_path: Path) -> None:
    """read_yaml parses a text once (its parse is shared): each read still gets a document
    that no other read's change reaches, and the file's new text once it changes."""
    path = tmp_path / "config.yaml"
    path.write_text("env:\n  seed: 3\n  list: &l [1, 2]\n  again: *l\n")
    first = read_yaml(path)
    first["env"]["seed"] = 4
    first["env"]["list"].append(3)
    second = read_yaml(path)
    assert second == {"env": {"seed": 3, "list": [1, 2], "again": [1, 2]}}
    assert second["env"]["list"] is second["env"]["again"]  # an alias, as PyYAML reads it
    path.write_text("env:\n  seed: 5\n")
    assert read_yaml(path) == {"env": {"seed": 5}}
    # An error is raised at every read, not only the first.
    path.write_text("env: [\n")
    for _ in range(2):
        with pytest.raises(ConfigError, match="not valid YAML"):
            read_yaml(path)
