"""Whole simulated routines for training and evaluation: one seed -> a person doing a routine.

The API for the recogniser's training and evaluation (``pipeline.recognition.train`` and the
evaluation scripts)::

    from pipeline.sim.routines import ROUTINE_KINDS, simulate_routine

    motion = simulate_routine(seed=7, duration_s=40.0, kind="still-heavy")
    motion.joints_m   # (T, 17, 3) clean joints, CAVE frame, metres
    motion.labels     # (T,) still | forward | left | right (TEAM.md LABELS)
    motion.tags       # (T,) behaviour names: march, walk, run, side-step-out-back, step-together,
                      #      shuffle, turn, crouch, squat, kneel, bend, lean, tiptoe, jump, sway,
                      #      dance-on-spot, weight-shift, stretch, stand-up, look-around, point,
                      #      wave, cross-arms, hands-on-hips, touch-face ("" for plain standing)
    motion.contacts   # (T, 2) bool, feet planted [left, right]
    motion.to_sequence()  # the SPEC skeleton sequence (source="sim"), for save_npz

Kinds (``ROUTINE_KINDS``; what each draws: :mod:`pipeline.sim.ranges`):

- ``stepping``: stepping bouts of every style (marching with and without arm swing, knee lift
  3-30 cm, pauses, slides, creeping; walking and running; side steps out-and-back,
  step-together and shuffles 8-45 cm wide; cadence 0.5-2.6 steps/s; irregular and asymmetric
  bouts), with short still moments;
- ``still``: the still library only (every frame ``still``; :mod:`pipeline.sim.behaviours`):
  crouch, squat, kneel, bend to pick up, lean far, tiptoe, jump, sway, dance on the spot,
  weight shifts, stretches, looking around, pointing, waving, turns on the spot, standing
  idle: for false-movement training;
- ``still-heavy``: the still library with short stepping bouts;
- ``mixed``: all of it (the default of :func:`pipeline.sim.script.random_script`, which the
  live demo's navigator plays).

Everything (body 1.40-2.05 m with varied proportions, personal style, routine, motion) comes
from ``seed``: the same seed gives the same routine; routines of different kinds from one
seed are different people. For finer control draw the parts yourself:
:func:`pipeline.sim.body.sample_body`, :func:`pipeline.sim.body.sample_style`,
:func:`pipeline.sim.script.random_script` (``kind=...``), :func:`pipeline.sim.motion.simulate_user`.
"""

from __future__ import annotations

import numpy as np

from pipeline.errors import InputError
from pipeline.sim.body import HEIGHT_RANGE, sample_body, sample_style
from pipeline.sim.motion import UserMotion, simulate_user
from pipeline.sim.ranges import ROUTINE_KINDS
from pipeline.sim.script import random_script

# Bumped whenever the same seed and kind would give other motion (the rhythmic pivot turns of
# 2026-12-04 were the first such change after the held-out sets existed): the sets that
# ``cavewalk data sources`` writes from this simulator carry it in their stamp and are made again,
# and the training data's prepared cache keys our simulator's sources by it (``prepare``).
SIM_VERSION = 2

__all__ = ["ROUTINE_KINDS", "simulate_routine"]


def simulate_routine(
    seed: int,
    duration_s: float,
    kind: str = "mixed",
    *,
    fps: float = 30.0,
    start_xy_m: tuple[float, float] = (0.0, 0.0),
    height_range: tuple[float, float] = HEIGHT_RANGE,
) -> UserMotion:
    """A random person doing a random routine of ``kind`` for ``duration_s`` seconds at ``fps``."""
    if kind not in ROUTINE_KINDS:
        raise InputError(f"kind must be one of {', '.join(ROUTINE_KINDS)}, got {kind!r}")
    kind_index = ROUTINE_KINDS.index(kind)
    r_body, r_style, r_script, r_motion = (
        np.random.default_rng(s) for s in np.random.SeedSequence([int(seed), kind_index]).spawn(4)
    )
    body = sample_body(r_body, height_range)
    style = sample_style(r_style)
    script = random_script(r_script, duration_s, kind=kind, start_xy_m=start_xy_m)
    return simulate_user(script, body, fps, seed=int(r_motion.integers(2**31)), style=style)
