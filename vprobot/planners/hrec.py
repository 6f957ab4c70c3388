"""H_rec: one view per face of the object's bounding box (paper "Comparison with benchmark
algorithms").

The box is the world-axis-aligned bounding box of the object as it is posed in the episode. Each
view lies on the line from the box centre through a face centre, at the working distance from
the box centre, and looks at the object's centre (action A_3C0R): six views, whatever they
cover. (Placing the sensor at the working distance from the face itself would leave only the
first 3 cm behind the face within the sensor's far bound of 0.50 m: about 45 % coverage on the
bundled motors instead of the paper's 97 %.) With the robot, each view is first reached from
the current configuration; the reachable ones are ordered for short joint travel and the others
follow, so that executing them reports them unreachable (the IK gets one more chance from
wherever the robot then is).
"""

from __future__ import annotations

import numpy as np

from vprobot.episode import Episode, ViewRequest
from vprobot.kinematics import SensorTarget
from vprobot.planners.base import PlanPlanner, register_planner
from vprobot.planners.ordering import fixed_plan
from vprobot.planners.self_stopping import SelfStopping


def box_views(vertices_world: np.ndarray, center: np.ndarray,
              distance: float) -> list[SensorTarget]:
    """The six face views of the axis-aligned box around `vertices_world` (n, 3): at `distance`
    from the box centre through each face centre, looking at `center`."""
    middle = (vertices_world.min(axis=0) + vertices_world.max(axis=0)) / 2.0
    normals = np.concatenate([-np.eye(3), np.eye(3)])
    return [SensorTarget.look_at(middle + distance * normal, center) for normal in normals]


@register_planner
class BoxFacesPlanner(SelfStopping, PlanPlanner):
    """H_rec: six bounding-box face views, run to their end (not stopped at the goal)."""

    name = "hrec"
    evaluated = ("hrec",)

    def plan(self, episode: Episode) -> list[ViewRequest]:
        scene = episode.scene
        vertices = scene.mesh.mesh.vertices @ episode.object_pose.rotation.T + episode.center
        return fixed_plan(episode, box_views(vertices, episode.center,
                                             scene.cell.config.sensor.working_distance_m))
