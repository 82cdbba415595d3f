"""The primary navigator: which tracked user drives the locomotion.

``manual``: the operator picks a user id (``set_manual``); that user is the navigator whenever
tracked, and stays chosen through an occlusion of up to ``hold_s``. A manual navigator lost for
longer is re-acquired when a new user id appears where they vanished (the tracker lost them and
gave them a new id: same person), or after ``manual_grace_s`` more the choice falls back to ``auto``
(a session must not run on with nobody steering).
``auto``: the person nearest the CAVE centre who has been tracked for ``dwell_s``; the choice is
sticky (it survives an occlusion of up to ``hold_s``) and passes to someone else only when they
have been nearer the centre by ``switch_margin_m`` for ``dwell_s``, or the navigator is lost.
Every change is logged and returned as a :class:`NavigatorChange` for the session log.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pipeline.errors import InputError
from pipeline.triangulation.config import NavigatorConfig
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class NavigatorChange:
    """The navigator (or the selection mode) changed.

    timestamp_s: time of the frame (or of the last frame, for an operator's change).
    previous, current: user ids, None = no navigator.
    mode: ``auto`` or ``manual`` after the change.
    reason: a short human-readable cause.
    """

    timestamp_s: float
    previous: int | None
    current: int | None
    mode: str
    reason: str

    def __post_init__(self) -> None:
        if self.mode not in ("auto", "manual"):
            raise ValueError(f"mode must be 'auto' or 'manual', got {self.mode!r}")


@dataclass(slots=True)
class _Seen:
    first_s: float
    last_s: float
    radius_m: float
    xy_m: tuple[float, float]


@dataclass(slots=True)
class _LastSeen:
    """Where and when the manual navigator was last seen (for re-acquisition and the grace period)."""

    user_id: int
    t_s: float
    xy_m: tuple[float, float]


class NavigatorSelector:
    """Chooses the primary navigator among the tracked users, frame by frame."""

    def __init__(self, config: NavigatorConfig | None = None) -> None:
        self.config = config or NavigatorConfig()
        self._mode: str = self.config.mode
        self._manual_id: int | None = None
        self._current: int | None = None
        self._seen: dict[int, _Seen] = {}
        self._challenger_since: dict[int, float] = {}
        self._manual_last: _LastSeen | None = None
        self._t = 0.0

    @property
    def mode(self) -> str:
        return self._mode

    @property
    def current(self) -> int | None:
        """The navigator's user id, or None."""
        return self._current

    @property
    def tracked(self) -> tuple[int, ...]:
        """User ids seen within ``hold_s`` of the last frame, sorted."""
        return tuple(sorted(self._seen))

    def _change(self, previous: int | None, previous_mode: str, reason: str) -> NavigatorChange | None:
        if previous == self._current and previous_mode == self._mode:
            return None
        ev = NavigatorChange(self._t, previous, self._current, self._mode, reason)
        log.info("navigator %s -> %s (%s, %s)", previous, self._current, self._mode, reason)
        return ev

    def set_manual(self, user_id: int) -> NavigatorChange | None:
        """Make ``user_id`` the navigator until ``set_auto`` or another ``set_manual``.

        Raises InputError (and changes nothing) when that user is not currently tracked.
        """
        if isinstance(user_id, bool) or not isinstance(user_id, int | np.integer):
            raise InputError(f"user_id must be an integer, got {user_id!r}")
        uid = int(user_id)
        if uid not in self._seen:
            known = ", ".join(str(u) for u in self.tracked) or "none"
            raise InputError(f"user {uid} is not tracked (tracked users: {known})")
        previous, previous_mode = self._current, self._mode
        self._mode, self._manual_id, self._current = "manual", uid, uid
        seen = self._seen[uid]
        self._manual_last = _LastSeen(uid, seen.last_s, seen.xy_m)
        self._challenger_since.clear()
        return self._change(previous, previous_mode, "chosen by the operator")

    def resume_manual(self, user_id: int, xy_m: tuple[float, float]) -> None:
        """The operator's choice of ``user_id`` made before this selector existed (a fusion worker
        started again), last seen at ``xy_m``: a person first tracked there from the next frame on
        is re-acquired as the navigator; nobody there for ``hold_s + manual_grace_s``: automatic."""
        self._mode, self._manual_id, self._current = "manual", None, None
        self._manual_last = _LastSeen(int(user_id), math.nan, (float(xy_m[0]), float(xy_m[1])))
        self._challenger_since.clear()

    def set_auto(self) -> NavigatorChange | None:
        """Return to automatic choice (the current navigator stays while tracked)."""
        previous, previous_mode = self._current, self._mode
        self._mode, self._manual_id, self._manual_last = "auto", None, None
        self._challenger_since.clear()
        if self._current is not None and self._current not in self._seen:
            self._current = None
        return self._change(previous, previous_mode, "automatic choice")

    def update(self, people: Sequence[Person3D], timestamp_s: float) -> NavigatorChange | None:
        """Feed one frame's people; returns the change of navigator, if any."""
        t = float(timestamp_s)
        if not math.isfinite(t):
            raise InputError(f"timestamp_s must be finite, got {timestamp_s!r}")
        self._t = t
        cfg = self.config
        cx, cy = cfg.center_m
        present: set[int] = set()
        for p in people:
            pos = p.position_m
            if not np.all(np.isfinite(pos)):
                continue
            r = float(math.hypot(pos[0] - cx, pos[1] - cy))
            xy = (float(pos[0]), float(pos[1]))
            s = self._seen.get(p.user_id)
            if s is None or t - s.last_s > cfg.hold_s:
                self._seen[p.user_id] = _Seen(t, t, r, xy)
            else:
                s.last_s, s.radius_m, s.xy_m = t, r, xy
            present.add(p.user_id)
        for uid in [u for u, s in self._seen.items() if t - s.last_s > cfg.hold_s]:
            del self._seen[uid]
            self._challenger_since.pop(uid, None)

        previous, previous_mode = self._current, self._mode
        auto_reason: str | None = None
        if self._mode == "manual":
            change, fell_back = self._update_manual(present, t, previous, previous_mode)
            if not fell_back:
                return change
            auto_reason = fell_back

        eligible = {
            u: self._seen[u].radius_m
            for u in present
            if t - self._seen[u].first_s >= cfg.dwell_s and self._seen[u].radius_m <= cfg.max_radius_m
        }
        if self._current is not None and self._current in self._seen:
            r_cur = self._seen[self._current].radius_m
            for u in list(self._challenger_since):
                if u not in eligible or eligible[u] + cfg.switch_margin_m >= r_cur:
                    del self._challenger_since[u]
            for u, r in eligible.items():
                if u != self._current and r + cfg.switch_margin_m < r_cur:
                    self._challenger_since.setdefault(u, t)
            ready = [u for u, since in self._challenger_since.items() if t - since >= cfg.dwell_s]
            if ready:
                self._current = min(ready, key=lambda u: eligible[u])
                self._challenger_since.clear()
                return self._change(previous, previous_mode, "another user is nearer the centre")
            return None
        self._challenger_since.clear()
        self._current = min(eligible, key=lambda u: (eligible[u], u)) if eligible else None
        reason = "nearest the centre" if self._current is not None else "navigator lost"
        if auto_reason is not None:
            reason = f"{auto_reason}; {reason}" if self._current is not None else auto_reason
        return self._change(previous, previous_mode, reason)

    def _update_manual(
        self, present: set[int], t: float, previous: int | None, previous_mode: str
    ) -> tuple[NavigatorChange | None, str | None]:
        """The manual branch of :meth:`update`: (the change, None) or (None, why it fell back to auto)."""
        cfg = self.config
        mid = self._manual_id
        if self._manual_last is not None and math.isnan(self._manual_last.t_s):  # resumed: wait from now
            self._manual_last = _LastSeen(self._manual_last.user_id, t, self._manual_last.xy_m)
        if mid is not None and mid in present:
            seen = self._seen[mid]
            self._manual_last = _LastSeen(mid, t, seen.xy_m)
            self._current = mid
            return self._change(previous, previous_mode, "operator's choice tracked"), None
        last = self._manual_last
        if last is None:  # manual from the config, nobody chosen yet: wait for the operator
            self._current = None
            return self._change(previous, previous_mode, "waiting for the operator's choice"), None
        newcomer = self._newcomer_near(last, present, t)
        if newcomer is not None:
            self._manual_id = self._current = newcomer
            self._manual_last = _LastSeen(newcomer, t, self._seen[newcomer].xy_m)
            reason = (
                f"operator's choice re-acquired: user {newcomer} appeared where user {last.user_id} "
                f"was last seen"
            )
            return self._change(previous, previous_mode, reason), None
        if mid is not None and mid in self._seen:  # an occlusion shorter than hold_s
            self._current = mid
            return None, None
        self._current = None
        missing_s = t - last.t_s
        if missing_s <= cfg.hold_s + cfg.manual_grace_s:
            return self._change(previous, previous_mode, "operator's choice lost"), None
        self._mode, self._manual_id, self._manual_last = "auto", None, None
        return None, f"operator's choice lost for {missing_s:.1f} s: automatic choice"

    def _newcomer_near(self, last: _LastSeen, present: set[int], t: float) -> int | None:
        """A user first seen after the manual navigator vanished, near where they were last seen."""
        cfg = self.config
        if cfg.reacquire_radius_m <= 0 or t - last.t_s > cfg.hold_s + cfg.manual_grace_s:
            return None
        best: tuple[float, int] | None = None
        for u in present:
            s = self._seen[u]
            if u == last.user_id or s.first_s < last.t_s - 1e-9:
                continue
            d = math.hypot(s.xy_m[0] - last.xy_m[0], s.xy_m[1] - last.xy_m[1])
            if d <= cfg.reacquire_radius_m and (best is None or d < best[0]):
                best = (d, u)
        return None if best is None else best[1]
