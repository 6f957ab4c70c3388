"""The README's sensing picture (scripts/make_sensing_picture.py): its causes partition the loss."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from vprobot.cell.sensor import LOSS_CAUSES

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "make_sensing_picture.py"


def test_the_pictures_view_loses_points_to_every_cause_and_keeps_the_models_frame() -> None:
    """The picture draws the package's classification (`DepthSensor.losses_at`) of one view of
    the motor: every ideal point is measured or lost to one cause, each cause loses some there,
    and the measured ones are the structured-light frame's."""
    spec = importlib.util.spec_from_file_location("make_sensing_picture", SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    losses, measured, _, _ = script.acquire_frames((153, 128))
    np.testing.assert_array_equal(losses.ideal.pixels[losses.cause == -1], measured.pixels)
    counts = losses.counts()
    assert sum(counts.values()) == len(losses.ideal)
    assert all(counts[cause] > 0 for cause in LOSS_CAUSES)
