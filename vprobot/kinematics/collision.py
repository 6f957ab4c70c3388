"""Collision checks of robot configurations from MuJoCo contacts."""

from __future__ import annotations

import mujoco
import numpy as np

from vprobot.kinematics.forward import ForwardKinematics


class CollisionChecker:
    """Finds contacts of robot links and sensor housing with the cell, the object and each other.

    Adjacent links never count (MuJoCo filters parent-child contacts) and neither do the link
    pairs the robot description excludes; environment geoms do not collide with each other by
    their collision bits. A contact counts when its penetration exceeds `margin_m` (a negative
    margin demands clearance).

    Args:
        forward: Forward kinematics whose MjData holds the current object placement.
        margin_m: Penetration depth tolerated before a contact counts as a collision.
    """

    def __init__(self, forward: ForwardKinematics, margin_m: float = 0.0):
        self.forward = forward
        self.model = forward.cell.model
        self.data = forward.data
        self.margin_m = margin_m

    def _collide(self, q: np.ndarray) -> None:
        self.forward.set_configuration(q)
        mujoco.mj_collision(self.model, self.data)

    def in_collision(self, q: np.ndarray) -> bool:
        """Whether configuration `q` puts any robot geom into contact."""
        self._collide(q)
        count = self.data.ncon
        # The struct-array view is orders of magnitude faster than iterating MjContact objects.
        return count > 0 and bool((self.data.contact.dist[:count] < -self.margin_m).any())

    def colliding_pairs(self, q: np.ndarray) -> list[tuple[str, str]]:
        """Names of the bodies in contact at `q` (for messages and debugging)."""
        self._collide(q)
        pairs = []
        for contact in self.data.contact[: self.data.ncon]:
            if contact.dist < -self.margin_m:
                body1 = self.model.body(self.model.geom_bodyid[contact.geom1]).name
                body2 = self.model.body(self.model.geom_bodyid[contact.geom2]).name
                pairs.append((body1, body2))
        return pairs
