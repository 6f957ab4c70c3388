"""`scripts/compare_with_baselines.py`: runs from any folder, says when an agent's row is over
only some of its seeds, and answers a bad argument with one line (exit 2)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "compare_with_baselines.py"
SEEDS = ROOT / "results" / "families" / "motors" / "seeds.csv"


def compare(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=cwd, capture_output=True,
                          text=True, timeout=120, check=False)


def test_a_partial_seeds_table_is_compared_from_another_folder(tmp_path: Path) -> None:
    """Seed 1 has not scored test-v1 yet and no seed the other lists: the rows say so, and
    the baselines of the repository are found from a folder outside it."""
    header, validation, test, *_ = SEEDS.read_text().splitlines()
    assert validation.startswith("validation,0 1 2,3,") and test.startswith("test-v1,0 1 2,3,")
    agent = tmp_path / "agent"
    agent.mkdir()
    (agent / "seeds.csv").write_text("\n".join([
        header, validation, test.replace("test-v1,0 1 2,3,", "test-v1,0 2,2,"),
        "shapes-v1,,0" + "," * (header.count(",") - 2)]) + "\n")
    result = compare("--agents", "partial=agent", "--out", "comparison.md", "--targets",
                     cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    text = (tmp_path / "comparison.md").read_text()
    assert "| agent (partial) | 0 2 (2 of 3 seeds) | 92.4 (91.5-92.9) |" in text
    assert text.count("| agent (partial) | none of 3 seeds | - | - | - |") == 2
    assert "| test-v1 | partial (2 of 3 seeds) |" in text
    assert "| shapes-v1 | partial (none of 3 seeds) | - |" in text
    assert "| uniform4 | - | 95.1 | 4.00 | 93 |" in text  # results/motors' row


def test_bad_arguments_are_one_line_errors(tmp_path: Path) -> None:
    for args, message in [
            (["--agents", f"a={SEEDS.parent}", "--out", "missing/comparison.md"],
             "--out missing/comparison.md: folder missing does not exist"),
            (["--agents", f"a={tmp_path}", "--out", "comparison.md"],
             f"--agents a={tmp_path}: expected LABEL=DIR with DIR/seeds.csv")]:
        result = compare(*args, cwd=tmp_path)
        assert result.returncode == 2
        assert result.stderr.splitlines() == [f"compare_with_baselines.py: error: {message}"]
    assert not (tmp_path / "comparison.md").exists()
