"""What the docs claim holds: `configs/default.yaml` lists every setting of the schema with its
default (README, docs/running.md), docs/README.md's Layout names every module and subpackage of
`vprobot/`; the README's tour gives each long command's run time and says how to install torch's
CPU build, and no example writes into the repository's own `results/`; docs/benchmarks.md
describes every benchmark suite; the view sphere's reach and the README's candidate count are the
figures vprobot printed (`results/view_sphere/`, `results/export/plan.txt`)."""

from __future__ import annotations

import dataclasses
import json
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest

from vprobot.cell.check import CellError, check_cell
from vprobot.config import Config, load_config, replace, with_sensor
from vprobot.files.paths import DEFAULT_CONFIG, available_sensors
from vprobot.files.schema import read_yaml
from vprobot.kinematics.survey import default_cell
from vprobot.planners.candidates import CANDIDATE_COUNT

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "vprobot"


def settings(cls: type, prefix: str = "") -> set[str]:
    """Every setting of the config dataclass `cls`, dotted (`env.reward`); a section is a
    field whose default is itself a dataclass."""
    keys = set()
    for field in dataclasses.fields(cls):
        default = field.default_factory() if callable(field.default_factory) else field.default
        if dataclasses.is_dataclass(default):
            keys |= settings(type(default), f"{prefix}{field.name}.")
        else:
            keys.add(prefix + field.name)
    return keys


def written(data: dict[str, Any], prefix: str = "") -> set[str]:
    """Every key a YAML mapping sets, dotted; a nested mapping is a section, an empty one a
    value (`agent.encoder_settings: {}`)."""
    keys = set()
    for name, value in data.items():
        if isinstance(value, dict) and value:
            keys |= written(value, f"{prefix}{name}.")
        else:
            keys.add(prefix + name)
    return keys


def test_default_yaml_lists_every_setting_of_the_schema() -> None:
    missing = settings(Config) - written(read_yaml(DEFAULT_CONFIG))
    assert not missing, f"configs/default.yaml lacks {sorted(missing)}"


def test_default_yaml_values_are_the_schema_defaults() -> None:
    assert load_config(DEFAULT_CONFIG) == Config()


def layout() -> str:
    text = (ROOT / "docs" / "README.md").read_text()
    section = text.split("\n## Layout\n", 1)[1]
    return section.split("\n## ", 1)[0]


def test_docs_layout_names_every_module_and_subpackage() -> None:
    named = set(re.findall(r"`([\w./-]+)`", layout()))
    modules = {path.stem for path in PACKAGE.glob("*.py") if path.stem != "__init__"}
    packages = {f"{path.parent.name}/" for path in PACKAGE.glob("*/__init__.py")}
    missing = sorted((modules | packages) - named)
    assert not missing, f"docs/README.md#layout does not name {missing}"


def bash_blocks(path: Path) -> list[str]:
    """The lines of a Markdown file's ```bash blocks."""
    return [line for block in re.findall(r"```bash\n(.*?)```", path.read_text(), re.S)
            for line in block.splitlines()]


def test_readme_tour_states_the_run_time_of_each_long_command() -> None:
    readme = ROOT / "README.md"
    tour = bash_blocks(readme)
    long = [line for line in tour if re.match(r"vprobot (evaluate|train|sweep)\b", line)]
    assert len(long) >= 5
    untimed = [line for line in long if not re.search(r"# .*~\d+ (s|min|h)\b", line)]
    assert untimed == []


def test_readme_says_how_to_install_the_cpu_build_of_the_pinned_torch_before_its_commands(
        ) -> None:
    (pin,) = re.findall(r'"torch==([\d.]+)"', (ROOT / "pyproject.toml").read_text())
    readme = (ROOT / "README.md").read_text()
    install = f"`pip install torch=={pin} --index-url https://download.pytorch.org/whl/cpu`"
    assert install in readme
    assert "CUDA build" in readme
    # Said before the set-up commands, which would otherwise take the CUDA build.
    assert readme.index(install) < readme.index("```bash")


def _pins(text: str) -> dict[str, str]:
    """`name==version` lines of a requirements text, by normalised name."""
    return {match[0].lower().replace("_", "-"): match[1]
            for match in re.findall(r"^([A-Za-z0-9_.-]+)==([^\s;]+)", text, re.MULTILINE)}


def test_readme_installs_the_releases_the_suite_passed_with() -> None:
    readme = (ROOT / "README.md").read_text()
    setup = bash_blocks(ROOT / "README.md")[:2]
    assert all("pip install -e " in line and "-c constraints.txt" in line for line in setup)
    assert "newest" in readme
    locked = _pins((ROOT / "constraints.txt").read_text())
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())
    wanted = [re.split(r"[\s<>=!~\[;]", requirement, maxsplit=1)[0].lower()
              for requirement in [*declared["project"]["dependencies"],
                                  *declared["project"]["optional-dependencies"]["test"]]]
    assert [name for name in wanted if name not in locked] == []
    # The exact pins of pyproject.toml are the locked releases.
    exact = dict(re.findall(r'"([A-Za-z0-9_.-]+)==([^"]+)"', (ROOT / "pyproject.toml").read_text()))
    assert {name: locked[name.lower()] for name in exact} == exact


def test_ci_runs_the_readmes_test_command_and_the_newest_releases() -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    assert bash_blocks(ROOT / "README.md")[1].split("  #")[0].strip() in ci
    assert 'pip install -q --upgrade -e ".[test]"' in ci  # no constraints: the newest


def test_doc_examples_do_not_write_into_the_repositorys_results() -> None:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    writing = [f"{page.name}: {line}" for page in pages for line in bash_blocks(page)
               if re.search(r"--(out|json)\s+results\b", line)]
    assert writing == []


def test_benchmarks_page_describes_every_suite() -> None:
    import argparse

    from vprobot.cli import build_parser

    (commands,) = [action for action in build_parser()._actions
                   if isinstance(action, argparse._SubParsersAction)]
    (suite,) = [action for action in commands.choices["benchmark"]._actions
                if action.dest == "suite"]
    section = (ROOT / "docs" / "benchmarks.md").read_text().split("\n## Suites\n", 1)[1]
    section = section.split("\n## ", 1)[0]
    assert [name for name in suite.choices if f"- `{name}`:" not in section] == []


VIEW_SPHERE = ROOT / "results" / "view_sphere"
"""`vprobot cell --robot ROBOT --sensor PRESET --json` of each bundled robot and sensor preset."""
DOC_ROBOTS = {"UR10": "ur10", "UR10 (default)": "ur10", "Panda": "panda",
              "Franka Emika Panda": "panda", "UR5": "ur5"}


REFUSED = "refused: its home holds the housing against the motor"
"""How the docs write a cell `vprobot cell` refuses, its start pose failing the cell's check."""


def reached(robot: str, preset: str) -> str:
    """The view sphere's reachable share that `vprobot cell` recorded, as the docs write it; for
    a cell without a record, that `vprobot cell` refuses it (its start pose collides)."""
    record = VIEW_SPHERE / f"{robot}_{preset}.json"
    if not record.is_file():
        cell = default_cell(with_sensor(replace(Config(), "cell", robot=robot), preset))
        with pytest.raises(CellError, match=r"cell\.start_joints_rad: at the start pose"):
            check_cell(cell, cell.make_data())
        return REFUSED
    recorded = json.loads(record.read_text())
    assert recorded["robot"] == robot
    return f"{100 * recorded['fraction']:.1f} %"


def table(path: Path, header: str) -> list[list[str]]:
    """The cells of the Markdown table in `path` whose header row starts with `header`."""
    lines = path.read_text().splitlines()
    start = next(index for index, line in enumerate(lines) if line.startswith(header))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows


def test_view_sphere_figures_are_those_vprobot_cell_recorded() -> None:
    robots = table(ROOT / "docs" / "cell-and-robots.md", "| robot | joints | placement | reachable")
    assert {DOC_ROBOTS[row[0]]: row[3] for row in robots[2:]} == {
        robot: reached(robot, "paper") for robot in ("ur10", "panda", "ur5")}
    presets = table(ROOT / "docs" / "sensor.md", "| robot, preset |")
    names = [re.findall(r"`(\w+)`", cell)[0] for cell in presets[0][1:]]
    assert sorted(names) == sorted(available_sensors())
    assert {(DOC_ROBOTS[row[0]], name): figure for row in presets[2:]
            for name, figure in zip(names, row[1:], strict=True)} == {
        (robot, name): reached(robot, name) for robot in ("ur10", "panda", "ur5")
        for name in names}
    benchmarks = (ROOT / "docs" / "benchmarks.md").read_text()
    (row,) = re.findall(r"^\| view sphere reachable, UR10 / Panda / UR5 .*?\| (.*?) \|", benchmarks,
                        re.MULTILINE)
    assert row == " / ".join(reached(robot, "paper") for robot in ("ur10", "panda", "ur5"))


def test_readme_states_the_candidates_the_first_commands_plan_reached() -> None:
    # results/export/plan.txt is what the README's first command printed.
    printed = (ROOT / "results" / "export" / "plan.txt").read_text()
    ((candidates, reachable),) = re.findall(r"candidates (\d+), (\d+) reachable", printed)
    assert int(candidates) == CANDIDATE_COUNT
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert (f"B_SCP over {candidates} candidate views, of which the UR10 reaches {reachable},"
            in readme)
