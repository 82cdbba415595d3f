"""The ``[navigation]`` section of the settings (no heavy imports here)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

NavigationMode = Literal["single", "each", "group"]
NAVIGATION_MODES: tuple[str, ...] = ("single", "each", "group")
MAX_NAVIGATORS = 8  # the most recogniser states the config allows at once


#: A person fused this recently (seconds) still counts as tracked when the operator chooses them
#: (navigator, navigation mode): the tracker may miss someone for a frame or two.
TRACKED_WITHIN_S = 1.0


@dataclass(frozen=True, slots=True)
class NavigationConfig:
    """How many navigators drive the CAVE, and how.

    mode: ``single``, ``each`` or ``group`` (see :mod:`pipeline.navigation`).
    user_ids: the chosen people in ``each`` and ``group`` mode; empty = everyone tracked.
    max_navigators: at most this many people get a recogniser state at once (those nearest the
        CAVE's centre first); the others are tracked but do not navigate.
    """

    mode: NavigationMode = "single"
    user_ids: tuple[int, ...] = ()
    max_navigators: int = 4

    def __post_init__(self) -> None:
        if self.mode not in NAVIGATION_MODES:
            raise ValueError(f"navigation mode must be one of {', '.join(NAVIGATION_MODES)}, "
                             f"got {self.mode!r}")
        ids = tuple(self.user_ids)
        if any(isinstance(u, bool) or not isinstance(u, int) or u < 0 for u in ids):
            raise ValueError(f"navigation user_ids must be integers >= 0, got {list(ids)}")
        if len(set(ids)) != len(ids):
            raise ValueError(f"navigation user_ids must be distinct, got {list(ids)}")
        if self.mode == "single" and ids:
            raise ValueError("navigation user_ids apply to the each and group modes, not single "
                             "(single mode picks its navigator through the navigator setting)")
        if not 1 <= self.max_navigators <= MAX_NAVIGATORS:
            raise ValueError(f"max_navigators must be 1..{MAX_NAVIGATORS}, got {self.max_navigators}")
        object.__setattr__(self, "user_ids", ids)
