"""How much a coverage moves with the CPU's arithmetic kernels (issue 42): nbv's rollout of the
T-slot (seed 0, straight-line moves, robot in the loop) played once per kernel setting, each in a
fresh process with an empty cache (so that the ground truth is built under that setting too), and
compared with the rows `stop fit` recorded on the machine the study ran on
(results/stop_estimate/foreign/rollouts.csv).

The settings pick the kernels another CPU would get: OpenBLAS's core type (Haswell: AVX2 and
FMA, as on AMD Zen; Sandybridge: AVX without FMA; Prescott: SSE3), numpy's SIMD paths
(NPY_DISABLE_CPU_FEATURES) and torch's (ATEN_CPU_CAPABILITY).

    python scripts/cpu_spread.py --out results/cpu_spread
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PART = ROOT / "results" / "stop_estimate" / "foreign" / "t_slot.stl"
RECORDED = ROOT / "results" / "stop_estimate" / "foreign" / "rollouts.csv"
NO_NUMPY_SIMD = {"NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"}
SETTINGS: dict[str, dict[str, str]] = {
    "native": {},
    "openblas-haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "openblas-sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "openblas-prescott": {"OPENBLAS_CORETYPE": "Prescott"},
    "sandybridge-numpy-v2-torch-default": {"OPENBLAS_CORETYPE": "Sandybridge",
                                           "ATEN_CPU_CAPABILITY": "default", **NO_NUMPY_SIMD},
}
PLAY = """
import json, sys
from pathlib import Path
from vprobot.config import Config, replace
from vprobot.episode import seeded_episode
from vprobot.stop_studies.dataset import rollout
config = replace(Config(), "kinematics", path_planner="line")
spec = seeded_episode(config.env, Path(sys.argv[1]), 0, 0.001)
print(json.dumps([row["coverage"] for row in rollout(config, spec, "nbv")]))
"""


def play(setting: dict[str, str]) -> list[float]:
    """The coverage after each view under `setting`, in a fresh process and cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, **setting, "VPROBOT_CACHE_DIR": cache}
        out = subprocess.run([sys.executable, "-c", PLAY, str(PART)], env=env, check=True,
                             capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[-1])


def recorded() -> list[float]:
    with RECORDED.open() as stream:
        return [float(row["coverage"]) for row in csv.DictReader(stream)
                if row["object"].endswith("t_slot.stl") and row["planner"] == "nbv"
                and row["seed"] == "0"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    out = parser.parse_args().out
    out.mkdir(parents=True, exist_ok=True)
    columns = {"recorded (stop fit's machine)": recorded()}
    for name, setting in SETTINGS.items():
        print(name, file=sys.stderr)
        columns[name] = play(setting)
    views = min(len(values) for values in columns.values())
    with (out / "coverage.csv").open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["view", *columns])
        for view in range(views):
            writer.writerow([view + 1, *(f"{values[view]:.6f}" for values in columns.values())])
    spread = max(round((max(v[i] for v in columns.values()) - min(v[i] for v in columns.values()))
                       * 2048) for i in range(views))
    print(f"largest spread over the settings: {spread} of 2048 GT points")


if __name__ == "__main__":
    main()
