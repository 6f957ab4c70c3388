"""`vprobot report baselines`: runs from any folder, says when an agent's row is over only some
of its seeds, and answers a bad argument with one line (exit 2)."""

from __future__ import annotations

from pathlib import Path

import pytest

from vprobot.cli import main

ROOT = Path(__file__).resolve().parents[1]
SEEDS = ROOT / "results" / "families" / "motors" / "seeds.csv"


def test_a_partial_seeds_table_is_compared_from_another_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Seed 1 has not scored test-v1 yet and no seed the other lists: the rows say so, and
    the baselines of the repository are found from a folder outside it."""
    header, validation, test, *_ = SEEDS.read_text().splitlines()
    assert validation.startswith("validation,0 1 2,3,") and test.startswith("test-v1,0 1 2,3,")
    agent = tmp_path / "agent"
    agent.mkdir()
    (agent / "seeds.csv").write_text("\n".join([
        header, validation, test.replace("test-v1,0 1 2,3,", "test-v1,0 2,2,"),
        "shapes-v1,,0" + "," * (header.count(",") - 2)]) + "\n")
    monkeypatch.chdir(tmp_path)
    assert main(["report", "baselines", "--agents", "partial=agent", "--out", "comparison.md",
                 "--targets"]) == 0
    text = (tmp_path / "comparison.md").read_text()
    assert ("Written by `vprobot report baselines --agents partial=agent --out comparison.md "
            "--targets`") in text
    assert "| agent (partial) | 0 2 (2 of 3 seeds) | 92.4 (91.5-92.9) |" in text
    assert text.count("| agent (partial) | none of 3 seeds | - | - | - |") == 2
    assert "| test-v1 | partial (2 of 3 seeds) |" in text
    assert "| shapes-v1 | partial (none of 3 seeds) | - |" in text
    assert "| uniform4 | - | 93.3 | 4.00 | 87 |" in text  # results/motors' row


def test_bad_arguments_are_one_line_errors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    for args, message in [
            (["--agents", f"a={SEEDS.parent}", "--out", "missing/comparison.md"],
             "--out missing/comparison.md: folder missing does not exist"),
            (["--agents", f"a={tmp_path}", "--out", "comparison.md"],
             f"{tmp_path} holds no seeds.csv (of `vprobot train --seeds`)")]:
        assert main(["report", "baselines", *args]) == 2
        assert capsys.readouterr().err == f"vprobot report baselines: error: {message}\n"
    with pytest.raises(SystemExit) as exit_:
        main(["report", "baselines", "--agents", f"={SEEDS.parent}", "--out", "comparison.md"])
    assert exit_.value.code == 2
    assert capsys.readouterr().err == (f"vprobot report baselines: error: argument --agents: "
                                       f"must be LABEL=DIR, got '={SEEDS.parent}'\n")
    assert not (tmp_path / "comparison.md").exists()
