"""Command-line start-up benchmark: how long `vprobot --help` takes before the user reads it.

Each command runs `RUNS` times in a fresh interpreter, as the `vprobot` script runs it
(`from vprobot.cli import main`), timed from start to exit; the figures are the medians, beside
that of a bare interpreter (`python -c pass`), the floor no command goes below. The target is
`vprobot --help`, `plan --help` and `evaluate --help` in at most 0.3 s: the parser is built
from light modules only, and the registries list their bundled entries without importing them
(`tests/test_cli.py` checks that these import neither MuJoCo nor torch, trimesh, scipy.spatial
or Ray).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from typing import Any

RUNS = 7
COMMANDS = {"help": (("--help",), 0), "plan_help": (("plan", "--help"), 0),
            "evaluate_help": (("evaluate", "--help"), 0), "unknown_command": (("evalute",), 2)}
"""What is timed, with the exit code it must end with: the overview, the helps of the commands
that list the planners and stop rules (from their registries' declarations, importing none)
and a mistyped command (an error before any work)."""
_SCRIPT = "import sys\nfrom vprobot.cli import main\nsys.exit(main())\n"
"""What the `vprobot` console script runs."""


def _median_s(argv: Sequence[str], runs: int, shown: str, code: int = 0) -> float:
    """Median wall time of `runs` fresh interpreters running `argv` (`shown` in messages).

    Raises:
        RuntimeError: If one exits otherwise than with `code` (a broken command is no figure).
    """
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        child = subprocess.run([sys.executable, *argv], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True, check=False)
        times.append(time.perf_counter() - start)
        if child.returncode != code:
            raise RuntimeError(f"{shown} exited with {child.returncode}, not {code}: "
                               f"{child.stderr.strip()}")
    return statistics.median(times)


def run_cli_benchmark(runs: int = RUNS) -> dict[str, Any]:
    """Median seconds of each of `COMMANDS` (`<name>_s`) and of a bare interpreter
    (`python_s`), `runs` fresh processes each.

    Raises:
        ValueError: If runs < 1.
    """
    if runs < 1:
        raise ValueError(f"runs must be >= 1, got {runs}")
    results: dict[str, Any] = {"runs": runs,
                               "python_s": _median_s(["-c", "pass"], runs, "python -c pass")}
    for name, (argv, code) in COMMANDS.items():
        results[f"{name}_s"] = _median_s(["-c", _SCRIPT, *argv], runs,
                                         " ".join(["vprobot", *argv]), code)
    return results
