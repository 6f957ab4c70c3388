"""Progress of the long stages of a plan (ground truth, candidate screening, visibility).

Library calls stay silent; a command that a person watches (`plan`, `render`) shows the display
while it runs (`showing_progress()`). A stage draws its bar only once it has run for `DELAY_S`,
so the bundled motor's second-long stages print nothing while a CAD part's minute-long ones do.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

DELAY_S = 2.0
"""A stage shows its bar after running this long."""

Item = TypeVar("Item")

_shown = False


@contextlib.contextmanager
def showing_progress() -> Iterator[None]:
    """Show the stage bars (and notes) of this process while the block runs."""
    global _shown
    before, _shown = _shown, True
    try:
        yield
    finally:
        _shown = before


def stage(description: str, total: int, unit: str = "it",
          items: Iterable[Item] | None = None) -> tqdm:
    """A progress bar named `description` (silent unless shown): iterate it over `items`, or
    advance it with `update(n)` when the work is not a plain loop."""
    return tqdm(items, desc=description, total=total, unit=unit, delay=DELAY_S,
                disable=not _shown, file=sys.stderr, dynamic_ncols=True)


def note(text: str) -> None:
    """One line on stderr about a stage without steps (e.g. simplifying a mesh), when shown."""
    if _shown:
        print(text, file=sys.stderr, flush=True)
