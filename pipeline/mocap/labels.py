"""Semi-automatic LABELS for mocap clips: foot contacts with hysteresis, then the clip's rule.

Contacts (per foot): the ankle's height above its own standing level (the clip's low percentile
of that ankle's height, so a model whose ankle sits 5 cm or 9 cm above the sole reads the same)
and its speed (3D, central differences). A foot touches down when it is below ``on_height_m``
and slower than ``on_speed_mps``; it lifts off when it rises above ``off_height_m`` or moves
faster than ``off_speed_mps``. Between the thresholds it keeps its state (hysteresis).

Rules (``annotations.toml``, per clip): ``bout`` -- the clip's label from the first lift-off to
the last touch-down (TEAM.md LABELS; the pauses inside keep it), ``still`` before and after;
``still`` -- the whole clip one label, its ``label`` (``still`` unless said otherwise: every catalogue
clip with this rule is ``still``; ``cavewalk data convert --label forward`` labels a whole clip
``forward``); ``ignore`` -- the whole clip ``ignore``. Optional
``ignore_foot_above_m``: frames where a foot is that high above its standing level become
``ignore`` (a kick's raised leg). Then the annotated spans (checked by eye) override.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.skeleton import LABELS

F64 = NDArray[np.float64]
RULES = ("bout", "still", "ignore")


@dataclass(frozen=True, slots=True)
class ContactConfig:
    """Thresholds of the contact detector (metres above standing level, metres per second)."""

    on_height_m: float = 0.03
    off_height_m: float = 0.05
    on_speed_mps: float = 0.35
    off_speed_mps: float = 0.60
    standing_percentile: float = 5.0

    def __post_init__(self) -> None:
        if not (0 <= self.on_height_m <= self.off_height_m):
            raise InputError("contacts: need 0 <= on_height_m <= off_height_m")
        if not (0 <= self.on_speed_mps <= self.off_speed_mps):
            raise InputError("contacts: need 0 <= on_speed_mps <= off_speed_mps")


def foot_heights(ankles: F64, percentile: float) -> F64:
    """(T, 2) height of each ankle (T, 2, 3) above its own standing level."""
    z = ankles[:, :, 2]
    return z - np.nanpercentile(z, percentile, axis=0)[None, :]


def foot_speeds(ankles: F64, fps: float) -> F64:
    """(T, 2) 3D speed (m/s) of each ankle, central differences (one-sided at the ends)."""
    if len(ankles) < 2:
        return np.zeros(ankles.shape[:2])
    v = np.gradient(ankles, 1.0 / fps, axis=0)
    return np.linalg.norm(v, axis=-1)


def detect_contacts(ankles: F64, fps: float, cfg: ContactConfig = ContactConfig()) -> NDArray[np.bool_]:
    """(T, 2) bool foot contact [left, right] from ankle positions (T, 2, 3), CAVE frame."""
    if ankles.ndim != 3 or ankles.shape[1:] != (2, 3):
        raise InputError(f"ankles must have shape (T, 2, 3), got {ankles.shape}")
    h = foot_heights(ankles, cfg.standing_percentile)
    s = foot_speeds(ankles, fps)
    out = np.zeros(h.shape, dtype=bool)
    for foot in range(2):
        state = bool(h[0, foot] < cfg.off_height_m and s[0, foot] < cfg.off_speed_mps)
        for t in range(len(h)):
            if state and (h[t, foot] > cfg.off_height_m or s[t, foot] > cfg.off_speed_mps):
                state = False
            elif not state and h[t, foot] < cfg.on_height_m and s[t, foot] < cfg.on_speed_mps:
                state = True
            out[t, foot] = state
    return out


@dataclass(frozen=True, slots=True)
class Span:
    """A by-eye correction: frames with start_s <= t < end_s get ``label`` and ``tag``."""

    start_s: float
    end_s: float
    label: str
    tag: str

    def __post_init__(self) -> None:
        if self.label not in LABELS:
            raise InputError(f"span label {self.label!r} is not one of {list(LABELS)}")
        if not self.end_s > self.start_s >= 0:
            raise InputError(f"span needs 0 <= start_s < end_s, got {self.start_s}..{self.end_s}")


@dataclass(frozen=True, slots=True)
class LabelRule:
    """How a clip is labelled: the rule, its label and tag, the kick threshold, corrections."""

    rule: str
    label: str = "still"
    tag: str = ""
    ignore_foot_above_m: float | None = None
    spans: tuple[Span, ...] = ()

    def __post_init__(self) -> None:
        if self.rule not in RULES:
            raise InputError(f"label rule {self.rule!r} is not one of {list(RULES)}")
        if self.label not in LABELS:
            raise InputError(f"label {self.label!r} is not one of {list(LABELS)}")


def bout_span(contacts: NDArray[np.bool_]) -> tuple[int, int] | None:
    """[first lift-off, last touch-down] as frame indices (end inclusive), None if no foot lifts.

    A foot already in the air at the first (last) frame starts (ends) the bout there.
    """
    airborne = ~contacts.all(axis=1)
    idx = np.flatnonzero(airborne)
    if len(idx) == 0:
        return None
    return int(idx[0]), int(min(idx[-1] + 1, len(contacts) - 1))


def apply_rule(
    rule: LabelRule, contacts: NDArray[np.bool_], heights: F64, fps: float
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Per-frame (labels, tags) of a clip from its contacts (T, 2) and foot heights (T, 2)."""
    n = len(contacts)
    labels = np.full(n, "still", dtype=object)
    tags = np.full(n, "", dtype=object)
    if rule.rule == "bout":
        span = bout_span(contacts)
        if span is not None:
            labels[span[0]:span[1] + 1] = rule.label
            tags[span[0]:span[1] + 1] = rule.tag
    else:
        labels[:] = rule.label if rule.rule == "still" else "ignore"
        tags[:] = rule.tag
    if rule.ignore_foot_above_m is not None:
        high = np.nanmax(heights, axis=1) > rule.ignore_foot_above_m
        labels[high] = "ignore"
    t = np.arange(n) / fps
    for sp in rule.spans:
        sel = (t >= sp.start_s) & (t < sp.end_s)
        labels[sel] = sp.label
        tags[sel] = sp.tag
    return tuple(str(x) for x in labels), tuple(str(x) for x in tags)
