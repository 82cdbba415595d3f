"""The people recently lost, and whether a new track is one of them."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.identity.body import measure_distance
from pipeline.identity.config import IdentityConfig

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class LostUser:
    """A person no longer tracked: their user id, body signature (metres, per MEASURES), when and
    where (floor x, y, metres) they were last seen, and the bone-length prior their track had."""

    user_id: int
    signature: F64
    last_seen_s: float
    position_m: F64
    bone_prior_m: F64 | None = None


class Gallery:
    """Lost people, remembered ``memory_s``; :meth:`match` finds the one a new track is."""

    def __init__(self, config: IdentityConfig) -> None:
        self.config = config
        self.lost: dict[int, LostUser] = {}

    def add(self, user: LostUser) -> None:
        self.lost[user.user_id] = user

    def expire(self, timestamp_s: float) -> None:
        for uid in [u for u, lu in self.lost.items() if timestamp_s - lu.last_seen_s > self.config.memory_s]:
            del self.lost[uid]

    def match(
        self, signature: F64, first_seen_s: float, position_m: F64, candidates: list[LostUser] | None = None
    ) -> tuple[LostUser | None, str]:
        """The lost person (among ``candidates``, default the gallery) that a track first seen at
        ``first_seen_s`` at ``position_m`` with body ``signature`` is, or None; and why."""
        cfg = self.config
        pool = list(self.lost.values()) if candidates is None else candidates
        scored = []
        for lu in pool:
            if lu.last_seen_s >= first_seen_s:
                continue  # seen after the new track appeared: someone else
            reach = cfg.max_speed_mps * (first_seen_s - lu.last_seen_s) + 1.0
            if float(np.linalg.norm((position_m - lu.position_m)[:2])) > reach:
                continue
            scored.append((measure_distance(signature, lu.signature), lu))
        scored.sort(key=lambda s: s[0])
        if not scored or not math.isfinite(scored[0][0]):
            return None, "nobody lost could be them"
        d1, best = scored[0]
        if d1 > cfg.max_distance_m:
            return None, f"nearest body differs by {100 * d1:.1f} cm"
        if len(scored) > 1 and scored[1][0] < cfg.ambiguity_ratio * d1:
            return None, f"ambiguous: users {best.user_id} and {scored[1][1].user_id} both fit"
        return best, f"body within {100 * d1:.1f} cm"
