"""Grouping the cameras' newest frames into multi-view frames by capture time.

The grouper is pure bookkeeping (no threads, no clocks of its own): feed it each
camera's newest frame with :meth:`MultiViewGrouper.offer` and ask :meth:`poll` with
the current time. A group holds, for each camera, the newest frame not used yet,
provided its capture time lies within ``tolerance_s`` of the group's newest frame.
A camera that is late is waited for at most ``max_wait_s``; a camera that has
delivered nothing for ``gone_after_s`` is not waited for at all (the others go on).
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class GrouperConfig:
    """tolerance_s: frames this close in time form one multi-view frame. max_wait_s: how long to
    wait for a late camera. gone_after_s: a camera silent this long is not waited for (and is
    reported). The settings' ``[runtime.grouper]``."""

    tolerance_s: float = 0.02
    max_wait_s: float = 0.015
    gone_after_s: float = 1.0

    def __post_init__(self) -> None:
        for name in ("tolerance_s", "max_wait_s", "gone_after_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True, slots=True)
class FrameRef:
    """One camera's frame as the grouper sees it (the pixels stay where they are)."""

    camera: str
    seq: int
    timestamp_s: float


@dataclass(frozen=True, slots=True)
class MultiViewGroup:
    """Frames of several cameras taken at (nearly) the same time.

    members: the frames used, in the grouper's camera order.
    missing: cameras without a frame in this group (late beyond the wait, or gone).
    skipped: per camera, how many of its frames were never used (newer ones came first).
    """

    members: tuple[FrameRef, ...]
    missing: tuple[str, ...]
    skipped: dict[str, int] = field(default_factory=dict)

    @property
    def timestamp_s(self) -> float:
        """Capture time of the group: the oldest member (latency is counted from it)."""
        return min(m.timestamp_s for m in self.members)


class MultiViewGrouper:
    """Newest-frame grouping with a tolerance; see the module docstring."""

    def __init__(self, cameras: list[str], config: GrouperConfig | None = None) -> None:
        if not cameras:
            raise ValueError("MultiViewGrouper needs at least one camera, got none")
        if len(set(cameras)) != len(cameras):
            raise ValueError(f"camera names must be unique, got {cameras}")
        self.cameras = list(cameras)
        self.config = config or GrouperConfig()
        self._latest: dict[str, FrameRef] = {}
        self._used: dict[str, int] = {}
        self._last_seen: dict[str, float] = {}

    def offer(self, frame: FrameRef, now: float) -> None:
        """Tell the grouper about a camera's newest frame (older or repeated offers are ignored)."""
        if frame.camera not in self.cameras:
            raise ValueError(f"unknown camera {frame.camera!r}, expected one of {self.cameras}")
        prev = self._latest.get(frame.camera)
        if prev is None or frame.seq > prev.seq:
            self._latest[frame.camera] = frame
            self._last_seen[frame.camera] = now

    def alive(self, now: float) -> list[str]:
        """Cameras that delivered a frame within ``gone_after_s``."""
        return [c for c in self.cameras
                if c in self._last_seen and now - self._last_seen[c] <= self.config.gone_after_s]

    def poll(self, now: float) -> MultiViewGroup | None:
        """The next group, or None while nothing new has come or a live camera is still due."""
        fresh = [f for c in self.cameras if (f := self._latest.get(c)) is not None
                 and f.seq > self._used.get(c, -1)]
        if not fresh:
            return None
        newest = max(f.timestamp_s for f in fresh)
        members = [f for f in fresh if f.timestamp_s >= newest - self.config.tolerance_s]
        have = {f.camera for f in members}
        waiting = [c for c in self.alive(now) if c not in have]
        if waiting and now - newest < self.config.max_wait_s:
            return None
        skipped: dict[str, int] = {}
        for f in members:
            skipped[f.camera] = max(0, f.seq - self._used.get(f.camera, -1) - 1)
            self._used[f.camera] = f.seq
        missing = tuple(c for c in self.cameras if c not in have)
        return MultiViewGroup(tuple(members), missing, skipped)
