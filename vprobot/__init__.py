"""vprobot: robot-guided visual inspection planning in MuJoCo.

Importing it registers the gymnasium environment `vprobot/Inspect-v0`, without importing
gymnasium: the registration runs when gymnasium is first imported (at once if it already is).
Importing gymnasium here would cost every command line, `--help` included, 0.1-0.2 s.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING

from vprobot.compute import kernels

if TYPE_CHECKING:
    from importlib.machinery import ModuleSpec

# Offscreen rendering must work headless; MuJoCo reads this when it is first imported.
os.environ.setdefault("MUJOCO_GL", "egl")
# Before numpy loads: the same arithmetic on every CPU with AVX2 (vprobot/compute/kernels.py).
kernels.pin()

__version__ = "0.1.0"


def _register(gymnasium: ModuleType) -> None:
    gymnasium.register(id="vprobot/Inspect-v0", entry_point="vprobot.env.inspect_env:InspectEnv")


class _RegisterWithGymnasium:
    """A finder of `sys.meta_path` that finds nothing itself: when `gymnasium` is about to be
    imported it leaves `sys.meta_path` and wraps the real loader so that `_register` runs once
    gymnasium is whole. (wrapt's post-import hooks do this too, but importing wrapt costs as
    much as gymnasium; `importlib.abc.MetaPathFinder`, a base it need not have, 20 ms.)"""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> ModuleSpec | None:
        if fullname != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        loader = spec.loader
        exec_module = loader.exec_module

        def exec_and_register(module: ModuleType) -> None:
            exec_module(module)
            _register(module)

        loader.exec_module = exec_and_register  # type: ignore[method-assign]
        return spec


if "gymnasium" in sys.modules:
    _register(sys.modules["gymnasium"])
else:
    sys.meta_path.insert(0, _RegisterWithGymnasium())
