"""Live counters of the runtime: latency percentiles over a sliding window, rates, drops.

Stages of the latency (all from ``time.monotonic()`` stamps carried with each frame):
``capture`` capture time -> the detector takes the frame (time spent waiting in the ring),
``detect`` the pose stage, ``fuse`` detection done -> fusion done (queue + tracking,
triangulation, recognition), ``emit`` fusion done -> datagram sent, and ``end_to_end``
capture time -> datagram sent.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass

import numpy as np

STAGES = ("capture", "detect", "fuse", "emit", "end_to_end")


def percentiles(values: np.ndarray | list[float], qs: tuple[int, ...] = (50, 95, 99)) -> dict[str, float]:
    """``{"p50": .., "p95": .., "p99": ..}`` of ``values`` (NaN when empty)."""
    arr = np.asarray(values, dtype=np.float64)
    if arr.size == 0:
        return {f"p{q}": float("nan") for q in qs}
    return {f"p{q}": float(v) for q, v in zip(qs, np.percentile(arr, qs), strict=True)}


class LatencyWindow:
    """The last ``size`` samples (milliseconds) and their percentiles; thread-safe."""

    def __init__(self, size: int = 600) -> None:
        if size < 1:
            raise ValueError(f"window size must be >= 1, got {size}")
        self._values: deque[float] = deque(maxlen=size)
        self._lock = threading.Lock()
        self.count = 0

    def add(self, value_ms: float) -> None:
        with self._lock:
            self._values.append(float(value_ms))
            self.count += 1

    def summary(self) -> dict[str, float]:
        with self._lock:
            values = list(self._values)
        return {k: round(v, 3) for k, v in percentiles(values).items()}

    def values(self) -> list[float]:
        with self._lock:
            return list(self._values)


class RateMeter:
    """Events per second over the last ``window_s`` seconds; thread-safe."""

    def __init__(self, window_s: float = 2.0) -> None:
        if window_s <= 0:
            raise ValueError(f"window_s must be > 0, got {window_s}")
        self.window_s = window_s
        self._times: deque[float] = deque()
        self._lock = threading.Lock()
        self.count = 0

    def tick(self, now: float) -> None:
        with self._lock:
            self._times.append(now)
            self.count += 1
            self._trim(now)

    def _trim(self, now: float) -> None:
        while self._times and self._times[0] < now - self.window_s:
            self._times.popleft()

    def rate(self, now: float) -> float:
        with self._lock:
            self._trim(now)
            n = len(self._times)
            if n < 2:
                return 0.0
            span = self._times[-1] - self._times[0]
            return float((n - 1) / span) if span > 0 else 0.0


class RuntimeMetrics:
    """All live counters of one pipeline run."""

    def __init__(self, window: int = 600) -> None:
        self.latency = {stage: LatencyWindow(window) for stage in STAGES}
        self.fps = RateMeter()
        self._lock = threading.Lock()
        self.processed = 0
        self.dropped = 0

    def frame(self, now: float, stage_ms: dict[str, float], dropped: int) -> None:
        for stage, value in stage_ms.items():
            if stage in self.latency:
                self.latency[stage].add(value)
        self.fps.tick(now)
        with self._lock:
            self.processed += 1
            self.dropped += int(dropped)

    def latency_summary(self) -> dict[str, dict[str, float]]:
        return {stage: w.summary() for stage, w in self.latency.items()}


@dataclass(frozen=True, slots=True)
class AdaptiveRate:
    """The paper's dynamic frame rate: the period a stage waits between frames.

    The stage never runs faster than ``target_fps``; when one frame costs more than that
    period, the period stretches to ``busy_s * headroom`` so the stage leaves some CPU
    to the others (capture, fusion) instead of starving them, and the frames in between
    are dropped (newest first).
    """

    target_fps: float
    headroom: float = 1.1

    def __post_init__(self) -> None:
        if self.target_fps <= 0 or self.headroom < 1.0:
            raise ValueError(f"target_fps must be > 0 and headroom >= 1, got {self}")

    def period_s(self, busy_s: float) -> float:
        return max(1.0 / self.target_fps, busy_s * self.headroom)


def ema(previous: float | None, value: float, alpha: float = 0.2) -> float:
    """Exponential moving average (the first value starts it)."""
    return value if previous is None else (1.0 - alpha) * previous + alpha * value
