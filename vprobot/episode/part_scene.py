"""Everything that depends on one part's mesh: built once, reused across episodes."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

from vprobot.cell.fit import check_fits
from vprobot.cell.scene import GEOM_GROUP_OBJECT, Cell
from vprobot.cell.sensor import DepthSensor
from vprobot.config import Config
from vprobot.coverage.ground_truth import ENVIRONMENT_GROUP, GroundTruth, ground_truth
from vprobot.geometry.poses import Pose
from vprobot.kinematics import RobotArm
from vprobot.parts.loading import LoadedMesh, load_mesh


@dataclasses.dataclass
class PartScene:
    """One part's mesh in the cell: its cell, robot arm, sensor and ground truth.

    Attributes:
        mesh: The loaded mesh (centred; `mesh.offset` and `mesh.scale` place the file).
        cell: The compiled cell holding it.
        arm: Robot kinematics in that cell.
        sensor: The depth sensor at the chosen resolution (the robot occludes).
        ground_truth: P_GT of the mesh (mesh frame).
    """

    mesh: LoadedMesh
    cell: Cell
    arm: RobotArm
    sensor: DepthSensor
    ground_truth: GroundTruth

    @classmethod
    def load(cls, config: Config, mesh_path: str | Path, scale: float = 1.0,
             resolution: tuple[int, int] | None = None,
             scale_option: str = "scale") -> PartScene:
        """Load a mesh file and build its cell, arm, sensor and ground truth.

        `scale_option` is how the user set `scale` (`mesh_loading.scale_setting`): the hints
        of a unit mistake name it.

        Raises:
            FileNotFoundError, ValueError: For a missing, unreadable, empty, flat or mis-scaled
                mesh, or an object too large for the cell (`vprobot.cell.fit`), before any ground
                truth is built.
        """
        return cls.build(config, load_mesh(mesh_path, scale, scale_option), resolution,
                         scale_option)

    @classmethod
    def build(cls, config: Config, mesh: LoadedMesh,
              resolution: tuple[int, int] | None = None,
              scale_option: str = "scale") -> PartScene:
        """Build the cell, arm, sensor and ground truth of an already loaded mesh (see `load`).

        Raises:
            ValueError: For an object too large for the cell, before any ground truth is built.
        """
        # Up front: an object that does not fit would otherwise cost a ground-truth build and a
        # plan that cannot succeed.
        check_fits(mesh, config, scale_option)
        cell = Cell(config, mesh.mesh)
        return cls(
            mesh=mesh,
            cell=cell,
            arm=RobotArm(cell),
            sensor=DepthSensor(cell, resolution=resolution),
            ground_truth=ground_truth(mesh.mesh, config),
        )

    @functools.cached_property
    def free_sensor(self) -> DepthSensor:
        """The same sensor seeing the object and the fixture only (a free-flying sensor)."""
        return DepthSensor(self.cell, resolution=self.sensor.resolution,
                           groups=(ENVIRONMENT_GROUP, GEOM_GROUP_OBJECT))

    def object_block(self, object_pose: Pose) -> dict[str, object]:
        """How to place the mesh file, as stored on disk, into the world (plan JSON).

        The loader scaled the file's vertices by `scale` and subtracted `offset`; a file vertex
        v therefore lands at position + R (scale * v - offset) = position' + R scale v.
        """
        position = object_pose.position - object_pose.rotation @ self.mesh.offset
        block: dict[str, object] = {
            "mesh": str(Path(self.mesh.path).resolve()),
            "position": [float(x) for x in position],
            "quaternion": [float(x) for x in object_pose.quaternion],
            "scale": float(self.mesh.scale),
        }
        if self.mesh.simplification is not None:
            # The views were planned on a simplified copy: say how far it is from the file.
            block["simplification"] = dataclasses.asdict(self.mesh.simplification)
        return block
