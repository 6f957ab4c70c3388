"""A wheel works on its own: robots, motors and configs ship as package data.

The wheel is built from this checkout and installed (without dependencies) into a fresh venv
that sees the dependencies of the running interpreter as plain paths, not the editable install
of this checkout; then `vprobot plan` and `gym.make` run from an unrelated folder.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


def _run(argv: list[str], cwd: Path, env: dict[str, str]) -> str:
    done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{argv} failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.fixture(scope="module")
def wheel_venv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    root = tmp_path_factory.mktemp("packaging")
    # Without PYTHONPATH, which could put a checkout's vprobot before the wheel's.
    env = {**{key: value for key, value in os.environ.items() if key != "PYTHONPATH"},
           "VPROBOT_CACHE_DIR": str(root / "cache"), "MUJOCO_GL": "egl"}
    # Built from a copy: an in-tree build would leave build/ behind, and reuse a stale one. The
    # user's outputs (runs/, studies/) stay out: large, and written to while trainings run.
    source = root / "source"
    shutil.copytree(REPO, source, symlinks=True, ignore=shutil.ignore_patterns(
        ".git", "build", "dist", "*.egg-info", "__pycache__", ".*_cache", "results", "docs",
        "runs", "studies"))
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
          "-w", str(root / "dist"), str(source)], root, env)
    (wheel,) = (root / "dist").glob("vprobot-*.whl")
    venv = root / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], root, env)
    _run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install",
          "-q", "--no-deps", "--no-index", str(wheel)], root, env)
    # The dependencies as plain path entries: their .pth files, and so this checkout's
    # editable install, are not processed.
    site = Path(_run([str(venv / "bin" / "python"), "-c",
                      "import sysconfig; print(sysconfig.get_paths()['purelib'])"], root,
                     env).strip())
    paths = [entry for entry in sys.path if entry.endswith("site-packages")
             and Path(entry).is_dir()]
    (site / "dependencies.pth").write_text("\n".join(paths) + "\n")
    work = root / "elsewhere"
    work.mkdir()
    return venv, {**env, "PATH": f"{venv / 'bin'}{os.pathsep}{env['PATH']}"}


def test_wheel_plans_from_an_unrelated_folder(wheel_venv: tuple[Path, dict[str, str]]) -> None:
    venv, env = wheel_venv
    work = venv.parent / "elsewhere"
    out = _run([str(venv / "bin" / "vprobot"), "plan", "--out", "plan.json"], work, env)
    assert "goal 90% reached" in out
    assert (work / "plan.json").stat().st_size > 0
    where = _run([str(venv / "bin" / "python"), "-c", "import vprobot; print(vprobot.__file__)"],
                 work, env)
    assert where.startswith(str(venv)), where
    robots = _run([str(venv / "bin" / "vprobot"), "reach", "--help"], work, env)
    assert "ur10" in robots and "ur5" in robots


def test_wheel_makes_the_env_without_torch(wheel_venv: tuple[Path, dict[str, str]]) -> None:
    venv, env = wheel_venv
    code = ("import sys, gymnasium as gym, vprobot\n"
            "env = gym.make('vprobot/Inspect-v0', resolution=(107, 75))\n"
            "obs, info = env.reset(seed=0)\n"
            "assert obs.shape == (2048, 3) and info['acquisitions'] == 1\n"
            "assert 'torch' not in sys.modules and 'stable_baselines3' not in sys.modules\n"
            "print('ok')")
    assert _run([str(venv / "bin" / "python"), "-c", code], venv.parent / "elsewhere",
                env).strip() == "ok"
