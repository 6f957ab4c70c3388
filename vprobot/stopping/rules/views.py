"""`views:N`: stop after N acquisitions (the initial view included), a fixed budget as GenNBV's
and Hestia's."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vprobot.stopping.rules.base import StopRule, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode


@register_stop
class ViewsStop(StopRule):
    """Stops once N views were acquired; unreached requests do not count."""

    name = "views"
    pattern = r"(?::(?P<count>.*))?"
    usage = "views:N (N >= 1)"
    description = "after N acquisitions"

    def __init__(self, count: int):
        if count < 1:
            raise ValueError(f"views:N needs N >= 1, got {count}")
        self.count = count

    @classmethod
    def options(cls, **groups: str) -> dict[str, Any]:
        text = groups.get("count")
        if text is None or not text.isdecimal() or int(text) < 1:
            raise ValueError("N must be an integer >= 1")
        return {"count": int(text)}

    def check(self, episode: Episode) -> str | None:
        acquired = sum(view.acquired for view in episode.views)
        return f"views:{self.count}" if acquired >= self.count else None
