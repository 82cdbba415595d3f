"""The navigation stage: per-person recogniser states and the mode's commands, frame by frame.

:class:`Navigators` runs in the fusion process after the navigator choice. In ``single`` mode it
only reports the navigator's command (the fusion stage's own recogniser made it); in ``each``
and ``group`` mode it keeps one recogniser state per navigating person (sharing one ONNX
session), and in ``group`` mode also the room's command (:func:`pipeline.navigation.group.group_command`).
Every frame's :class:`NavigationFrame` lists each person's command and the command changes
since the previous frame (the session log records them).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.navigation.config import NAVIGATION_MODES, NavigationConfig, NavigationMode
from pipeline.navigation.group import GroupCommand, Vote, group_command
from pipeline.recognition.types import ActionEstimate
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)

GROUP = None  # the user id of the group's stream and of its command changes


class Recognizer(Protocol):
    def update(self, joints_m: NDArray[np.floating], timestamp_s: float) -> ActionEstimate: ...

    def reset(self) -> None: ...


@dataclass(frozen=True, slots=True)
class PersonCommand:
    """One navigating person's own command. position_m: (x, y, z) floor position, metres."""

    user_id: int
    action: ActionEstimate
    position_m: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class CommandChange:
    """A person's (user_id) or the group's (user_id None) command changed. Labels None = no command."""

    user_id: int | None
    previous: str | None
    current: str | None
    timestamp_s: float


@dataclass(frozen=True, slots=True)
class NavigationFrame:
    """The navigation stage's output for one frame.

    mode: the navigation mode. chosen: the chosen user ids (empty = everyone tracked).
    commands: each navigating person's command (in single mode, the navigator's), by user id.
    group: the room's command (group mode only; None when nobody is tracked).
    changes: command changes since the previous frame.
    """

    mode: NavigationMode
    chosen: tuple[int, ...] = ()
    commands: tuple[PersonCommand, ...] = ()
    group: GroupCommand | None = None
    changes: tuple[CommandChange, ...] = ()

    def __post_init__(self) -> None:
        if self.mode not in NAVIGATION_MODES:
            raise ValueError(f"mode must be one of {NAVIGATION_MODES}, got {self.mode!r}")
        if self.group is not None and self.mode != "group":
            raise ValueError(f"a group command belongs to group mode, not {self.mode!r}")

    @property
    def user_ids(self) -> tuple[int, ...]:
        """The people who navigate this frame (their own streams in each mode)."""
        return tuple(c.user_id for c in self.commands)

    def command_of(self, user_id: int) -> PersonCommand | None:
        return next((c for c in self.commands if c.user_id == user_id), None)


def _position(p: Person3D) -> tuple[float, float, float]:
    pos = p.position_m
    return (float(pos[0]), float(pos[1]), float(pos[2]))


class Navigators:
    """The navigation stage (see the module docstring).

    make_recognizer: builds one person's recogniser state (None: no actions, only the single
    mode's navigator is reported). Raises InputError from :meth:`set_mode` for a bad request,
    and nothing changes then.
    """

    def __init__(self, config: NavigationConfig, make_recognizer: Callable[[], Recognizer] | None) -> None:
        self.config = config
        self._make = make_recognizer
        self._states: dict[int, Recognizer] = {}
        self._labels: dict[int | None, str] = {}  # the last command of each person / the group

    @property
    def mode(self) -> NavigationMode:
        return self.config.mode

    @property
    def chosen(self) -> tuple[int, ...]:
        return self.config.user_ids

    def set_mode(self, mode: str, user_ids: Sequence[int] = ()) -> None:
        """Switch mode (and the chosen people); InputError, nothing changed, for a bad request."""
        try:
            config = NavigationConfig(mode, tuple(user_ids), self.config.max_navigators)  # type: ignore[arg-type]
        except ValueError as exc:
            raise InputError(str(exc)) from None
        if config.mode != self.config.mode or config.user_ids != self.config.user_ids:
            log.info("navigation %s %s -> %s %s", self.config.mode, list(self.config.user_ids),
                     config.mode, list(config.user_ids))
            self._states.clear()  # every navigator starts afresh in the new mode
        self.config = config

    def navigating(self, people: Sequence[Person3D]) -> list[Person3D]:
        """The people who get a recogniser state this frame: the chosen (or all) tracked people,
        nearest the CAVE's centre first, at most ``max_navigators``."""
        chosen = set(self.config.user_ids)
        pool = [p for p in people if not chosen or p.user_id in chosen]
        pool = [p for p in pool if np.all(np.isfinite(p.position_m[:2]))]
        pool.sort(key=lambda p: (float(np.hypot(*p.position_m[:2])), p.user_id))
        return sorted(pool[: self.config.max_navigators], key=lambda p: p.user_id)

    def update(self, people: Sequence[Person3D], timestamp_s: float, navigator: int | None = None,
               action: ActionEstimate | None = None) -> NavigationFrame:
        """One frame. In single mode ``navigator`` / ``action`` are the fusion stage's own."""
        if self.config.mode == "single":
            self._states.clear()
            commands: tuple[PersonCommand, ...] = ()
            person = next((p for p in people if p.user_id == navigator), None)
            if person is not None and action is not None:
                commands = (PersonCommand(person.user_id, action, _position(person)),)
            return NavigationFrame("single", (), commands, None, self._changes(commands, None, timestamp_s))
        navigating = self.navigating(people)
        ids = {p.user_id for p in navigating}
        for gone in [u for u in self._states if u not in ids]:
            del self._states[gone]  # lost: a person who comes back starts afresh
        out = []
        if self._make is not None:
            for p in navigating:
                state = self._states.get(p.user_id)
                if state is None:
                    state = self._states[p.user_id] = self._make()
                out.append(PersonCommand(p.user_id, state.update(p.joints_m, timestamp_s), _position(p)))
        commands = tuple(out)
        group = None
        if self.config.mode == "group":
            group = group_command([Vote(c.user_id, c.action, c.position_m) for c in commands])
        return NavigationFrame(self.config.mode, self.config.user_ids, commands, group,
                               self._changes(commands, group, timestamp_s))

    def _changes(self, commands: Sequence[PersonCommand], group: GroupCommand | None,
                 timestamp_s: float) -> tuple[CommandChange, ...]:
        now: dict[int | None, str] = {c.user_id: c.action.label for c in commands}
        if group is not None:
            now[GROUP] = group.action.label
        changes = [CommandChange(u, self._labels.get(u), now.get(u), timestamp_s)
                   for u in sorted(set(self._labels) | set(now), key=lambda u: -1 if u is None else u)
                   if self._labels.get(u) != now.get(u)]
        self._labels = now
        return tuple(changes)
