"""Turn an exported plan JSON (docs/plan-format.md) back into an episode that can be rendered.

The plan fixes the cell (robot, base, sensor mount, sensor) and where the mesh file sits; the
config supplies everything else (IK and path settings, ground-truth settings). Reachable views
are driven to with their stored joints and acquired again, so coverage is recomputed rather than
trusted; unreachable views become records in which the robot stays. A free-flying plan
(`"carrier": "free"`) places the sensor at every view's pose again.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vprobot.config import Config
from vprobot.episode import Episode, EpisodeRecord, PartScene, ViewRequest
from vprobot.geometry.poses import Pose
from vprobot.kinematics import SensorTarget
from vprobot.plan import (
    plan_carrier,
    plan_field,
    plan_object,
    plan_quaternion,
    plan_vector,
    read_plan,
)


def episode_from_plan(config: Config, plan_path: str | Path,
                      resolution: tuple[int, int] | None = None
                      ) -> tuple[PartScene, EpisodeRecord]:
    """Rebuild the scene of a plan JSON and replay its views.

    Args:
        config: Settings the plan does not fix (kinematics, ground truth).
        plan_path: The plan (docs/plan-format.md), e.g. from `vprobot plan --json`.
        resolution: Sensor resolution of the replayed acquisitions; the plan's when omitted.

    Returns:
        The part's scene and the episode, one view record per plan view, in order.

    Raises:
        ValueError: If the plan is unreadable or incomplete, its mesh is missing, or a view's
            joints are invalid or collide on the way.
    """
    plan_path = Path(plan_path)
    document = read_plan(plan_path)
    if document.get("object") is None:
        raise ValueError(f"plan {plan_path} has no object block (mesh and pose); nothing to "
                         f"render")
    cell_config, mesh, rotation = plan_object(config, document, plan_path)
    scene = PartScene.build(cell_config, mesh, resolution)
    carrier = plan_carrier(document)
    episode = Episode(scene, rotation, carrier)
    for index, view in enumerate(document["views"]):
        where = f"views[{index}]"
        pose = Pose.from_quat(plan_vector(view, "position", 3, where),
                              plan_quaternion(view, "quaternion", where))
        if carrier == "free":
            episode.request(ViewRequest(SensorTarget(pose, roll_free=False)))
        elif plan_field(view, "reachable", where) and view.get("joints") is not None:
            joints = plan_vector(view, "joints", scene.cell.joints.dof, where)
            # The plan's own path when it has one (plans since issue 32), else planned anew.
            stored = view.get("waypoints")
            try:
                episode.replay(joints, requested=pose,
                               waypoints=None if stored is None else np.asarray(stored, float))
            except ValueError as error:
                raise ValueError(f"plan {where}: {error}") from error
        else:
            episode.skip(pose, view.get("reason") or "unreachable")
    return scene, episode.record()
