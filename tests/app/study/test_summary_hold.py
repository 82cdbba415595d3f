"""How long the operator held navigation in a session, from its event log (app.study.summary)."""

from __future__ import annotations

from typing import Any

from app.db.models import Event
from app.study.summary import held_s


def ev(ts: float, kind: str, **payload: Any) -> Event:
    return Event(session_id=1, ts=ts, kind=kind, payload=payload)


def test_held_time_counts_from_each_hold_to_its_release_and_to_the_end() -> None:
    events = [
        ev(90.0, "hold", held=True),  # before the session: its start says whether it was held
        ev(100.0, "session", state="running", held=False),
        ev(110.0, "hold", held=True),
        ev(115.0, "action", label="forward"),
        ev(112.0 + 8.0, "hold", held=True),  # said again (a rebuilt pipeline): the same hold
        ev(130.0, "hold", held=False),
        ev(150.0, "hold", held=True),
        ev(170.0, "hold", held=False),  # after the window's end
    ]
    assert held_s(events, 100.0, 160.0) == (30.0, 2)


def test_a_session_that_starts_held_counts_from_its_start() -> None:
    events = [ev(100.0, "session", state="running", held=True), ev(104.5, "hold", held=False)]
    assert held_s(events, 100.0, 200.0) == (4.5, 1)
    assert held_s([ev(100.0, "session", state="running")], 100.0, 200.0) == (0.0, 0), \
        "a log written before the hold existed: never held"
