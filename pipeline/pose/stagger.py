"""Less model work per frame when the CPU is short: detect only some views each frame, staggered.

On a short CPU (two cores that also decode four videos and run the fusion) the pose model
cannot look at every view in every frame at 30 fps, and the frames it cannot take are
dropped. Instead, each frame runs the model on at most ``k`` of the ``n`` views; every other
view *carries* its tracked people: the tracker's motion model moves each person's box to
where it expects them, and their keypoints go along (shifted and scaled with the box), with
their scores lowered for every frame without a detection
(:func:`pipeline.tracking.carry.carried_detections`). Triangulation then sees every view each
frame, the freshly detected ones with their full scores. The ids stay: a carried person is
matched to their own track.

Which views: those that need a look first (a new view, a view where a tracked person was not
found, a view with a person not yet confirmed by the tracker), then those detected longest
ago; ``k`` views in all, more only when more need a look.

How many: ``pose.views_per_frame`` (0 = adaptive). Adaptive, :class:`ViewBudget` starts with
every view and watches the capture times of the frames it gets: while the detector keeps
up, consecutive frames are one source frame apart; when frames are being skipped (the CPU is
short) it takes one view less, down to ``pose.min_views_per_frame``; after a long enough run
without skips it tries one view more (and waits longer before the next try when that brought
the skips back). On a machine that keeps up, or offline where no frame is ever skipped, every
view is detected in every frame, as before.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Collection, Sequence

from pipeline.pose.config import PoseConfig

SKIP_FACTOR = 1.5  # a frame more than this many source frame intervals after the last one: skipped
DOWN_WINDOW = 15  # frames looked at before taking one view less
DOWN_RATE = 0.2  # ... when more than this fraction of them came after skipped frames
UP_WINDOW = 90  # frames without a skip before trying one view more
MAX_BACKOFF = 8  # a try that brought the skips back makes the next wait up to this many times longer
INTERVALS = 900  # capture-time gaps kept for the source's frame interval (the smallest; 30 s at 30 fps)


class ViewBudget:
    """How many views the model looks at this frame (see the module docstring)."""

    def __init__(self, config: PoseConfig) -> None:
        self.config = config
        self._k: int | None = None
        self._n = 0
        self._last_ts: float | None = None
        self._gaps: deque[float] = deque(maxlen=INTERVALS)
        self._skips: deque[bool] = deque(maxlen=UP_WINDOW)
        self._since_change = 0
        self._backoff = 1
        self._raised_at: int | None = None  # frames since the last raise, while it is on trial
        self.changes: list[tuple[float, int]] = []  # (capture time, views) at each change

    def views(self, n: int) -> int:
        """Views to detect in a frame of ``n`` views."""
        fixed = self.config.views_per_frame
        if fixed:
            return min(fixed, n)
        self._n = max(self._n, n)  # a frame may lack a late camera: the count of the others stays
        if self._k is None:
            self._k = n
        return max(1, min(self._k, n))

    @property
    def interval_s(self) -> float | None:
        """The source's frame interval as seen (the smallest recent gap), None before two frames."""
        return min(self._gaps) if self._gaps else None

    def update(self, timestamp_s: float) -> None:
        """After a frame: its capture time (frames are given in order)."""
        last, self._last_ts = self._last_ts, timestamp_s
        if last is None or timestamp_s <= last or self.config.views_per_frame:
            return
        gap = timestamp_s - last
        self._gaps.append(gap)
        interval = min(self._gaps)
        self._skips.append(gap > SKIP_FACTOR * interval)
        self._since_change += 1
        if self._raised_at is not None:
            self._raised_at += 1
        k, lowest = self._k or self._n, min(self.config.min_views_per_frame, self._n)
        recent = list(self._skips)[-DOWN_WINDOW:]
        if (k > lowest and self._since_change >= DOWN_WINDOW
                and sum(recent) > DOWN_RATE * len(recent)):
            if self._raised_at is not None and self._raised_at <= 2 * DOWN_WINDOW:
                self._backoff = min(2 * self._backoff, MAX_BACKOFF)  # the try did not hold
            self._set(k - 1, timestamp_s)
            self._raised_at = None
        elif (k < self._n and self._since_change >= UP_WINDOW * self._backoff
              and not any(list(self._skips)[-UP_WINDOW:])):
            self._set(k + 1, timestamp_s)
            self._raised_at = 0
        elif self._raised_at is not None and self._raised_at > 2 * DOWN_WINDOW:
            self._raised_at, self._backoff = None, 1  # the last try held

    def _set(self, k: int, timestamp_s: float) -> None:
        self._k = k
        self._since_change = 0
        self._skips.clear()
        self.changes.append((timestamp_s, k))


def choose_views(k: int, since: Sequence[int], attention: Collection[int]) -> list[int]:
    """Indices of the views to detect: every one in ``attention``, then the most overdue by
    ``since`` (frames since each was last detected; ties to the lower index) up to ``k`` in all,
    and any view carried for its whole turn (``n / k`` frames) however many that makes: a view
    never waits longer than the stagger says."""
    n = len(since)
    turn = -(-n // max(k, 1))  # ceil(n / k)
    order = sorted(range(n), key=lambda i: (i not in attention, -since[i], i))
    picked = [i for i in order if i in attention]
    for i in order:
        if i not in picked and (len(picked) < k or since[i] + 1 >= turn):
            picked.append(i)
    return sorted(picked)
