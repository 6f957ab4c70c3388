"""Work that every planner of one episode does alike, done once (docs/evaluation.md#shared-work).

`evaluate` runs each planner on a fresh `Episode` of the same spec and carrier. What a planner
derives from the episode's start alone (the scene, the object pose, the carrier, the start
configuration) is the same for each of them: the model-based planners' candidate views, their
reachability screening and predicted visibility, and the simulated acquisitions that confirm
them; so are the robot's moves, reached targets and frames, which depend on their arguments
only. An `Episode` keeps such results in its `SharedWork`: its own, or one handed to every
episode of a spec and carrier, which refuses to serve an episode that starts otherwise.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any, TypeVar

import numpy as np

from vprobot.episode.part_scene import PartScene

T = TypeVar("T")


class SharedWork:
    """Results computed from an episode's start, by key, for every episode that starts alike."""

    def __init__(self) -> None:
        self._start: tuple[PartScene, bytes, str, bytes] | None = None
        self._results: dict[Hashable, Any] = {}

    def bind(self, scene: PartScene, object_rotation: np.ndarray, carrier: str,
             start_joints: np.ndarray) -> None:
        """Serve an episode that starts as these say (the first one fixes them).

        Raises:
            ValueError: If an episode that starts otherwise was served before.
        """
        start = (scene, np.asarray(object_rotation, dtype=float).tobytes(), carrier,
                 np.asarray(start_joints, dtype=float).tobytes())
        if self._start is None:
            self._start = start
        elif (start[0] is not self._start[0]) or start[1:] != self._start[1:]:
            raise ValueError("shared work serves the episodes of one scene, object pose, carrier "
                             "and start configuration; this episode starts otherwise")

    def get(self, key: Hashable, compute: Callable[[], T]) -> T:
        """The result under `key`, computed by `compute` the first time it is asked for."""
        if key not in self._results:
            self._results[key] = compute()
        return self._results[key]
