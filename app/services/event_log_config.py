"""The event log's frozen config: the settings' ``[event_log]`` section.

Apart from the writer (:mod:`app.services.event_log`), which imports SQLAlchemy, so that the
settings, and every ``cavewalk`` command with them, start without it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class EventWriterConfig:
    """The settings' ``[event_log]``: a batch is written every ``flush_interval_s`` (at most 1 s:
    the most a crash can lose) or when ``max_batch`` events have gathered."""

    flush_interval_s: float = 0.5
    max_batch: int = 2000

    def __post_init__(self) -> None:
        if not 0 < self.flush_interval_s <= 1.0:
            raise ValueError(f"flush_interval_s must be in (0, 1], got {self.flush_interval_s}")
        if self.max_batch < 1:
            raise ValueError(f"max_batch must be >= 1, got {self.max_batch}")
