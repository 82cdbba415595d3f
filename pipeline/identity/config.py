"""The identity stage's frozen config: the settings' ``[identity]`` section (no heavy imports)."""

from __future__ import annotations

from dataclasses import dataclass


def _check(cond: bool, what: str, value: object) -> None:
    if not cond:
        raise ValueError(f"{what}, got {value!r}")


@dataclass(frozen=True, slots=True)
class IdentityConfig:
    """Re-identification of people from their body measurements.

    enabled: False = ids from the 3D track alone (a person unseen for ``tracks3d.max_missing_s``
        comes back with a new id).
    memory_s: a lost person is remembered this long.
    window_s: a new track is measured this long before it is compared with the lost people.
    decide_s: ... and compared until it is this old; then it keeps its new id.
    min_gap_s: a tracked person unseen this long counts as lost too (their track may have broken:
        the new one may be them).
    max_distance_m: RMS difference of the body measurements (metres) under which a new track may
        be a lost person.
    ambiguity_ratio: ... and the next-best lost person must be this many times farther.
    max_speed_mps: a lost person cannot have walked faster than this to where the new track
        appeared (plus 1 m: where they were last seen is uncertain).
    min_samples: frames of measurements a signature needs.
    body_weight: weight, in the 3D tracks' assignment, of a skeleton's body differing from a user's
        signature (per ``max_distance_m``, at most 3), against the floor distance (per gate) and
        the cameras' track ids (-2 when all agree); 0 = ids from position and 2D tracks alone.
    """

    enabled: bool = True
    memory_s: float = 300.0
    window_s: float = 0.7
    decide_s: float = 4.0
    min_gap_s: float = 0.3
    max_distance_m: float = 0.03
    ambiguity_ratio: float = 1.5
    max_speed_mps: float = 3.0
    min_samples: int = 8
    body_weight: float = 1.0

    def __post_init__(self) -> None:
        _check(self.memory_s >= 0.0, "memory_s must be >= 0", self.memory_s)
        _check(self.window_s > 0.0, "window_s must be > 0", self.window_s)
        _check(self.decide_s >= self.window_s, "decide_s must be >= window_s", self.decide_s)
        _check(self.min_gap_s >= 0.0, "min_gap_s must be >= 0", self.min_gap_s)
        _check(self.max_distance_m > 0.0, "max_distance_m must be > 0", self.max_distance_m)
        _check(self.ambiguity_ratio >= 1.0, "ambiguity_ratio must be >= 1", self.ambiguity_ratio)
        _check(self.max_speed_mps > 0.0, "max_speed_mps must be > 0", self.max_speed_mps)
        _check(self.min_samples >= 1, "min_samples must be >= 1", self.min_samples)
        _check(self.body_weight >= 0.0, "body_weight must be >= 0", self.body_weight)
