"""Prompted protocols: a list of timed steps whose labels come for free.

A protocol is a TOML file::

    name = "four actions"
    description = "The paper's four actions, each twice."
    steps = ["still 5 s", "forward 8 s", "still 3 s", "left 6 s", "crouch 4 s (label still)"]

A step is ``WHAT DURATION s`` with an optional ``(label L)``; ``WHAT`` is one of the four
actions (its own label) or a behaviour (``crouch``, ``turn``, ...) that must name its label,
which then becomes the step's tag. A step may also be a table
``{what = "crouch", duration_s = 4, label = "still", text = "Crouch down, then stand up"}``
to choose the instruction shown to the participant.

:func:`label_spans` turns a protocol into label spans on the take's clock, with ``ignore``
for ``margin_s`` after every change of label (the participant's reaction time) and
``lead_s`` before it.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.errors import InputError, read_user_text
from pipeline.skeleton import ACTIONS

#: The participant's instruction for each action (a step's ``text`` replaces it).
DEFAULT_TEXT: dict[str, str] = {
    "still": "Stand still",
    "forward": "Step forward on the spot",
    "left": "Step to your left on the spot",
    "right": "Step to your right on the spot",
}
_STEP = re.compile(
    r"^\s*(?P<what>[a-z][a-z0-9_-]*)\s+(?P<dur>[0-9]+(?:\.[0-9]+)?)\s*s\s*(?:\(\s*label\s+(?P<label>[a-z]+)\s*\))?\s*$"
)
MAX_STEP_S = 3600.0
MAX_STEPS = 500
_NAME_OK = re.compile(r"^[A-Za-z0-9_. -]{1,64}$")


@dataclass(frozen=True, slots=True)
class Step:
    """One instruction: ``what`` for ``duration_s`` seconds, labelled ``label`` (one of the four actions).

    tag: the behaviour's name when ``what`` is not an action ("" otherwise).
    text: what the participant reads.
    """

    what: str
    duration_s: float
    label: str
    text: str
    tag: str = ""

    def __post_init__(self) -> None:
        if self.label not in ACTIONS:
            raise InputError(
                f"step {self.what!r}: unknown label {self.label!r}; expected one of {list(ACTIONS)}"
            )
        if not (math.isfinite(self.duration_s) and 0 < self.duration_s <= MAX_STEP_S):
            raise InputError(
                f"step {self.what!r}: duration must be in (0, {MAX_STEP_S:g}] s, got {self.duration_s}"
            )


@dataclass(frozen=True, slots=True)
class Protocol:
    """A named list of steps; ``start_s`` of each step on the take's clock (0 = the take's start)."""

    name: str
    steps: tuple[Step, ...]
    description: str = ""

    def __post_init__(self) -> None:
        if not self.steps:
            raise InputError(f"protocol {self.name!r} has no steps")
        if len(self.steps) > MAX_STEPS:
            raise InputError(f"protocol {self.name!r} has {len(self.steps)} steps (at most {MAX_STEPS})")

    @property
    def duration_s(self) -> float:
        return float(sum(s.duration_s for s in self.steps))

    def starts_s(self) -> list[float]:
        out, t = [], 0.0
        for s in self.steps:
            out.append(t)
            t += s.duration_s
        return out

    def step_at(self, t_s: float) -> tuple[int, Step, float] | None:
        """(index, step, seconds left in it) at ``t_s`` seconds into the take, None after the end."""
        if t_s < 0:
            return None
        for i, (start, step) in enumerate(zip(self.starts_s(), self.steps, strict=True)):
            if t_s < start + step.duration_s:
                return i, step, start + step.duration_s - t_s
        return None

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "duration_s": self.duration_s,
            "steps": [
                {"what": s.what, "duration_s": s.duration_s, "label": s.label, "text": s.text, "tag": s.tag}
                for s in self.steps
            ],
        }


def parse_step(item: Any, where: str) -> Step:
    """One step from its string (``crouch 4 s (label still)``) or table form."""
    if isinstance(item, str):
        m = _STEP.match(item)
        if m is None:
            raise InputError(
                f"{where}: cannot read step {item!r}; write e.g. 'forward 8 s' or 'crouch 4 s (label still)'"
            )
        what, duration, label, text = m["what"], float(m["dur"]), m["label"], None
    elif isinstance(item, dict):
        unknown = sorted(set(item) - {"what", "duration_s", "label", "text"})
        if unknown:
            raise InputError(f"{where}: unknown step keys {unknown} (known: what, duration_s, label, text)")
        what, raw, label, text = item.get("what"), item.get("duration_s"), item.get("label"), item.get("text")
        if not isinstance(what, str) or not re.fullmatch(r"[a-z][a-z0-9_-]*", what):
            raise InputError(f"{where}: 'what' must be a lower-case word, got {what!r}")
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise InputError(f"{where}: 'duration_s' must be a number of seconds, got {raw!r}")
        duration = float(raw)
        if label is not None and not isinstance(label, str):
            raise InputError(f"{where}: 'label' must be a string, got {label!r}")
        if text is not None and (not isinstance(text, str) or not 0 < len(text) <= 200):
            raise InputError(f"{where}: 'text' must be 1-200 characters, got {text!r}")
    else:
        raise InputError(f"{where}: a step is a string or a table, got {type(item).__name__}")
    if label is None:
        if what not in ACTIONS:
            raise InputError(
                f"{where}: unknown label {what!r}: {what!r} is not one of the actions {list(ACTIONS)}; "
                f"name its label, e.g. '{what} {duration:g} s (label still)'"
            )
        label = what
    tag = "" if what in ACTIONS else what
    if text is None:
        text = (
            DEFAULT_TEXT[what] if what in ACTIONS else what.replace("-", " ").replace("_", " ").capitalize()
        )
    return Step(what=what, duration_s=float(duration), label=label, text=text, tag=tag)


def parse_protocol(data: dict[str, Any], where: str = "protocol") -> Protocol:
    """A protocol from its TOML table; :class:`InputError` naming the problem."""
    unknown = sorted(set(data) - {"name", "description", "steps"})
    if unknown:
        raise InputError(f"{where}: unknown keys {unknown} (known: name, description, steps)")
    name = data.get("name")
    if not isinstance(name, str) or not _NAME_OK.match(name):
        raise InputError(
            f"{where}: 'name' must be 1-64 letters, digits, spaces, '.', '_' or '-', got {name!r}"
        )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise InputError(f"{where}: 'description' must be a string")
    steps = data.get("steps")
    if not isinstance(steps, list) or not steps:
        raise InputError(f"{where}: 'steps' must be a non-empty list")
    return Protocol(
        name=name,
        description=description,
        steps=tuple(parse_step(s, f"{where}: step {i + 1}") for i, s in enumerate(steps)),
    )


def parse_protocol_text(text: str, where: str = "protocol") -> Protocol:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: not valid TOML: {exc}") from None
    return parse_protocol(data, where)


def load_protocol(path: str | Path) -> Protocol:
    return parse_protocol_text(read_user_text(path, "protocol file"), str(path))


#: The protocols that ship with cavewalk (``protocols/*.toml`` in the repository).
PROTOCOLS_DIR = Path(__file__).resolve().parents[2] / "protocols"


def shipped_protocols(folder: Path = PROTOCOLS_DIR) -> dict[str, Path]:
    """Protocol file stem -> path, for the protocols that ship with the product."""
    return {p.stem: p for p in sorted(folder.glob("*.toml"))} if folder.is_dir() else {}


@dataclass(frozen=True, slots=True)
class LabelSpan:
    """``label`` from ``t_start`` to ``t_end`` seconds on the take's clock (``t_end`` excluded).

    user_id: the person it applies to; None = whoever is the navigator at each frame.
    source: ``protocol``, ``margin`` or ``operator``.
    tag: free text naming what the person did (``crouch``...).
    """

    t_start: float
    t_end: float
    label: str
    user_id: int | None = None
    source: str = "protocol"
    tag: str = ""

    def __post_init__(self) -> None:
        if self.label not in (*ACTIONS, "ignore"):
            raise InputError(f"unknown label {self.label!r}; expected one of {[*ACTIONS, 'ignore']}")
        if not (math.isfinite(self.t_start) and math.isfinite(self.t_end) and self.t_end > self.t_start >= 0):
            raise InputError(f"a span needs 0 <= t_start < t_end, got {self.t_start}..{self.t_end}")


def check_margin(margin_s: float, name: str = "margin_s") -> float:
    if (
        isinstance(margin_s, bool)
        or not isinstance(margin_s, int | float)
        or not (math.isfinite(margin_s) and 0 <= margin_s <= 5.0)
    ):
        raise InputError(f"{name} must be a number of seconds in [0, 5], got {margin_s!r}")
    return float(margin_s)


def label_spans(protocol: Protocol, margin_s: float = 0.5, lead_s: float = 0.0) -> list[LabelSpan]:
    """The protocol's labels as spans, ``ignore`` from ``lead_s`` before to ``margin_s`` after each change.

    Consecutive steps with the same label are one span (no change, no margin).
    """
    margin_s, lead_s = check_margin(margin_s), check_margin(lead_s, "lead_s")
    merged: list[list[Any]] = []  # [start, end, label, tag]
    for start, step in zip(protocol.starts_s(), protocol.steps, strict=True):
        end = start + step.duration_s
        if merged and merged[-1][2] == step.label and merged[-1][3] == step.tag:
            merged[-1][1] = end
        else:
            merged.append([start, end, step.label, step.tag])
    spans: list[LabelSpan] = []
    for i, (start, end, label, tag) in enumerate(merged):
        change_before = i > 0 and merged[i - 1][2] != label  # a new tag with the same label is no change
        change_after = i < len(merged) - 1 and merged[i + 1][2] != label
        a = start + (margin_s if change_before else 0.0)
        b = end - (lead_s if change_after else 0.0)
        if change_before and (lead_s > 0 or margin_s > 0):
            g0, g1 = start - lead_s, min(a, end)
            if g1 > g0:
                spans.append(LabelSpan(round(g0, 6), round(g1, 6), "ignore", source="margin"))
        if b > a:
            spans.append(LabelSpan(round(a, 6), round(b, 6), label, tag=tag, source="protocol"))
    return spans


def frame_labels(t_s: list[float] | Any, spans: list[LabelSpan], default: str = "ignore") -> list[str]:
    """The label of each time (seconds on the take's clock): the last span that covers it wins."""
    out = []
    for t in t_s:
        label = default
        for s in spans:
            if s.t_start <= t < s.t_end:
                label = s.label
        out.append(label)
    return out
