"""The navigation stage's output as plain JSON values (the status snapshot, the dashboard, the log)."""

from __future__ import annotations

from typing import Any

from pipeline.navigation.config import NavigationConfig
from pipeline.navigation.navigators import NavigationFrame
from pipeline.results import action_record


def navigation_record(frame: NavigationFrame | None, config: NavigationConfig) -> dict[str, Any]:
    """``{"mode", "chosen", "commands": [{"user_id", "label", "confidence", "action"}], "group"}``;
    ``group`` is ``{"label", "confidence", "members", "votes", "action"}`` or None. Without a frame
    (stopped, or no 3D) the configured mode and no commands."""
    if frame is None:
        return {"mode": config.mode, "chosen": list(config.user_ids), "commands": [], "group": None}
    group = None
    if frame.group is not None:
        g = frame.group
        group = {"label": g.action.label, "confidence": round(g.confidence, 4), "members": list(g.members),
                 "votes": dict(g.votes), "action": action_record(g.action)}
    return {
        "mode": frame.mode,
        "chosen": list(frame.chosen),
        "commands": [{"user_id": c.user_id, "label": c.action.label,
                      "confidence": round(c.action.confidence, 4), "action": action_record(c.action)}
                     for c in frame.commands],
        "group": group,
    }
