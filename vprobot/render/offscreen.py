"""A headless OpenGL view of a MuJoCo model: one camera, extra geoms, RGB or depth out.

`mujoco.Renderer` picks its OpenGL backend when `mujoco` is first imported, so it fails headless
whenever something imported mujoco before MUJOCO_GL was set. This view creates its context from
MUJOCO_GL (default EGL) itself, which works whatever the import order was.
"""

from __future__ import annotations

import contextlib
import copy
import os
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

MAX_SIZE_PX = 4096
FINE_SAMPLES = 4


def _gl_context_class() -> Any:
    backend = os.environ.get("MUJOCO_GL", "egl").strip().lower()
    if backend == "egl":
        from mujoco.egl import GLContext
    elif backend == "osmesa":
        from mujoco.osmesa import GLContext
    elif backend in ("glfw", "glx"):
        from mujoco.glfw import GLContext
    else:
        raise ValueError(f"MUJOCO_GL={backend!r} is not supported for offscreen rendering; "
                         "use egl, osmesa or glfw")
    return GLContext


def check_size(width: int, height: int) -> tuple[int, int]:
    """Return the image size as ints, or raise ValueError naming the bad value."""
    for name, value in (("width", width), ("height", height)):
        if int(value) != value or not 1 <= value <= MAX_SIZE_PX:
            raise ValueError(f"{name} must be an integer in [1, {MAX_SIZE_PX}], got {value}")
    return int(width), int(height)


class OffscreenView:
    """Renders a model's state from a free or fixed camera into numpy images.

    The model is copied, so the framebuffer size and quality settings do not leak into the
    caller's model.

    Args:
        model: The model to render.
        width: Image width in pixels.
        height: Image height in pixels.
        fine: 4x multisampling and floor reflections (for stills); without them software
            OpenGL (Mesa llvmpipe) renders several times faster. Shadows stay off either way:
            MuJoCo's extra light passes add up on lines and wash the markers' colours out.
        max_geom: Room for extra geoms drawn per frame, on top of the model's own.

    Raises:
        ValueError: For a size outside [1, 4096] or an unsupported MUJOCO_GL.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int, fine: bool = False,
                 max_geom: int = 1000):
        self.width, self.height = check_size(width, height)
        self.model = copy.copy(model)
        visual = self.model.vis
        visual.global_.offwidth = max(self.width, visual.global_.offwidth)
        visual.global_.offheight = max(self.height, visual.global_.offheight)
        visual.quality.offsamples = FINE_SAMPLES if fine else 0
        self.scene = mujoco.MjvScene(self.model, maxgeom=self.model.ngeom + max_geom)
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = fine
        self.option = mujoco.MjvOption()
        self.camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(self.model, self.camera)
        self._rect = mujoco.MjrRect(0, 0, self.width, self.height)
        self._gl = _gl_context_class()(self.width, self.height)
        self._gl.make_current()
        self._context = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._rgb = np.empty((self.height, self.width, 3), dtype=np.uint8)
        self._depth = np.empty((self.height, self.width), dtype=np.float32)

    def use_fixed_camera(self, name: str) -> None:
        """Render from the model's camera `name` instead of the free camera.

        Raises:
            ValueError: If the model has no such camera.
        """
        camera_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if camera_id < 0:
            raise ValueError(f"the model has no camera named {name!r}")
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.camera.fixedcamid = camera_id

    def update(self, data: mujoco.MjData,
               draw: Callable[[mujoco.MjvScene], None] | None = None) -> None:
        """Build the scene from `data` (after kinematics), then let `draw` append extra geoms."""
        # Cameras and lights are placed by mj_camlight, which mj_kinematics alone does not run.
        mujoco.mj_camlight(self.model, data)
        mujoco.mjv_updateScene(self.model, data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL.value, self.scene)
        if draw is not None:
            draw(self.scene)

    def rgb(self) -> np.ndarray:
        """Render the current scene; returns a new (height, width, 3) uint8 image."""
        self._gl.make_current()
        mujoco.mjr_render(self._rect, self.scene, self._context)
        mujoco.mjr_readPixels(self._rgb, None, self._rect, self._context)
        return np.flipud(self._rgb).copy()

    def depth(self) -> np.ndarray:
        """Render the current scene; returns the distance along the view axis (m) per pixel."""
        self._gl.make_current()
        mujoco.mjr_render(self._rect, self.scene, self._context)
        mujoco.mjr_readPixels(None, self._depth, self._rect, self._context)
        # Reversed-Z depth runs from 1 at the near clip plane to 0 at the far one, hyperbolically.
        extent = self.model.stat.extent
        near = self.model.vis.map.znear * extent
        far = self.model.vis.map.zfar * extent
        depth = np.flipud(self._depth).astype(float)
        return far * near / (depth * (far - near) + near)

    def close(self) -> None:
        """Free the OpenGL resources (also done when the view is garbage-collected)."""
        if self._gl is not None:
            self._gl.make_current()
            self._context.free()
            self._gl.free()
            self._gl = None

    def __enter__(self) -> OffscreenView:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __del__(self) -> None:
        # Best effort only: at interpreter exit EGL may already be torn down.
        with contextlib.suppress(Exception):
            if getattr(self, "_gl", None) is not None:
                self.close()
