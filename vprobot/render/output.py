"""Output files of the renderer: checked up front, written atomically (no half-written files)."""

from __future__ import annotations

import contextlib
from pathlib import Path
from types import TracebackType
from typing import Any

import imageio.v2 as imageio
import numpy as np

from vprobot.files.atomic import atomic_output
from vprobot.files.outputs import VIDEO_SUFFIXES, check_output_file

IMAGE_SUFFIXES = (".png",)


def check_output_path(path: str | Path, suffixes: tuple[str, ...]) -> Path:
    """Return `path` if a file of an allowed type can be written there (`vprobot.files.outputs`).

    Raises:
        ValueError: If `path` is a folder, its folder does not exist or cannot be written, or
            its suffix is not one of `suffixes`.
    """
    return check_output_file(path, "output path", suffixes)


class VideoWriter:
    """Frames to an MP4 (H.264 via imageio-ffmpeg) or an animated GIF, written atomically.

    Use as a context manager; the file appears at `path` only when the block exits cleanly.

    Args:
        path: Output file, `.mp4` or `.gif`, in an existing folder.
        fps: Frames per second.
        width: Frame width in pixels (every frame must have this size).
        height: Frame height in pixels.

    Raises:
        ValueError: For a bad path, a non-positive fps, or an odd size for MP4.
    """

    def __init__(self, path: str | Path, fps: float, width: int, height: int):
        self.path = check_output_path(path, VIDEO_SUFFIXES)
        if not fps > 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.is_gif = self.path.suffix.lower() == ".gif"
        if not self.is_gif and (width % 2 or height % 2):
            raise ValueError(f"MP4 (H.264, yuv420p) needs an even frame size, got "
                             f"{width}x{height}")
        self.fps, self.width, self.height = fps, width, height
        self.frames = 0
        self._stack = contextlib.ExitStack()
        self._writer: Any = None

    def __enter__(self) -> VideoWriter:
        temporary = self._stack.enter_context(atomic_output(self.path))
        if self.is_gif:
            self._writer = imageio.get_writer(temporary, mode="I", duration=1000.0 / self.fps,
                                              loop=0)
        else:
            # macro_block_size=2: keep the requested size instead of imageio's rescale to 16s.
            self._writer = imageio.get_writer(temporary, fps=self.fps, codec="libx264",
                                              quality=6, pixelformat="yuv420p",
                                              macro_block_size=2, ffmpeg_log_level="error")
        return self

    def append(self, frame: np.ndarray) -> None:
        """Add one RGB frame (height, width, 3) uint8.

        Raises:
            ValueError: If the frame does not have the writer's size.
        """
        if frame.shape != (self.height, self.width, 3):
            raise ValueError(f"frame shape {frame.shape} differs from the video's "
                             f"{(self.height, self.width, 3)}")
        self._writer.append_data(frame)
        self.frames += 1

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        try:
            self._writer.close()
        except BaseException as error:
            # A failed close (e.g. the encoder died) must discard the file like any other error.
            self._stack.__exit__(type(error), error, error.__traceback__)
            raise
        self._stack.__exit__(exc_type, exc, traceback)


def write_png(path: str | Path, image: np.ndarray) -> Path:
    """Write an RGB image as PNG atomically.

    Raises:
        ValueError: For a bad output path (see `check_output_path`).
    """
    path = check_output_path(path, IMAGE_SUFFIXES)
    with atomic_output(path) as temporary:
        imageio.imwrite(temporary, image)
    return path
