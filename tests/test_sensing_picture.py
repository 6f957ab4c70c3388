"""The README's sensing picture (scripts/make_sensing_picture.py): its causes partition the loss."""

from __future__ import annotations

import importlib.util
import itertools
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "make_sensing_picture.py"


def test_each_reduction_of_the_model_keeps_a_subset_of_the_one_befores_pixels() -> None:
    """The picture names one cause per lost pixel (shadow, incidence, dropout) by the step at
    which it is lost; that holds only if every step keeps a subset of the step before."""
    spec = importlib.util.spec_from_file_location("make_sensing_picture", SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    frames, _, _ = script.acquire_frames((153, 128))
    assert list(frames) == ["ideal", "shadow", "limits", "structured_light"]
    pixels = [frame.pixels for frame in frames.values()]
    for before, after in itertools.pairwise(pixels):
        assert np.isin(after, before).all()
        assert len(after) < len(before)  # each step loses some at this view
