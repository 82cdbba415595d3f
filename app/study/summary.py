"""A session's summary from its event log: how long it ran, how long it ran without a navigator,
how long navigation was held, the gaps in the locomotion stream (the dashboard's alarm),
the actions, and what was corrected.
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from app.db.models import Event, Participant, StudySession
from app.db.study_repository import get_session


def _time_when(events: list[Event], start_ts: float, end_ts: float, initial: Any,
               update: Callable[[Event, Any], Any], counts: Callable[[Any], bool]) -> tuple[float, int]:
    """Seconds of [start_ts, end_ts] in which ``counts(state)`` holds, and how often it began: the
    state starts as ``initial`` and each event of the window makes it ``update(event, state)``."""
    state, t, total, began = initial, start_ts, 0.0, 0
    for e in events:
        if e.ts < start_ts:
            continue
        if e.ts > end_ts:
            break
        was = counts(state)
        if was:
            total += e.ts - t
        t, state = e.ts, update(e, state)
        began += counts(state) and not was
    if counts(state):
        total += end_ts - t
    return max(0.0, total), began


def _navigator(e: Event, nav: Any) -> Any:
    p = e.payload or {}
    if e.kind == "session" and p.get("state") == "running":
        return p.get("navigator")
    if e.kind == "navigator":
        return p.get("current")
    if e.kind == "pipeline" and p.get("state") in ("stopped", "error", "stalled"):
        return None
    return nav


def _held(e: Event, held: bool) -> bool:
    p = e.payload or {}
    if e.kind == "session" and p.get("state") == "running":
        return bool(p.get("held", False))
    if e.kind == "hold":
        return bool(p.get("held"))
    return held


def without_navigator_s(events: list[Event], start_ts: float, end_ts: float) -> float:
    """Seconds of [start_ts, end_ts] with no navigator, from the session's ``session``, ``navigator``
    and ``pipeline`` events (a stopped or failed pipeline has no navigator)."""
    return _time_when(events, start_ts, end_ts, None, _navigator, lambda nav: nav is None)[0]


def held_s(events: list[Event], start_ts: float, end_ts: float) -> tuple[float, int]:
    """Seconds of [start_ts, end_ts] navigation was held (the operator's hold, or a controller
    session's own), and how often a hold began, from the session's ``session`` (held at its start)
    and ``hold`` events."""
    return _time_when(events, start_ts, end_ts, False, _held, bool)


def session_summary(db: Session, session_id: int) -> dict[str, Any]:
    session = get_session(db, session_id)
    events = list(
        db.scalars(select(Event).where(Event.session_id == session_id).order_by(Event.ts, Event.id))
    )
    out: dict[str, Any] = {
        "session_id": session_id,
        "status": session.status,
        "duration_s": None,
        "without_navigator_s": None,
        "without_navigator_fraction": None,
        "held_s": None,
        "holds": 0,
        "locomotion_alarms": 0,
        "locomotion_gap_s": 0.0,
        "navigator_changes": 0,
        "actions_s": {},
        "questionnaires": 0,
        "corrections": 0,
        "overrides": 0,
        "stopped_by": session.stopped_by,
    }
    starts = [e.ts for e in events if e.kind == "session" and (e.payload or {}).get("state") == "running"]
    stops = [e.ts for e in events if e.kind == "session" and (e.payload or {}).get("state") == "stopped"]
    if not starts:
        return out
    start = starts[0]
    end = stops[-1] if stops and session.status == "stopped" else time.time()
    duration = max(0.0, end - start)
    out["duration_s"] = round(duration, 1)
    without = without_navigator_s(events, start, end)
    out["without_navigator_s"] = round(without, 1)
    out["without_navigator_fraction"] = round(without / duration, 4) if duration > 0 else None
    held, out["holds"] = held_s(events, start, end)
    out["held_s"] = round(held, 1)
    actions: dict[str, float] = defaultdict(float)
    label: str | None = None
    t = start
    open_gap: float | None = None
    for e in events:
        p = e.payload or {}
        if e.kind == "action" and start <= e.ts <= end:
            if label is not None:
                actions[label] += e.ts - t
            label, t = p.get("label"), e.ts
        elif e.kind == "navigator":
            out["navigator_changes"] += 1
        elif e.kind == "alarm" and p.get("alarm") == "no_locomotion":
            if p.get("state") == "raised":
                out["locomotion_alarms"] += 1
                open_gap = float(p.get("since_ts", e.ts))
            elif p.get("state") == "cleared" and open_gap is not None:
                out["locomotion_gap_s"] += e.ts - open_gap
                open_gap = None
        elif e.kind == "questionnaire":
            out["questionnaires"] += 1
            out["corrections"] += "corrects" in p
        elif e.kind == "override":
            out["overrides"] += 1
    if label is not None:
        actions[label] += end - t
    if open_gap is not None:
        out["locomotion_gap_s"] += end - open_gap
    out["locomotion_gap_s"] = round(out["locomotion_gap_s"], 1)
    out["actions_s"] = {k: round(v, 1) for k, v in actions.items()}
    return out


#: the columns of sessions.csv: one row per session, its summary flattened (``action_<label>_s``)
SESSION_COLUMNS: tuple[str, ...] = (
    "session_id",
    "participant_code",
    "condition",
    "planned_index",
    "status",
    "started_at",
    "duration_s",
    "without_navigator_s",
    "without_navigator_fraction",
    "held_s",
    "holds",
    "locomotion_alarms",
    "locomotion_gap_s",
    "navigator_changes",
    "questionnaires",
    "corrections",
    "overrides",
    "stopped_by",
    "action_still_s",
    "action_forward_s",
    "action_left_s",
    "action_right_s",
)


def session_rows(db: Session) -> list[dict[str, Any]]:
    """Every session's summary as one flat row (sessions.csv), in session order."""
    rows: list[dict[str, Any]] = []
    query = (
        select(StudySession, Participant.code)
        .join(Participant, Participant.id == StudySession.participant_id)
        .order_by(StudySession.id)
    )
    for session, code in db.execute(query).all():
        summary = session_summary(db, session.id)
        row = {k: v for k, v in summary.items() if k != "actions_s"}
        row.update(
            participant_code=code,
            condition=session.condition,
            planned_index=session.planned_index,
            started_at=session.started_at.isoformat() if session.started_at else None,
        )
        for label, seconds in summary["actions_s"].items():
            row[f"action_{label}_s"] = seconds
        rows.append(row)
    return rows
