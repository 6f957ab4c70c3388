"""Offscreen rendering of inspections: rollout videos, summary pictures, replayed plans.

MuJoCo binds its OpenGL backend when it is first imported, and headless machines need EGL; the
default is set here, before this package imports mujoco (an explicit MUJOCO_GL still wins).
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from vprobot.render.video import EpisodeRenderer, RenderedVideo, render_episode

__all__ = ["EpisodeRenderer", "RenderedVideo", "render_episode"]
