"""The design document in docs/: every reference to it from the code and between its pages
leads to a page and a heading that exist, no reference to the old internal spec is left, and
every page is in the index. The README: short, opening with the two set-up commands (the second
is what CI runs), touring every command."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SOURCES = ("vprobot", "tests", "scripts")
SUFFIXES = (".py", ".md", ".yaml")
FROM_CODE = re.compile(r"docs/([\w-]+\.md)(?:#([\w-]+))?")
"""A reference from the code: `docs/PAGE.md` or `docs/PAGE.md#anchor`."""
BETWEEN_PAGES = re.compile(r"\]\((?:([\w-]+\.md))?(?:#([\w-]+))?\)")
"""A Markdown link within docs/: `](PAGE.md)`, `](PAGE.md#anchor)` or `](#anchor)`."""
OLD_SPEC = re.compile(r"SPEC (?:sections?|§)")


def anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    return {anchor(line.lstrip("#")) for line in page.read_text().splitlines()
            if line.startswith("#")}


def source_files() -> list[Path]:
    files = [ROOT / "README.md"]
    for folder in SOURCES:
        files += [path for path in sorted((ROOT / folder).rglob("*")) if path.suffix in SUFFIXES]
    # This file names the patterns it looks for.
    return [path for path in files if path != Path(__file__).resolve()]


def test_anchor_follows_github_rules() -> None:
    assert anchor("The occupancy grid of `nbv`") == "the-occupancy-grid-of-nbv"
    assert anchor(" States, actions, rewards") == "states-actions-rewards"
    assert anchor("Split v1") == "split-v1"


def test_code_references_lead_to_existing_pages_and_headings() -> None:
    references = [(path, page, target) for path in source_files()
                  for page, target in FROM_CODE.findall(path.read_text(errors="replace"))]
    assert len(references) >= 31
    broken = [f"{path.relative_to(ROOT)}: docs/{page}#{target}"
              for path, page, target in references
              if not (DOCS / page).is_file() or (target and target not in anchors(DOCS / page))]
    assert broken == []


def test_links_between_pages_lead_to_existing_pages_and_headings() -> None:
    broken = []
    for path in sorted(DOCS.glob("*.md")):
        for page, target in BETWEEN_PAGES.findall(path.read_text()):
            linked = DOCS / page if page else path
            if not linked.is_file() or (target and target not in anchors(linked)):
                broken.append(f"{path.name}: {page}#{target}")
    assert broken == []


def test_no_reference_to_the_internal_spec_remains() -> None:
    left = [f"{path.relative_to(ROOT)}:{number}" for path in source_files()
            for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1)
            if OLD_SPEC.search(line)]
    assert left == []


README_COMMANDS = (
    "pip install -e . -c constraints.txt && vprobot plan --out plan.json --video rollout.mp4"
    "  # main job",
    'pip install -e ".[test]" -c constraints.txt && python -m pytest -q'
    "                      # tests",
)
"""The two set-up commands on a fresh machine, as the README states them."""
TORCH_FIRST = ("First `pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu`"
               " (the CUDA build otherwise, several GB); Python 3.11:")
"""The line before them: without torch's CPU build installed first, pip takes the CUDA one."""


def test_readme_is_short_and_opens_with_the_two_set_up_commands() -> None:
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) < 200
    opening = [line for line in lines[1:] if line.strip()][:5]
    assert lines[0].startswith("# ")
    assert opening == [TORCH_FIRST, "```bash", *README_COMMANDS, "```"]


def test_ci_runs_the_readmes_test_command() -> None:
    command = README_COMMANDS[1].split("#")[0].strip()
    assert command in (ROOT / ".ci" / "run").read_text().splitlines()


def test_ci_checks_the_lint_and_the_types_of_the_package() -> None:
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    assert any(line.startswith("ruff check") and "vprobot tests scripts" in line
               for line in lines)
    assert any(line.startswith("mypy") for line in lines)
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
    assert config["packages"] == ["vprobot"] and "ignore_missing_imports" not in config


def test_every_docs_page_is_in_the_index() -> None:
    index = (DOCS / "README.md").read_text()
    pages = {path.name for path in DOCS.glob("*.md")} - {"README.md"}
    assert {page for page in pages if f"]({page})" not in index} == set()


def test_readme_tours_every_command() -> None:
    import argparse

    from vprobot.cli import build_parser

    (commands,) = [action for action in build_parser()._actions
                   if isinstance(action, argparse._SubParsersAction)]
    readme = (ROOT / "README.md").read_text()
    assert [name for name in commands.choices if f"| `{name}` |" not in readme] == []
