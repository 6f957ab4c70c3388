"""Offscreen rendering of inspections: rollout videos, summary stills, replayed plans.

MuJoCo binds its OpenGL backend when it is first imported, and headless machines need EGL; the
default is set here, before this package imports mujoco (an explicit MUJOCO_GL still wins). The
renderer's own views create their context from MUJOCO_GL themselves (see `offscreen`), so they
work even when mujoco was imported first.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from vprobot.render.demo import ring_inspection
from vprobot.render.replay import episode_from_plan
from vprobot.render.summary import render_summary
from vprobot.render.video import EpisodeRenderer, RenderedVideo, render_episode

__all__ = [
    "EpisodeRenderer",
    "RenderedVideo",
    "episode_from_plan",
    "render_episode",
    "render_summary",
    "ring_inspection",
]
