"""Each extension point extended from outside the package, as docs/extending.md says (issue 35):
one plugin file, written to a temporary folder, registers a toy of each kind, and the CLI
(`vprobot --plugin FILE ...`), a config file where one names the kind, and `vprobot evaluate
--workers 2` (Ray workers, which import the plugin themselves) take each toy as they take the
bundled ones, with no other file changed.

One section per kind: its toy's source in `TOYS`, its registry in `REGISTRIES` (and how a
bundled module registers in `BUNDLED`), its tests under its heading; a new kind adds the three.
No config names a planner, a stop rule, a part family or an export format: their toys go
through the CLI. The Ray evaluation at the end runs the toys an evaluation takes (a planner, a
stop rule, a part family: the episode list's objects, a sensing model) together, once, with a
robot folder and a sensor preset file of one's own (data, not code: no plugin). The reward's
and the encoder's toys, which a training run takes, are in tests/test_extensions_agent.py.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import DepthSensor
from vprobot.cli import main
from vprobot.config import Config, ConfigError, load_config
from vprobot.coverage.ground_truth import gt_sensing
from vprobot.episode import seeded_episode, write_episode_list
from vprobot.evaluation import SETTINGS_NAME
from vprobot.export.formats import FORMATS
from vprobot.extensions import plugins
from vprobot.extensions.registry import Registry
from vprobot.families import FAMILIES
from vprobot.files.paths import DEFAULT_MOTOR, ROBOTS_DIR, SENSORS_DIR
from vprobot.geometry.poses import Pose
from vprobot.parts.loading import load_mesh
from vprobot.planners.base import PLANNERS
from vprobot.planners.runner import make_planner
from vprobot.planners.self_stopping import stop_subject
from vprobot.sensing import IDEAL, SENSING_MODELS, frame_generator
from vprobot.stopping.rules import STOPS

ROOT = Path(__file__).resolve().parents[1]
CONFIG = Config()
MODULE = "vprobot_toys"
"""The plugin's module name (its file is `vprobot_toys.py`)."""
PLANNED_IN = "planned_in.txt"
"""The file beside the plugin where the toy planner notes each process that planned."""
MEASURED_IN = "measured_in.txt"
"""The file beside the plugin where the toy sensing model notes each process that measured."""
IMPORTED_IN = "imported_in.txt"
"""The file beside the evaluation's second plugin where it notes each process that imported it."""

TOYS: dict[str, str] = {}
"""Each kind's toy, as plugin source."""
REGISTRIES: dict[str, Registry[Any]] = {}
"""Each kind's registry."""
BUNDLED: dict[str, tuple[str, str, str, str]] = {}
"""Each kind's registry as a fresh process finds it (its module and name), the decorator a
bundled module registers with, and the module an entry comes from (an expression of `entry`)."""


def plugin_source() -> str:
    """The plugin: every kind's toy in one module."""
    return "\n\n".join(['"""vprobot\'s toys, one of each kind (tests/test_extensions.py)."""',
                        *TOYS.values()])


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """The plugin file, not loaded yet; afterwards this process without it and its toys."""
    monkeypatch.setattr(plugins, "_loaded", [])
    # Read first: the bundled entries register now, so only the toys are undone.
    before = {kind: set(registry) for kind, registry in REGISTRIES.items()}
    path = tmp_path / "plugin" / f"{MODULE}.py"
    path.parent.mkdir()
    path.write_text(plugin_source())
    yield path
    for kind, registry in REGISTRIES.items():
        for name in set(registry) - before[kind]:
            registry.unregister(name)
    sys.modules.pop(MODULE, None)


def help_text(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """The help of `vprobot ARGV --help`, as one line whatever the wrapping."""
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--help"])
    assert exit_.value.code == 0
    return " ".join(capsys.readouterr().out.split())


# ---- planner ------------------------------------------------------------------------------

TOYS["planner"] = f'''import os
from pathlib import Path

from vprobot.episode import ViewRequest
from vprobot.kinematics import SensorTarget
from vprobot.planners.base import PlanPlanner, register_planner
from vprobot.planners.self_stopping import SelfStopping


@register_planner
class TopToy(SelfStopping, PlanPlanner):
    """Three views straight down onto the object, from three heights, run to their end."""

    name = "toptoy"
    evaluated = ("toptoy",)

    def plan(self, episode):
        # Which processes planned: the command's, or Ray's workers.
        with (Path(__file__).parent / "{PLANNED_IN}").open("a") as stream:
            stream.write(f"{{os.getpid()}}\\n")
        distance = episode.scene.cell.config.sensor.working_distance_m
        return [ViewRequest(SensorTarget.look_at(
            episode.center + [0.0, 0.0, distance * (1.0 - 0.02 * index)], episode.center))
            for index in range(3)]'''
REGISTRIES["planner"] = PLANNERS
BUNDLED["planner"] = ("vprobot.planners.base", "PLANNERS", "@register_planner", "entry.__module__")


def test_a_plugin_planner_is_named_by_the_cli_built_by_name_and_evaluated_by_default(
        plugin: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "toptoy" not in PLANNERS
    text = help_text(capsys, "--plugin", str(plugin), "evaluate")
    planners = text.split("--planners PLANNERS [PLANNERS ...] ")[1].split(" --episodes")[0]
    assert "toptoy" in planners.split("; ")[0].split(", ")
    assert "toptoy" in planners.split("; default: ")[1].split()
    planner = help_text(capsys, "--plugin", str(plugin), "plan").split("--planner PLANNER ")[1]
    assert "toptoy" in planner.split(": ")[0].split(", ")
    built = make_planner("toptoy", CONFIG)
    assert type(built).__module__ == MODULE and not stop_subject(built).stops_at_goal


def test_evaluate_without_planners_runs_the_plugin_planner_it_declares(
        plugin: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    plugins.load([str(plugin)])
    # The bundled planners out of the default set, which then holds the toy alone.
    for cls in PLANNERS.values():
        if cls.__module__ != MODULE:
            monkeypatch.setattr(cls, "evaluated", ())
    assert main(["--plugin", str(plugin), "evaluate", "--parts", str(DEFAULT_MOTOR), "--seeds",
                 "0", "--carriers", "free", "--out", str(tmp_path / "out")]) == 0
    with (tmp_path / "out" / "evaluation_episodes.csv").open() as stream:
        assert [(row["planner"], row["acquisitions"]) for row in csv.DictReader(stream)] == [
            ("toptoy", "3")]


# ---- stop rule ----------------------------------------------------------------------------

TOYS["stop rule"] = '''from vprobot.stopping.rules.base import StopRule, register_stop


@register_stop
class TwoToy(StopRule):
    """Stops once two views were acquired."""

    name = "twotoy"
    description = "after two acquisitions (a toy)"

    def check(self, episode):
        return "two views" if sum(view.acquired for view in episode.views) >= 2 else None'''
REGISTRIES["stop rule"] = STOPS
BUNDLED["stop rule"] = ("vprobot.stopping.rules.base", "STOPS", "@register_stop",
                        "entry.__module__")


def test_a_plugin_stop_rule_is_described_by_the_help_and_stops_a_plan(
        plugin: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "twotoy: after two acquisitions (a toy)" in help_text(
        capsys, "--plugin", str(plugin), "plan")
    plan = tmp_path / "plan.json"
    # The toy planner plans three views; the toy rule stops it after two.
    assert main(["--plugin", str(plugin), "plan", "--no-summary", "--planner", "toptoy", "--stop",
                 "twotoy",
                 "--carrier", "free", "--out", str(plan)]) == 0
    document = json.loads(plan.read_text())
    assert (len(document["views"]), document["stop_rule"], document["stop_reason"]) == (
        2, "twotoy", "two views")
    # nbv@RULE builds its own rule from the same registry.
    assert make_planner("nbv@twotoy", CONFIG).stop_rule.name == "twotoy"  # type: ignore[attr-defined]


# ---- part family --------------------------------------------------------------------------

TOYS["part family"] = '''import trimesh

from vprobot.families.base import Parameter, PartFamily, register_family


@register_family
class BlockToy(PartFamily):
    name = "blocktoy"
    description = "blocktoy: a square block (a toy)"
    parameters = (Parameter("side_m", 0.08, 0.12, "side of the square"),
                  Parameter("height_ratio", 0.5, 1.0, "height / side"))

    def build(self, values):
        side = values["side_m"]
        return trimesh.creation.box((side, side, side * values["height_ratio"]))'''
REGISTRIES["part family"] = FAMILIES
BUNDLED["part family"] = ("vprobot.families.base", "FAMILIES", "@register_family",
                          "type(entry).__module__")


def test_a_plugin_part_family_is_listed_and_generated_by_the_cli(
        plugin: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--plugin", str(plugin), "objects", "list"]) == 0
    assert "blocktoy: blocktoy: a square block (a toy)" in capsys.readouterr().out
    out = tmp_path / "blocks"
    assert main(["--plugin", str(plugin), "objects", "generate", "--family", "blocktoy",
                 "--count", "2", "--out", str(out)]) == 0
    for seed in (0, 1):
        values = json.loads((out / f"blocktoy_000{seed}.json").read_text())["parameters"]
        mesh = trimesh.load(out / f"blocktoy_000{seed}.stl")
        side = values["side_m"]
        np.testing.assert_allclose(mesh.extents, [side, side, side * values["height_ratio"]],
                                   rtol=1e-6)


# ---- export format ------------------------------------------------------------------------

TOYS["export format"] = '''from vprobot.export.formats.base import register_format


@register_format("jointstoy", ".txt", "each view and its joints, one a line (a toy)")
def joints_toy(motion, dt):
    return "".join(f"{stop.view} {' '.join(map(repr, stop.joints.tolist()))}\\n"
                   for stop in motion.stops)'''
REGISTRIES["export format"] = FORMATS
BUNDLED["export format"] = ("vprobot.export.formats.base", "FORMATS", "@register_format(",
                            "entry.write.__module__")


def test_a_plugin_export_format_writes_a_plan_through_the_cli(
        plugin: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "jointstoy (.txt): each view and its joints" in help_text(
        capsys, "--plugin", str(plugin), "export")
    plan = tmp_path / "plan.json"
    assert main(["--plugin", str(plugin), "plan", "--no-summary", "--planner", "toptoy", "--stop",
                 "twotoy",
                 "--no-timing", "--out", str(plan)]) == 0
    # The format's suffix, from its registration.
    assert main(["--plugin", str(plugin), "export", str(plan), "--format", "jointstoy",
                 "--out", str(tmp_path / "joints.json")]) == 2
    assert ".txt" in capsys.readouterr().err
    out = tmp_path / "joints.txt"
    assert main(["--plugin", str(plugin), "export", str(plan), "--format", "jointstoy",
                 "--out", str(out)]) == 0
    # Each view the robot reached, in order, with the joints the plan holds for it.
    views = [(index, view["joints"]) for index, view in
             enumerate(json.loads(plan.read_text())["views"]) if view.get("waypoints")]
    rows = [line.split() for line in out.read_text().splitlines()]
    assert len(views) == 2 and [int(row[0]) for row in rows] == [index for index, _ in views]
    np.testing.assert_array_equal([[float(value) for value in row[1:]] for row in rows],
                                  [joints for _, joints in views])


# ---- every kind ---------------------------------------------------------------------------

# ---- sensing model ------------------------------------------------------------------------

TOYS["sensing model"] = '''import dataclasses
import os
from pathlib import Path

from vprobot.sensing import IDEAL, SENSING_MODELS, SensingModel


@SENSING_MODELS.register_named
@dataclasses.dataclass(frozen=True)
class HalfDropout(SensingModel):
    """Every hit drops out with probability 1/2; the rest are measured exactly."""

    name = "half_dropout"

    def measure(self, hits):
        # Which processes measured: the command's, or Ray's workers.
        with (Path(__file__).parent / "{MEASURED_IN}").open("a") as stream:
            stream.write(f"{os.getpid()}\\n")
        kept = hits.rng.random(len(hits.pixels)) < 0.5
        return hits.pixels[kept], hits.points[kept]

    def deterministic(self):
        # A point kept with a probability above 0 is inspectable: the ideal sensor's GT.
        return IDEAL'''.replace("{MEASURED_IN}", MEASURED_IN)
REGISTRIES["sensing model"] = SENSING_MODELS
BUNDLED["sensing model"] = ("vprobot.sensing.models", "SENSING_MODELS",
                            "@SENSING_MODELS.register_named", "entry.__module__")


def test_a_plugin_sensing_model_is_named_by_the_config_and_measures_through_its_class(
        plugin: Path, tmp_path: Path) -> None:
    path = tmp_path / "half.yaml"
    path.write_text("sensor: {sensing: half_dropout}\n")
    with pytest.raises(ConfigError, match=r"sensor.sensing must be one of"):
        load_config(path)
    plugins.load([str(plugin)])
    config = load_config(path)
    assert "half_dropout" in SENSING_MODELS and gt_sensing(config.sensor) == IDEAL
    cell = Cell(config, load_mesh(DEFAULT_MOTOR).mesh)
    data = cell.make_data()
    pose = Pose.look_at(cell.object_center + [0.1, -0.2, 0.4], cell.object_center)
    frame = DepthSensor(cell, resolution=(107, 75)).acquire_from_pose(data, pose)
    # The reference: the ideal frame, each hit kept by the frame's own draw (vprobot.sensing).
    ideal = DepthSensor(cell, resolution=(107, 75), sensing=IDEAL).acquire_from_pose(data, pose)
    kept = frame_generator(pose.position, pose.rotation, ideal.object_pose.position,
                           ideal.object_pose.rotation).random(len(ideal)) < 0.5
    assert 0 < len(frame) < len(ideal)
    np.testing.assert_array_equal(frame.pixels, ideal.pixels[kept])
    np.testing.assert_array_equal(frame.points_world, ideal.points_world[kept])


ENTRY_MODULES = """
import importlib, json, sys
found = {}
for kind, (module, name, _, expression) in json.loads(sys.argv[1]).items():
    registry = getattr(importlib.import_module(module), name)
    found[kind] = sorted({eval(expression) for entry in registry.values()})
print(json.dumps(found))
"""
"""A fresh process that reads each registry, having imported nothing but its module, and
prints the modules its entries come from."""


def test_a_bundled_module_that_registers_is_found_by_its_registry_alone() -> None:
    """One file per bundled extension, declared in its registry: the registry imports it."""
    found = json.loads(subprocess.run([sys.executable, "-c", ENTRY_MODULES, json.dumps(BUNDLED)],
                                      check=True, capture_output=True, text=True).stdout)
    for kind, (module, _, decorator, _) in BUNDLED.items():
        package = module.rsplit(".", 1)[0]
        folder = ROOT / package.replace(".", "/")
        registering = sorted(f"{package}.{path.stem}" for path in folder.glob("*.py")
                             if any(line.startswith(decorator)
                                    for line in path.read_text().splitlines()))
        assert registering and found[kind] == registering, kind


def test_the_plugin_registers_one_toy_of_each_kind(plugin: Path) -> None:
    before = {kind: set(registry) for kind, registry in REGISTRIES.items()}
    plugins.load([str(plugin)])
    assert {kind: set(registry) - before[kind] for kind, registry in REGISTRIES.items()} == {
        "planner": {"toptoy"}, "stop rule": {"twotoy"}, "part family": {"blocktoy"},
        "export format": {"jointstoy"}, "sensing model": {"half_dropout"}}


def test_the_toys_run_in_an_evaluation_on_two_ray_workers(plugin: Path, tmp_path: Path) -> None:
    """The toy planner, stopped by the toy rule, on two instances of the toy family, measured
    by the toy sensing model, with a robot folder and a sensor preset file of one's own (a copy
    of the bundled UR10's folder, the paper's preset at a fifth of its resolution): planned and
    measured in the workers, which imported both plugins (a module on PYTHONPATH, a .py file
    given relative to the command's folder); a config file names the robot and the preset as
    the options do."""
    pytest.importorskip("ray")
    robot = tmp_path / "my_arm"
    shutil.copytree(ROBOTS_DIR / "ur10", robot)
    preset = tmp_path / "my_sensor.yaml"
    preset.write_text((SENSORS_DIR / "paper.yaml").read_text().replace(
        "resolution: [430, 300]", "resolution: [86, 60]"))
    config_file = tmp_path / "cell.yaml"
    config_file.write_text(f"cell: {{robot: {robot}}}\nsensor: {preset}\n")
    config = load_config(config_file)
    assert config.cell.robot == str(robot) and config.sensor.resolution == (86, 60)
    episodes = tmp_path / "toys.json"
    write_episode_list(episodes, [seeded_episode(CONFIG.env, f"generated/blocktoy_000{seed}.stl",
                                                 seed) for seed in (0, 1)])
    # A second plugin, given as a .py file relative to the command's folder, notes each
    # process that imported it; the toys' plugin is given as a module on PYTHONPATH.
    (tmp_path / "extra").mkdir()
    (tmp_path / "extra" / "noting.py").write_text(
        f"import os\nfrom pathlib import Path\nwith (Path(__file__).parent / {IMPORTED_IN!r})"
        f".open('a') as stream:\n    stream.write(f'{{os.getpid()}}\\n')\n")
    command = subprocess.Popen(
        [sys.executable, "-m", "vprobot.cli", "--plugin", MODULE, "--plugin", "extra/noting.py",
         "evaluate", "--planners", "toptoy", "--stop", "twotoy", "--episodes", str(episodes),
         "--robot", "my_arm", "--sensor", "my_sensor.yaml", "--sensing", "half_dropout",
         "--carriers", "robot", "--workers", "2", "--out", "out"],
        cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(plugin.parent), str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])})
    _, stderr = command.communicate(timeout=600)
    assert command.returncode == 0, stderr
    with (tmp_path / "out" / "evaluation_episodes.csv").open() as stream:
        rows = sorted(csv.DictReader(stream), key=lambda row: row["episode"])
    # The toy rule stopped the toy planner's three views at two, on each toy part.
    assert [(row["part"], row["planner"], row["requested"], row["acquisitions"])
            for row in rows] == [("blocktoy_0000.stl", "toptoy --stop twotoy", "2", "2"),
                                 ("blocktoy_0001.stl", "toptoy --stop twotoy", "2", "2")]
    settings = json.loads((tmp_path / "out" / SETTINGS_NAME).read_text())["config"]
    assert (settings["cell"]["robot"], settings["sensor"]["resolution"],
            settings["sensor"]["sensing"]) == ("my_arm", [86, 60], "half_dropout")
    imported = {int(pid) for pid in (tmp_path / "extra" / IMPORTED_IN).read_text().split()}
    for noted in (PLANNED_IN, MEASURED_IN):
        pids = {int(pid) for pid in (tmp_path / "plugin" / noted).read_text().split()}
        assert pids and command.pid not in pids and pids <= imported, noted
