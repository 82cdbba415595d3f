"""The locomotion streams of a frame: which commands the emitter sends, per navigation mode.

- ``single``: the navigator's command (``user_id`` = theirs, OSC ``/cave/locomotion``);
- ``each``: one command per navigating person (OSC ``/cave/locomotion/{user_id}``);
- ``group``: the room's command with ``user_id`` None (OSC ``/cave/locomotion``).
"""

from __future__ import annotations

import numpy as np

from pipeline.emitter.protocol import LocomotionCommand
from pipeline.results import FrameResult


def _xyz(pos: object) -> tuple[float, float, float]:
    p = np.asarray(pos, dtype=np.float64).reshape(3)
    p = np.where(np.isfinite(p), p, 0.0)
    return (float(p[0]), float(p[1]), float(p[2]))


def frame_commands(result: FrameResult) -> tuple[LocomotionCommand, ...]:
    """The commands to stream for ``result`` (empty: nothing to send, only heartbeats)."""
    nav = result.navigation
    if nav is None or nav.mode == "single":
        if result.navigator is None or result.action is None:
            return ()
        person = next((p for p in result.people3d if p.user_id == result.navigator), None)
        a = result.action
        return (LocomotionCommand(
            user_id=int(result.navigator), action=a.label, confidence=a.confidence,
            yaw_deg=float(a.yaw_deg), speed_mps=float(a.speed_mps),
            position_m=_xyz(person.position_m if person is not None else np.zeros(3)),
            timestamp_s=result.timestamp_s,
        ),)
    if nav.mode == "group":
        g = nav.group
        if g is None:
            return ()
        return (LocomotionCommand(
            user_id=None, action=g.action.label, confidence=g.confidence, yaw_deg=g.action.yaw_deg,
            speed_mps=g.action.speed_mps, position_m=_xyz(g.position_m), timestamp_s=result.timestamp_s,
        ),)
    return tuple(
        LocomotionCommand(
            user_id=c.user_id, action=c.action.label, confidence=c.action.confidence,
            yaw_deg=float(c.action.yaw_deg), speed_mps=float(c.action.speed_mps),
            position_m=_xyz(c.position_m), timestamp_s=result.timestamp_s, per_user=True,
        )
        for c in nav.commands
    )
