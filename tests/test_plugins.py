"""Plugins: a planner in a module outside the package, loaded by `--plugin` or an entry point.
(In the Ray workers: tests/test_extensions.py's evaluation loads a `.py` file given relative to
the command's folder, tests/test_extensions_agent.py's a module on PYTHONPATH and a file; in
`SubprocVecEnv`'s children: tests/test_extensions_agent.py's training at `agent.n_envs: 2`.)"""

from __future__ import annotations

import csv
import importlib.metadata
import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from vprobot.cli import main
from vprobot.compute.processes import worker_pool
from vprobot.config import load_config
from vprobot.extensions import plugins
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.planners.base import PLANNERS, planner_names
from vprobot.report import check

ROOT = Path(__file__).resolve().parents[1]
TOY = '''"""A user's own planner: NAME, two views straight down onto the object."""

from vprobot.episode import ViewRequest
from vprobot.kinematics import SensorTarget
from vprobot.planners.base import PlanPlanner, register_planner
from vprobot.planners.self_stopping import SelfStopping


@register_planner
class TopViews(SelfStopping, PlanPlanner):
    name = "NAME"

    def plan(self, episode):
        distance = episode.scene.cell.config.sensor.working_distance_m
        return [ViewRequest(SensorTarget.look_at(
            episode.center + [0.0, 0.0, distance * (1.0 - 0.02 * index)], episode.center))
            for index in range(2)]
'''
ONE_FREE_EPISODE = ["--parts", str(DEFAULT_MOTOR), "--carriers", "free"]


def _toy(folder: Path, module: str, planner: str) -> Path:
    """A module `module` in `folder` that registers the planner `planner`."""
    folder.mkdir(exist_ok=True)
    path = folder / f"{module}.py"
    path.write_text(TOY.replace("NAME", planner))
    return path


def _rows(out: Path) -> list[dict[str, str]]:
    with (out / "evaluation_episodes.csv").open() as stream:
        return list(csv.DictReader(stream))


@pytest.fixture
def fresh_plugins(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """This process without plugins, and afterwards without the toy modules (listed by the
    test) and their planners."""
    monkeypatch.setattr(plugins, "_loaded", [])
    planner_names()  # the package's own planners registered first: only the toys' are undone
    planners = set(PLANNERS)
    toys: list[str] = []
    yield toys
    for name in set(PLANNERS) - planners:
        PLANNERS.unregister(name)
    for module in toys:
        sys.modules.pop(module, None)


def test_a_py_file_plugin_registers_its_planner_for_the_command(
        tmp_path: Path, fresh_plugins: list[str]) -> None:
    toy = _toy(tmp_path, "filetop_plugin", "filetop")
    fresh_plugins.append("filetop_plugin")
    assert main(["--plugin", str(toy), "--plugin", str(toy), "evaluate", "--planners", "filetop",
                 *ONE_FREE_EPISODE, "--seeds", "0", "--out", str(tmp_path / "out")]) == 0
    assert [(row["planner"], row["acquisitions"]) for row in _rows(tmp_path / "out")] == [
        ("filetop", "2")]
    # Imported once, under the file's name, and listed as Ray tasks take it.
    assert plugins.loaded() == (str(toy.resolve()),)
    assert sys.modules["filetop_plugin"].__file__ == str(toy.resolve())


def test_the_workers_of_a_pool_load_the_plugins_before_their_tasks(
        tmp_path: Path, fresh_plugins: list[str]) -> None:
    """`worker_pool` (the teacher's shards) spawns fresh processes: each imports the plugins
    this process loaded, once, before it takes a task."""
    imports = tmp_path / "imports.txt"
    marker = tmp_path / "marker_plugin.py"
    marker.write_text(f"import os\nwith open({str(imports)!r}, 'a') as log:\n"
                      f"    log.write(f'{{os.getpid()}}\\n')\n")
    fresh_plugins.append("marker_plugin")
    plugins.load([str(marker)])
    with worker_pool(2) as pool:
        workers = {pool.submit(os.getpid).result() for _ in range(4)}
    imported = [int(line) for line in imports.read_text().split()]
    # This process first; then each worker once (a worker started but given no task may too).
    assert imported[0] == os.getpid() and len(set(imported)) == len(imported)
    assert workers <= set(imported[1:])


def test_report_check_regenerates_a_plugin_planners_rows_in_its_child(
        tmp_path: Path, fresh_plugins: list[str], session_cache: Path) -> None:
    """`report check` runs `vprobot evaluate` as a child command, which loads the plugins of
    the checking process through its `--plugin` options."""
    toy = _toy(tmp_path, "checktop_plugin", "checktop")
    fresh_plugins.append("checktop_plugin")
    assert main(["--plugin", str(toy), "evaluate", "--planners", "checktop", *ONE_FREE_EPISODE,
                 "--seeds", "0", "--out", str(tmp_path / "out")]) == 0
    regenerated = tmp_path / "regenerated"
    check.regenerate(tmp_path / "out", regenerated, cache=session_cache)
    assert check.differences(tmp_path / "out", regenerated, None) == []
    assert [row["planner"] for row in _rows(regenerated / "tables")] == ["checktop"]


def test_an_entry_point_plugin_is_imported_without_an_option(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fresh_plugins: list[str]) -> None:
    _toy(tmp_path, "entrytop_plugin", "entrytop")
    fresh_plugins.append("entrytop_plugin")
    monkeypatch.syspath_prepend(str(tmp_path))
    entry = importlib.metadata.EntryPoint("entrytop", "entrytop_plugin", plugins.ENTRY_POINT_GROUP)

    def entry_points(**selection: str) -> list[importlib.metadata.EntryPoint]:
        return [entry] if selection == {"group": plugins.ENTRY_POINT_GROUP} else []

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    assert main(["evaluate", "--planners", "entrytop", *ONE_FREE_EPISODE, "--seeds", "0",
                 "--out", str(tmp_path / "out")]) == 0
    assert [row["planner"] for row in _rows(tmp_path / "out")] == ["entrytop"]
    assert plugins.loaded() == ("entrytop_plugin",)


@pytest.mark.parametrize(("plugin", "error"), [
    ("no_such_plugin", "ModuleNotFoundError: No module named 'no_such_plugin'"),
    ("{tmp}/missing.py", "FileNotFoundError: no such file: {tmp}/missing.py"),
    ("{tmp}/broken.py", "RuntimeError: half-written"),
    ("{tmp}/csv.py", "ValueError: a module named 'csv' is already imported; rename the file"),
    ("{tmp}/exits.py", "SystemExit: 0"),
], ids=["unknown-module", "missing-file", "raises", "shadows-a-module", "exits"])
def test_a_plugin_that_fails_to_import_is_a_one_line_error_naming_it(
        plugin: str, error: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        fresh_plugins: list[str]) -> None:
    (tmp_path / "broken.py").write_text('raise RuntimeError("half-written\\nsecond line")\n')
    (tmp_path / "csv.py").write_text("")
    (tmp_path / "exits.py").write_text("import sys\nsys.exit(0)\n")
    plugin, error = (text.replace("{tmp}", str(tmp_path)) for text in (plugin, error))
    assert main(["--plugin", plugin, "evaluate", "--planners", "hrec"]) == 2
    assert capsys.readouterr().err == (f"vprobot: error: plugin {plugin!r} failed to import: "
                                       f"{error}\n")
    assert plugins.loaded() == ()


def test_only_the_global_plugin_options_are_plugins(capsys: pytest.CaptureFixture[str]) -> None:
    """Not a `--plugin` after the command (which the parser refuses), nor an abbreviation of
    another option there (`evaluate --pl hrec`)."""
    options = plugins.global_options(["--plugin", "a", "--plugin=b", "--plug", "c", "evaluate",
                                      "--pl", "hrec", "--plugin", "d"])
    assert options.plugin == ["a", "b", "c"]
    assert options.command == ["evaluate", "--pl", "hrec", "--plugin", "d"]
    assert plugins.global_options(["--plugin"]).plugin == []  # the parser says what is missing
    with pytest.raises(SystemExit) as refused:
        main(["evaluate", "--plugin", "x"])
    assert refused.value.code == 2
    assert "unrecognized arguments: --plugin x" in capsys.readouterr().err


def test_the_entry_points_are_read_for_a_command_not_for_the_list_of_commands(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        fresh_plugins: list[str]) -> None:
    """`vprobot --help` lists the commands, which no plugin changes: it skips reading every
    distribution's metadata; `vprobot CMD --help` lists registered names, so it reads them."""
    reads: list[str] = []
    monkeypatch.setattr(plugins, "entry_point_modules", lambda: reads.append("read") or [])
    for argv in (["--help"], ["-h"]):
        with pytest.raises(SystemExit):
            main(argv)
    assert reads == [] and "evaluate" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["stop", "--help"])
    capsys.readouterr()
    assert reads == ["read"]


def _fresh_vprobot(argv: list[str], folder: Path) -> subprocess.CompletedProcess[str]:
    """`vprobot ARGV` in a fresh process (whose registries have not been read), in `folder`."""
    return subprocess.run([sys.executable, "-m", "vprobot.cli", *argv], capture_output=True,
                          text=True, cwd=folder, env={**os.environ, "PYTHONPATH": str(ROOT)},
                          check=False, timeout=120)


def test_a_plugin_taking_a_bundled_name_is_a_one_line_error_naming_it(tmp_path: Path) -> None:
    """Registered before the bundled entries were read, the name was refused later, in the
    bundled module, with a traceback that named no plugin (issue 42, P20; any registry: the
    export formats' is the cheapest to read)."""
    (tmp_path / "taker.py").write_text(
        "from vprobot.export.formats.base import register_format\n"
        "register_format('csv', '.csv', 'mine')(lambda motion, dt: '')\n")
    ran = _fresh_vprobot(["--plugin", "./taker.py", "export", "--help"], tmp_path)
    assert (ran.returncode, ran.stderr) == (2, (
        "vprobot: error: plugin './taker.py' failed to import: ValueError: export format 'csv' "
        "is already registered; give it another name\n"))


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_an_interrupt_while_a_plugin_loads_is_the_commands_interruption(
        signum: int, tmp_path: Path) -> None:
    """Not a KeyboardInterrupt traceback (Ctrl-C) or exit 143 (SIGTERM) (issue 42, P19)."""
    (tmp_path / "slow.py").write_text(f"import os\nos.kill(os.getpid(), {int(signum)})\n")
    # As from a terminal: a test run started in the background (CI's) ignores SIGINT, and a
    # child inherits that, so Python would install no Ctrl-C handler and the signal would be lost.
    ran = subprocess.run(
        [sys.executable, "-m", "vprobot.cli", "--plugin", "./slow.py", "plan", "--help"],
        capture_output=True, text=True, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=False, timeout=120,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert (ran.returncode, ran.stderr) == (130, "vprobot: interrupted\n")


def test_the_planner_of_docs_extending_runs_as_a_plugin_through_plan(
        tmp_path: Path, fresh_plugins: list[str]) -> None:
    """The whole planner docs/extending.md shows, copied from its Planner section, plans."""
    section = (ROOT / "docs" / "extending.md").read_text().split("\n## Planner\n")[1]
    code = section.split("\n## ")[0].split("```python\n")[1].split("```")[0]
    plugin = tmp_path / "circle.py"
    plugin.write_text(code)
    fresh_plugins.append("circle")
    out = tmp_path / "plan.json"
    assert main(["--plugin", str(plugin), "plan", "--planner", "circle", "--carrier", "free",
                 "--no-summary", "--out", str(out)]) == 0
    views = json.loads(out.read_text())["views"]
    # Four views on a level circle of radius d / sqrt(2) (d: the working distance), each
    # adding coverage.
    positions = np.array([view["position"] for view in views])
    radius = load_config().sensor.working_distance_m / np.sqrt(2.0)
    assert positions.shape == (4, 3)
    np.testing.assert_allclose(positions[:, 2], positions[0, 2])
    np.testing.assert_allclose(np.linalg.norm(positions[:, :2] - positions[:, :2].mean(axis=0),
                                              axis=1), radius)
    assert np.all(np.diff([view["coverage"] for view in views]) > 0)
