"""2D annotations drawn on rendered frames: the episode's status, a coverage bar, an inset panel."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from PIL import Image, ImageDraw, ImageFont

TEXT_RGB = (240, 240, 240)
DIM_RGB = (170, 170, 170)
WARN_RGB = (255, 90, 80)
BAR_RGB = (40, 200, 70)
BOX_RGBA = (0, 0, 0, 150)
GOAL_COVERAGE = 0.9
"""Where the coverage bar marks the episode's goal (docs/states-actions-rewards.md#episode-end)."""
COVERAGE_LINE = 1
"""The status line under which the coverage bar goes."""
MAX_MARKS = 4
"""Unreachable requests listed by name; more are summed up in one line."""


@dataclasses.dataclass(frozen=True)
class OverlayStatus:
    """What the overlay says about the episode at one frame.

    Attributes:
        step: 1-based number of the current view (0 before the first).
        steps: Views in the episode.
        caption: What is happening (e.g. "moving to view 3").
        coverage: Cumulative coverage shown, in [0, 1].
        joint_time_s: Joint time travelled so far (s).
        sensor_path_m: Length of the sensor's path so far (m).
        unreachable: (view number, reason) of the unreachable requests so far.
        clock_s: The cell's clock, the elapsed cycle time (s); None without a cycle.
        cycle_s: The episode's cycle time (s); None without a cycle.
    """

    step: int
    steps: int
    caption: str
    coverage: float
    joint_time_s: float
    sensor_path_m: float
    unreachable: tuple[tuple[int, str], ...] = ()
    clock_s: float | None = None
    cycle_s: float | None = None


@functools.lru_cache(maxsize=8)
def font(size_px: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """Pillow's bundled font at `size_px`."""
    return ImageFont.load_default(size=size_px)


def _status_lines(status: OverlayStatus) -> list[tuple[str, tuple[int, int, int]]]:
    lines = [
        (f"view {status.step}/{status.steps}  {status.caption}" if status.step else
         f"{status.steps} views  {status.caption}", TEXT_RGB),
        (f"coverage {100.0 * status.coverage:5.1f} %", TEXT_RGB),
    ]
    if status.clock_s is not None and status.cycle_s is not None:
        lines.append((f"cell clock {status.clock_s:6.2f} s of {status.cycle_s:.2f} s cycle",
                      TEXT_RGB))
    lines.append((f"travel {status.joint_time_s:5.2f} s joint, {status.sensor_path_m:5.2f} m "
                  f"sensor", DIM_RGB))
    marks = [f"x view {step} unreachable ({reason.replace('_', ' ')})"
             for step, reason in status.unreachable]
    if len(marks) > MAX_MARKS:
        marks = [*marks[: MAX_MARKS - 1], f"x {len(marks) - MAX_MARKS + 1} more unreachable"]
    lines.extend((mark, WARN_RGB) for mark in marks)
    return lines


def draw_status(frame: np.ndarray, status: OverlayStatus) -> np.ndarray:
    """Return a copy of `frame` (h, w, 3) with the status box in its top-left corner."""
    image = Image.fromarray(frame)
    height = frame.shape[0]
    size = max(9, height // 30)
    text_font = font(size)
    margin, spacing = max(3, size // 2), max(1, size // 4)
    lines = _status_lines(status)
    widths = [text_font.getbbox(text)[2] for text, _ in lines]
    bar_height = max(3, size // 2)
    box_width = max(widths) + 2 * margin
    box_height = 2 * margin + len(lines) * (size + spacing) + 2 * bar_height
    layer = Image.new("RGBA", image.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    draw.rectangle((0, 0, box_width, box_height), fill=BOX_RGBA)
    y = margin
    for index, (text, rgb) in enumerate(lines):
        draw.text((margin, y), text, font=text_font, fill=rgb)
        y += size + spacing
        if index == COVERAGE_LINE:
            y = _draw_bar(draw, margin, y, box_width - 2 * margin, bar_height, status.coverage)
    image = Image.alpha_composite(image.convert("RGBA"), layer).convert("RGB")
    return np.asarray(image)


def _draw_bar(draw: ImageDraw.ImageDraw, x: int, y: int, width: int, height: int,
              coverage: float) -> int:
    """A coverage bar with a tick at the goal; returns the y below it."""
    draw.rectangle((x, y, x + width, y + height), outline=DIM_RGB)
    filled = round(np.clip(coverage, 0.0, 1.0) * width)
    if filled > 0:
        draw.rectangle((x, y, x + filled, y + height), fill=BAR_RGB)
    goal = x + round(GOAL_COVERAGE * width)
    draw.line((goal, y - 2, goal, y + height + 2), fill=TEXT_RGB)
    return y + 2 * height


def draw_swatch(draw: ImageDraw.ImageDraw, x: int, y: int, text: str,
                rgb: tuple[int, int, int], size_px: int) -> int:
    """A legend entry at (x, y): a square of colour `rgb`, then `text`; returns the x after it."""
    draw.rectangle((x, y + 1, x + size_px - 2, y + size_px - 1), fill=rgb, outline=DIM_RGB)
    x += size_px + max(2, size_px // 3)
    draw.text((x, y), text, font=font(size_px), fill=TEXT_RGB, stroke_width=1,
              stroke_fill=(0, 0, 0))
    return x + int(font(size_px).getlength(text)) + size_px


def inset(frame: np.ndarray, panel: np.ndarray, label: str, left: bool = False) -> np.ndarray:
    """Return a copy of `frame` with `panel` in its bottom-right (or bottom-left) corner, framed
    and labelled.

    At the bottom, because the overview camera has the floor there and the arm above.
    """
    out = frame.copy()
    panel_height, panel_width = panel.shape[:2]
    border = 2
    x0 = border if left else frame.shape[1] - panel_width - border
    y0 = frame.shape[0] - panel_height - border
    out[y0 - border:, x0 - border: x0 + panel_width + border] = 200
    out[y0: y0 + panel_height, x0: x0 + panel_width] = panel
    image = Image.fromarray(out)
    size = max(8, frame.shape[0] // 36)
    draw = ImageDraw.Draw(image)
    draw.text((x0 + border + 1, y0 + 1), label, font=font(size), fill=TEXT_RGB,
              stroke_width=1, stroke_fill=(0, 0, 0))
    return np.asarray(image)
