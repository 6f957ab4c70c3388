"""Collision checks of robot configurations from MuJoCo contacts."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from vprobot.cell.scene import PLANNING_SLACK_M, Cell
from vprobot.geometry.poses import Pose


class CollisionChecker:
    """Finds contacts of robot links and sensor housing with the cell, the object and each other.

    Adjacent links never count, nor links in contact in every configuration: the robot's MJCF
    excludes those pairs and no others, never the sensor (docs/cell-and-robots.md). Environment
    geoms do not collide with each other by their collision bits. The cell gives every
    environment geom its clearance as MuJoCo's geom margin (`Cell`, `cell.safety`): a robot geom
    closer to it than that is a collision, as is any penetration between robot geoms. Planning
    keeps `PLANNING_SLACK_M` more (the arm moves between the configurations a path is checked
    at); the replay check, which checks every sample, keeps the margins themselves
    (`planning=False`).

    The checker owns its MjData: the object placement it checks against is its own state, set
    once per episode with `place_object`, and never shared with FK, the sensor or a renderer.

    Args:
        cell: The compiled cell.
        object_rotation: Rotation of the object about its centre (3x3); upright when omitted.
        planning: Keep `PLANNING_SLACK_M` beyond the clearance margins.
    """

    def __init__(self, cell: Cell, object_rotation: np.ndarray | None = None,
                 planning: bool = True):
        self.cell = cell
        self.model = cell.model
        self.data = cell.make_data()
        # An environment contact carries margin + slack (`Cell`); robot pairs carry none.
        self._slack_off = 0.0 if planning else PLANNING_SLACK_M
        self.object_pose = self.place_object(np.eye(3) if object_rotation is None
                                             else object_rotation)

    def place_object(self, rotation: np.ndarray) -> Pose:
        """Place the object (and fixture) to check against; returns the object pose."""
        self.object_pose = self.cell.place_object(self.data, rotation)
        return self.object_pose

    def _collide(self, q: npt.ArrayLike) -> None:
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_collision(self.model, self.data)

    def in_collision(self, q: npt.ArrayLike) -> bool:
        """Whether configuration `q` puts any robot geom into contact."""
        self._collide(q)
        count = self.data.ncon
        # The struct-array view is orders of magnitude faster than iterating MjContact objects.
        if count == 0:
            return False
        contacts = self.data.contact
        return bool((contacts.dist[:count] < self._threshold(
            contacts.includemargin[:count])).any())

    def _threshold(self, includemargin: np.ndarray | float) -> np.ndarray:
        """The distance below which a contact counts: its margin, less the planning slack
        when not planning (environment pairs only)."""
        margin = np.asarray(includemargin, dtype=float)
        return np.where(margin > 0.0, margin - self._slack_off, margin)

    def first_collision(self, path: np.ndarray) -> int | None:
        """Index of the first configuration on `path` (n, dof) in collision, or None."""
        for index, q in enumerate(path):
            if self.in_collision(q):
                return index
        return None

    def colliding_pairs(self, q: np.ndarray) -> list[tuple[str, str]]:
        """Names of the bodies in contact at `q` (for messages and debugging)."""
        self._collide(q)
        pairs = []
        for contact in self.data.contact[: self.data.ncon]:
            if contact.dist < self._threshold(contact.includemargin):
                body1 = self.model.body(self.model.geom_bodyid[contact.geom1]).name
                body2 = self.model.body(self.model.geom_bodyid[contact.geom2]).name
                pairs.append((body1, body2))
        return pairs
