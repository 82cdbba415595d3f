"""The stepping-bout gate: one command per bout, held through the natural pause between steps.

What a user expects (MODEL_CARD.md, "Behaviour"):

- **No movement without a step.** A bout starts only on a step seen in the evidence
  (:mod:`pipeline.recognition.steps`): one foot lifting or sliding for ``confirm_s`` while the
  other carries the body (planted and not rising with it: not a jump, unless it is still down
  ``rise_wait_s`` after the lift and ``rise_lead_m`` lower: a walker's stance foot rolling over; or
  swinging since well before: running, if it lifted at most ``run_swing_s`` before or the
  full-body network's p(still) is at most ``run_still_prob``; feet both off contact for longer while
  the network is unsure slide or shuffle, as in dance footwork, and neither carries the body); a swing
  that lifted off while the other foot was up in the air (its swing begun well before and risen
  ``start_air_m``: a kick's stance foot sliding, the feet jumping or sliding apart into a wide stance)
  starts no bout unless the network sees a run (p(still) at most ``run_still_prob``), while
  the body is not crouched and not turning on the spot (``start_turn_deg`` within ``turn_window_s``
  while the foot has moved less than ``start_travel_m`` forward or back), and the network agreeing
  that it is movement (its smoothed probability of moving at least ``start_prob`` at some moment of
  that swing). Both feet planted, whatever the knees, hips and upper body do, is ``still``. Stepping
  the network does not know: ``rhythm_steps`` alternating steps in place in a row (none turning the
  body ``rhythm_turn_deg``, lift-offs within ``rhythm_gap_s``) start a bout without the network
  (reason ``rhythm``); it ignores the network's stops and ends when the next lift-off is later than
  the person's median rhythm allows, until the network is sure of one of its steps; after a bout the
  network ended, the rule waits for a new run of steps.
- **One command per bout.** Once started, the bout holds through the pauses between its steps:
  after each touch-down the next lift-off is due when the person's own rhythm says (the newest
  lift-off + ``pause_gain`` x the longest, or with ``rhythm="median"`` the median, of their last
  three lift-off intervals), plus
  ``pause_margin_s``, within [``min_allowance_s``, ``max_allowance_s``] after the touch-down;
  before two lift-offs are known, ``first_allowance_s``; an interval that broke a bout, up to
  ``max_interval_s``, still counts as the person's rhythm when the stepping resumes. If the next
  lift-off does not come by then, the rhythm has broken and the bout ends (``still``) there, unless
  the network is sure the bout goes on (smoothed p(still) below ``hold_still_prob``): then the pause
  may last up to ``max_allowance_s`` (a longer pause than the person has shown yet). With the feet
  apart after an opening step (a foot out to the side, ``split_hold``) the way back is still to come:
  the pause holds up to ``max_allowance_s`` whatever the rhythm says (``split_allowance_s`` after a step
  that opened ``split_width_m`` or more: slow side steps rest with the foot out, and the other foot
  may mark time unseen), unless the network is sure the bout has ended (``pause_still_prob``, as below).
  Such a foot lifting again is the way back (within ``split_memory_s`` of the bout's newest step): the
  bout's side is kept for it, a bout it starts goes to that side, and while it, or the other foot
  following it (a step-together), only rises in place (lower than ``march_lift_m``) it is no march
  step until it lands; nor when it lands (``way_back_landing``): a foot that stood out to the bout's
  side when it lifted and rose less than ``march_lift_m`` came part of the way home (a way back in
  two parts: a low rise, then a slide home), so its landing does not turn the bout forward.
- **Stops stay fast**: past the pause the person's *median* rhythm allows, a smoothed p(still) of
  ``late_still_prob`` already ends the bout (the longest-interval deadline is only for pauses the
  network does not call a stop).
- **The network can stop a bout**: a whole swing during which the network's probability of moving
  never reached ``stop_prob`` (a pivot step while turning on the spot, a kick) ends it, and so does
  a pause (``min_pause_s`` after a touch-down) in which the network is sure, with
  ``pause_still_prob``, that the person has stopped (it has learnt what a last step looks like); a
  crouch, a jump (both feet took off together; a foot still up ``jump_air_s`` after the other one
  landed is a step, not a jump: running; a bout of ``jump_steps`` landed steps the network is sure
  of goes on through it: a run's flight) or a body that is not upright (bent far over, lying,
  crawling: an unfamiliar posture) ends it at once, and so does a kick (a swing that raises the leg
  ``kick_deg`` from straight down, forward or to a side; no march step or stride does: its ankle
  stays under the knee; the kick's landing is no step, so no pause is held after it), so does a
  foot sliding back low while the other stands (``back_slide_m`` behind where it lifted off, never
  higher than ``back_slide_low_m`` this swing: the rear leg of a kneel or a lunge going down; it
  starts no bout either), and a pivot
  (the body turning more than ``max_turn_deg`` during one swing in place, twice that for a step that
  moves the foot ``turn_travel_m`` forward or back: walking a curve). Rhythmic pivot steps turn the
  body less per swing but keep turning: a swing while the steps turn the body (``swing_turn_deg``,
  this swing or the other foot's last one) and the body turned more than ``max_window_turn_deg``
  within ``turn_window_s``, the feet stepping in place, is a turn on the spot too: no bout starts,
  and a bout of fewer than ``steer_steps`` landed steps ends (an established march that starts to
  turn is steering and goes on; a side-step bout that turns the body is turning on the spot); a bout
  whose only step (in place) has landed ends once the body has turned ``first_turn_deg`` since that
  step's lift-off (a slow turn in single pivot steps; ``first_turn_open_deg`` after a step that opened
  sideways: a wide stance turns the hips and the shoulders a little). A swing whose foot rose ``march_lift_m``
  without itself turning the body is a march step, not a pivot: a turn that has just ended neither
  vetoes its start nor ends its bout.
- **Direction** (forward / left / right): the network's smoothed probabilities among the moving
  classes, weighted by the evidence of the newest step (``evidence_weight``): a foot opening
  sideways away from the other foot is a side step to that foot's side; a vertical (march) or
  forward step is forward; a closing step (the trailing foot following, or the foot coming back)
  keeps the bout's direction, and so does a single opening step to the other side (the way back
  of a step-touch; a bout that starts on such a step keeps the side of the steps just before, also
  when it started sideways on the network's word before the foot moved sideways: the start's
  direction is read again once the first step shows its side); ``side_switch_steps`` of them in a
  row turn the bout to that side, and so does one after ``travel_steps`` opening steps the same way
  in a row (travelling sideways). Stepping in place comes back to its place: an opening step to the
  other side by a foot that stands more than ``way_back_m`` out to the bout's side of where its side
  steps began (the landed lateral displacements added up) is the way back home, however many come
  in a row (a shuffle or a step-together returning); once the feet are home, the next one turns the
  bout; and if the same foot steps back again (it stepped out to the other side and back, after
  side steps that travelled) the bout turns to that side then. A march step (a foot up
  ``march_confirm_s`` without moving sideways, or landed so) turns a side-step bout forward if the
  network agrees and no foot steps sideways (and makes the place of the march the side steps' home);
  so does a swing that rose ``march_lift_m`` without opening sideways while the full-body network
  gives forward ``march_sure_prob`` of its moving probability (a march that begins on the way back
  from a side step: the foot comes home with a high knee lift), or rose ``march_low_lift_m`` while it
  gives forward ``march_surest_prob`` (a march from a side step's wide stance begins with low steps
  that bring the feet together);
  a closing step inside a forward bout after side steps (a march does not close) lets the network
  choose the direction again (``close_rechoose``).
- **Two judges** (a model with a start head, ``start_network``): while no bout is on, the gate reads
  the surer (lower smoothed p(still)) of the full-body network and the legs-only one (hips, legs,
  shoulders and the step evidence: it has not learnt stepping from the arm swing, so it knows other
  people's low, still-armed steps sooner); once a bout is on, only the full-body network holds and
  ends it (it sees the arms stop; the legs-only one holds pauses too long). The start head is quiet
  for ``start_quiet_s`` after the body was crouched (standing up from a kneel brings a foot back) and
  while the body has turned ``start_quiet_deg`` within ``turn_window_s`` (a turn's pivots): the
  full-body network knows those, the legs-only one less. Standing up from a kneel brings the feet
  back together from the kneel's split stance: within ``kneel_quiet_s`` after the body was crouched, a
  step whose foot stood ``kneel_split_m`` or more ahead of or behind the other at its lift-off starts
  no bout, whichever judge speaks.

:class:`BoutGate` is streaming; it holds only what it needs (times of the bout's steps).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.numbers import rounded
from pipeline.recognition.steps import SIDEWAYS_KINDS, StepFrame
from pipeline.skeleton import ACTIONS

_STILL, _FORWARD, _LEFT, _RIGHT = (ACTIONS.index(a) for a in ("still", "forward", "left", "right"))
RHYTHMS = ("max", "median")
REASONS = ("planted", "lifting", "stepping", "pause", "rhythm-broke", "jump", "crouched", "pivot",
           "network-still", "feet-unknown", "not-upright", "kick", "rhythm", "start-head",
           "step-back")  # fmt: skip


# the other foot lifted off "well before" this one (a run's overlapping step, a kick's stance foot) when
# more than this earlier; two feet leaving within it are a jump's, for the jump rule
WELL_BEFORE_S = 0.1


@dataclass(frozen=True, slots=True)
class GateConfig:
    """Settings of the bout gate (see the module docstring)."""

    start_prob: float = 0.6
    stop_prob: float = 0.15
    confirm_s: float = 0.1
    first_allowance_s: float = 0.8
    pause_gain: float = 1.0
    pause_margin_s: float = 0.2
    min_allowance_s: float = 0.25
    max_allowance_s: float = 1.2
    evidence_direction: bool = True
    evidence_weight: float = 3.0
    max_turn_deg: float = 30.0  # one swing in place turning the body this far is a pivot (twice: walking)
    pause_still_prob: float = 0.75
    min_pause_s: float = 0.1
    max_interval_s: float = 2.6
    min_swing_s: float = 0.1
    rhythm: str = "max"  # the person's step interval: "max" or "median" of their last three
    hold_still_prob: float = 0.35  # the deadline waits while the network's p(still) stays below this
    late_still_prob: float = 0.35  # past the median rhythm's due time, this p(still) ends the bout
    jump_air_s: float = 0.6  # a "jump" foot still up this long after the other landed: a step
    # a jump's feet both leave the floor: one foot off contact jump_rise_s but never jump_min_height_m
    # high while the other rose slide_step_m is a step over a sliding stance (a treadmill's belt, a
    # march sliding back), not a jump (both feet sliding low, as in a dance, stay a jump: no step)
    jump_rise_s: float = 0.15
    jump_min_height_m: float = 0.03
    slide_step_m: float = 0.05
    jump_steps: int = 4  # a bout of this many landed steps is not ended by a jump (0: always ended) ...
    # ... while the network's p(still) stays below hold_still_prob: a run's flight phase
    # a planted foot "rising" (half-way to a lift-off) may be the second foot of a jump taking off,
    # but not once the other has been up rise_wait_s without it and rise_lead_m higher: a walker's
    # stance foot rolling over (on tiptoes both feet rise together)
    rise_wait_s: float = 0.2
    rise_lead_m: float = 0.03
    # a foot swinging while the other is up too is a run's step only if the other lifted well before
    # this one, and either at most run_swing_s ago or with the full-body network's p(still) at most
    # run_still_prob: a runner's feet overlap in the air briefly, or the network sees the run (a
    # landing the tracker missed); feet both off contact longer, the network unsure, slide or shuffle
    # (dance footwork) and neither carries the body (run_still_prob 1: no limit)
    run_swing_s: float = 0.6
    run_still_prob: float = 0.05
    side_switch_steps: int = 2  # opening steps to the other side in a row that turn a side-step bout
    travel_steps: int = 2  # ... or one, after this many opening steps the same way in a row (travel)
    march_confirm_s: float = 0.2  # a side-step bout turns forward once a foot has risen this long without
    # moving sideways (or on the landing of such a step)
    # Turning on the spot: a foot swinging, its swing (or the other foot's last one) turned the body
    # swing_turn_deg, the body turned more than max_window_turn_deg within turn_window_s, every step in
    # place (less than turn_travel_m forward or back: walking a curve moves the feet) ...
    turn_window_s: float = 0.7
    max_window_turn_deg: float = 10.0  # inf: never
    swing_turn_deg: float = 5.0
    turn_travel_m: float = 0.2
    # no bout starts on a swing in place (less than start_travel_m forward or back so far) while the
    # body turned start_turn_deg within turn_window_s: a pivot of a turn on the spot (a walker's first
    # steps on a curve travel; a march that starts to turn after its first steps is steering)
    start_turn_deg: float = 10.0
    start_travel_m: float = 0.1
    first_turn_deg: float = 7.0  # the body turned this far since a bout's lone first step in place: a pivot
    first_turn_open_deg: float = 15.0  # ... or this far, if more, when that step opened sideways (a wide
    # stance turns the hips and shoulders a little)
    steer_steps: int = 2  # ... unless the bout has already landed this many steps: steering while marching
    # (0: a turning bout always ends)
    # a foot sliding back low while the other stands, back_slide_m behind where it lifted off and never
    # higher than back_slide_low_m this swing: the rear leg of a kneel or a lunge going down (a heel
    # kick rises as it goes back; no step in place slides a foot that far back; on a treadmill the
    # belt carries the stance foot back while the other swings): it ends a bout and starts none
    # (inf: never)
    back_slide_m: float = 0.22
    back_slide_low_m: float = 0.06
    kick_deg: float = 55.0  # a swing raising the leg this far (hip to ankle, from straight down) is a kick
    # the feet apart after an opening step (a foot out to the side): the way back is still to come, so
    # the pause holds up to max_allowance_s after that landing, whatever the rhythm, unless the network
    # is sure the bout has ended (pause_still_prob) ...
    split_hold: bool = True
    split_allowance_s: float = 2.0  # ... up to this long after the landing of a step that opened
    split_width_m: float = 0.05  # ... this far sideways (a narrower opening step: max_allowance_s)
    # such a foot (standing out to the bout's side, the other foot not having followed) is on its way
    # back when it lifts again: within split_memory_s of the bout's newest step the bout's side is kept
    # for it, a bout it starts goes to that side, and while it (or the other foot, following it) only
    # rises in place, lower than march_lift_m, it is not read as a march step (0: off)
    split_memory_s: float = 4.0
    # a swing whose foot rose march_lift_m without itself turning the body (swing_turn_deg) is a march
    # step, not a pivot of a turn on the spot: the body's turn just before it (a turn that has ended)
    # neither vetoes its start nor ends its bout (inf: never)
    march_lift_m: float = 0.10
    # the landing of a low rise (under march_lift_m) of a foot that stood out to the bout's side when it
    # lifted is the way back, no march step: it does not turn the bout forward (False: before 2026-12-07)
    way_back_landing: bool = True
    # a side-step bout turns forward while a foot that has risen march_lift_m swings without opening
    # sideways and the full-body network gives forward this share of its moving probability (a march
    # that begins on the way back from a side step; 1: never by this) ...
    march_sure_prob: float = 0.8
    # ... and so does one that has risen march_low_lift_m while the network gives forward this share
    # (a march from the wide stance of a side step begins with low steps that bring the feet together;
    # 1: never by this)
    march_low_lift_m: float = 0.05
    march_surest_prob: float = 0.9
    # Stepping the network does not know: rhythm_steps alternating steps in a row (left, right, left:
    # each lift-off within rhythm_gap_s of the other foot's, each swing turning the body less than
    # rhythm_turn_deg, none a jump or a kick) start a bout even while the network calls them still,
    # from the last of them (0: never). Such a bout ignores the network's stops and ends when the
    # next lift-off is later than the person's median rhythm allows; once the network is sure of one
    # of its steps it is an ordinary bout. After a bout the network ended, the rule waits for a new
    # run of steps (a break longer than rhythm_gap_s).
    rhythm_steps: int = 3
    rhythm_gap_s: float = 1.5
    rhythm_turn_deg: float = 3.0
    # a "swing" longer than this is no march step (the tracker missed a landing in between: a side
    # step out, a pause with the foot out, and back): neither while up nor when it lands where it
    # left does it turn a side-step bout forward (inf: any)
    max_step_swing_s: float = 1.0
    # a closing step (a foot moving towards the other one) inside a forward bout, after side steps,
    # lets the network choose among the moving classes (the bout's direction weighted 1.5): a march
    # does not close (walking's closing steps, with no side step before, are left alone)
    close_rechoose: bool = True
    # an opening step to the other side by a foot that stands more than way_back_m out to the bout's
    # side of where the bout's side steps began (the feet's landed lateral displacements added up) is
    # the way back home, however many of them come in a row (a shuffle or a step-together returning
    # to its place); only a step beyond home counts towards a new direction (inf: never)
    way_back_m: float = 0.05
    # with a model's start head: while no bout is on, the surer of the two networks speaks (off: the
    # full-body network alone, the ablation)
    start_network: bool = True
    # ... but not within start_quiet_s after the body was crouched (standing up from a kneel or a
    # squat brings a foot back) nor while the body has turned start_quiet_deg within turn_window_s
    # (the pivots of a turn on the spot): the full-body network knows those, the legs-only one less
    start_quiet_s: float = 1.5
    start_quiet_deg: float = 5.0
    # standing up from a kneel: within kneel_quiet_s after the body was crouched, a step whose foot
    # stood kneel_split_m or more ahead of or behind the other one (the kneel's split stance) brings
    # the feet back together and starts no bout, whichever judge speaks (0: off)
    kneel_quiet_s: float = 1.5
    kneel_split_m: float = 0.25
    # a swing that lifted off while the other foot was up in the air (its swing begun more than 0.1 s
    # before, not landed, and risen start_air_m) starts no bout: both feet moving at once is no step of
    # a standing person's (a kick's stance foot sliding as the leg comes down, the feet jumping or
    # sliding apart into a wide stance), unless the full-body network sees a run (p(still) at most
    # run_still_prob: a runner's feet overlap in the air); feet leaving together are the jump rule's;
    # a foot that only slides (a treadmill's belt under the stance foot) is not up (inf: off)
    start_air_m: float = 0.03

    def __post_init__(self) -> None:
        if self.rhythm not in RHYTHMS:
            raise ValueError(f"rhythm must be one of {', '.join(RHYTHMS)}, got {self.rhythm!r}")
        for name in (
            "start_prob",
            "stop_prob",
            "pause_still_prob",
            "hold_still_prob",
            "late_still_prob",
            "march_sure_prob",
            "march_surest_prob",
            "run_still_prob",
        ):
            v = getattr(self, name)
            if not 0 <= v <= 1:
                raise ValueError(f"{name} must be in [0, 1], got {v}")
        for name in (
            "confirm_s",
            "first_allowance_s",
            "pause_margin_s",
            "min_allowance_s",
            "max_allowance_s",
            "max_interval_s",
            "min_swing_s",
            "march_confirm_s",
            "jump_rise_s",
            "jump_min_height_m",
            "rise_lead_m",
            "turn_window_s",
            "turn_travel_m",
            "swing_turn_deg",
            "start_quiet_s",
            "split_allowance_s",
            "split_width_m",
            "split_memory_s",
            "kneel_quiet_s",
            "kneel_split_m",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be >= 0, got {v}")
        if self.min_allowance_s > self.max_allowance_s:
            raise ValueError(
                f"min_allowance_s ({self.min_allowance_s}) must not exceed "
                f"max_allowance_s ({self.max_allowance_s})"
            )
        names = (
            "slide_step_m", "way_back_m", "start_quiet_deg", "rise_wait_s", "jump_air_s", "run_swing_s",
            "start_air_m",
        )  # fmt: skip
        for name in names:
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0 (inf: never), got {getattr(self, name)}")
        if not (self.start_turn_deg > 0 and self.start_travel_m >= 0):
            raise ValueError(
                f"start_turn_deg must be > 0 (inf: never) and start_travel_m >= 0, got "
                f"{self.start_turn_deg}, {self.start_travel_m}"
            )
        for name in (
            "march_lift_m", "march_low_lift_m", "back_slide_m", "back_slide_low_m", "kick_deg",
            "first_turn_deg", "first_turn_open_deg", "max_window_turn_deg",
        ):  # fmt: skip
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 (inf: never), got {getattr(self, name)}")
        if self.jump_steps < 0:
            raise ValueError(f"jump_steps must be >= 0 (0: never), got {self.jump_steps}")
        if self.rhythm_steps < 0 or self.rhythm_steps == 1:
            raise ValueError(f"rhythm_steps must be 0 (never) or >= 2, got {self.rhythm_steps}")
        if not (self.rhythm_gap_s > 0 and self.rhythm_turn_deg >= 0):
            raise ValueError(
                f"rhythm_gap_s must be > 0 and rhythm_turn_deg >= 0, got {self.rhythm_gap_s}, "
                f"{self.rhythm_turn_deg}"
            )
        if self.steer_steps < 0:
            raise ValueError(f"steer_steps must be >= 0 (0: never), got {self.steer_steps}")
        if self.side_switch_steps < 1 or self.travel_steps < 1:
            raise ValueError(
                f"side_switch_steps and travel_steps must be >= 1, got {self.side_switch_steps}, "
                f"{self.travel_steps}"
            )
        if self.pause_gain < 1 or self.evidence_weight < 1:
            raise ValueError(
                f"pause_gain and evidence_weight must be >= 1, got {self.pause_gain}, {self.evidence_weight}"
            )


@dataclass(frozen=True, slots=True)
class GateVerdict:
    """The gate's decision in one frame (shown on the step strip).

    active: a bout is on. label: the command's class index. reason: one of REASONS.
    evidence: the direction the newest step's evidence points to ("forward", "left", "right") or None.
    allowance_s: the pause the person's rhythm allows now; deadline_s: when the bout ends unless a
    foot lifts (NaN while a foot swings or no bout).
    """

    active: bool
    label: int
    reason: str
    evidence: str | None
    allowance_s: float
    deadline_s: float

    def to_dict(self) -> dict[str, object]:
        return {
            "active": bool(self.active),
            "command": ACTIONS[self.label],
            "reason": self.reason,
            "evidence": self.evidence,
            "allowance_s": round(float(self.allowance_s), 3),
            "deadline_s": rounded(self.deadline_s),
        }


def evidence_direction(frame: StepFrame) -> int | None:
    """The class the newest step's displacement points to, or None (closing, small, unclear)."""
    k = frame.stepping
    if k < 0:
        return None
    kind = frame.feet[k].kind
    if kind == "open":
        return _LEFT if k == 0 else _RIGHT
    if kind in ("vertical", "forward"):
        return _FORWARD
    return None


def choose_direction(
    probs: NDArray[np.floating], evidence: int | None, config: GateConfig, current: int | None = None
) -> int:
    """The moving class: the network's moving probabilities weighted by the evidence."""
    p = np.asarray(probs, dtype=np.float64)
    score = p[1:].copy() + 1e-6
    if config.evidence_direction and evidence is not None:
        score[evidence - 1] *= config.evidence_weight
    elif current is not None:
        score[current - 1] *= 1.5  # no new evidence: the bout keeps its direction unless clearly wrong
    return int(np.argmax(score)) + 1


class BoutGate:
    """Streaming bout gate: ``update(step_frame, smoothed_probs, t)`` -> :class:`GateVerdict`."""

    def __init__(self, config: GateConfig | None = None) -> None:
        self.config = config or GateConfig()
        self.reset()

    def reset(self) -> None:
        self._active = False
        self._label = _STILL
        self._swing_lift = [math.nan, math.nan]  # lift-off time of each foot's current swing
        self._lift_in_air = [False, False]  # each foot's current swing lifted while the other was up
        self._swing_maxp = [0.0, 0.0]  # highest network p(moving) during it
        self._intervals: deque[float] = deque(maxlen=3)  # the person's last lift-off to lift-off times
        self._last_lift_t = math.nan
        self._bout_land_t = math.nan  # newest touch-down of the bout
        self._bout_steps = 0
        self._land_seen = [-math.inf, -math.inf]  # when each foot's newest touch-down was reported
        self._side = _STILL  # the side (left / right) the bout's side steps lead to; still = none yet
        self._side_lift = math.nan  # lift-off of the newest opening step counted for it
        self._opposite = 0  # opening steps to the other side since, in a row
        self._same = 0  # opening steps to the bout's side in a row
        self._side_t = -math.inf  # when the bout's newest step was seen (the side is kept that long)
        self._home = [0.0, 0.0]  # each foot's lateral place (m, +right) since the side was set
        self._homing = (-1, math.nan)  # (foot, lift-off) of the newest step read as the way back home
        self._yaws: deque[tuple[float, float]] = deque()  # (t, body yaw in degrees) over turn_window_s
        self._lift_yaw = [math.nan, math.nan]  # body yaw at each foot's newest lift-off (unwrapped)
        self._last_turn = [0.0, 0.0]  # the body's turn during each foot's current or last swing
        self._swing_top = [0.0, 0.0]  # each foot's highest point (above its standing level) this swing
        self._slid = [False, False]  # the current (or last) swing of each foot was part of a slide
        self._opened = [False, False]  # each foot's last step opened (away from the other, not followed)
        self._out_lift = [False, False]  # each foot stood out to the bout's side when it last lifted off
        self._first_foot = -1  # the foot of the bout's first landed step
        self._crouch_t = -math.inf  # when the body was last crouched
        self._turned_last = 0.0  # the body's turn within turn_window_s, as of the last frame
        self._kicked = [False, False]  # the current (or last) swing of each foot raised the leg kick_deg
        self._raised = [0, 0]  # frames in a row each swinging leg has been raised kick_deg
        self._run: deque[tuple[int, float]] = deque(maxlen=8)  # (foot, lift-off) of alternating steps
        self._unknown = False  # the bout was started by the rhythm alone: the network does not know it
        self._by_head = False  # started on the start head's word; the full-body network not yet sure
        self._vetoed = False  # the network ended a bout of the steps in the current run
        self._last_run_lift = -math.inf  # lift-off of the newest step counted for a run
        self._unsure_start = math.nan  # lift-off of a bout's first step, started sideways on the network's
        # word before the step showed which way it goes

    def _stance_ok(self, frame: StepFrame, k: int, p_still: float) -> bool:
        """The other foot carries the body (planted and not taking off too: no jump, though a foot
        still planted ``rise_wait_s`` after this one lifted and ``rise_lead_m`` below it is a stance
        foot rolling over, not a jump's), or it has been swinging since well before this one lifted
        (running: for at most ``run_swing_s``, unless the full-body network's ``p_still`` is at most
        ``run_still_prob``)."""
        c, other = self.config, frame.feet[1 - k]
        if not other.known:
            return False
        if other.planted:
            if not other.rising:
                return True
            # still planted rise_wait_s after this foot lifted and well below it: rolling over
            lead = frame.feet[k].height_m - other.height_m  # NaN (unknown) compares False
            return frame.t - self._swing_lift[k] >= c.rise_wait_s and lead >= c.rise_lead_m
        other_lift = self._swing_lift[1 - k]  # NaN (no swing seen) compares False
        run = frame.t - other_lift <= c.run_swing_s or p_still <= c.run_still_prob
        return other_lift < self._swing_lift[k] - WELL_BEFORE_S and run

    def _jump(self, frame: StepFrame, k: int) -> bool:
        """Foot ``k``'s swing is part of a jump: the tracker says both feet took off together, and it
        is not a foot still up ``jump_air_s`` after the other one landed (a jump lands on both feet
        together; a foot that stays up is stepping, e.g. running, whose feet overlap in the air)."""
        f, other = frame.feet[k], frame.feet[1 - k]
        if not f.jump or self._slid[k]:
            return False
        if f.planted:
            return True
        return not (other.planted and frame.t - self._land_seen[1 - k] > self.config.jump_air_s)

    def _track_slides(self, frame: StepFrame) -> None:
        """Each foot's highest point this swing; a "jump" in which one foot has been off contact
        ``jump_rise_s`` without rising ``jump_min_height_m`` while the other rose ``slide_step_m`` is a
        step over a sliding stance, for both feet's swings."""
        c = self.config
        for k, f in enumerate(frame.feet):
            h = f.height_m if math.isfinite(f.height_m) else 0.0
            if f.lifted:
                self._swing_top[k], self._slid[k] = h, False
            elif not f.planted:
                self._swing_top[k] = max(self._swing_top[k], h)
        for k, f in enumerate(frame.feet):
            low = f.swing_s >= c.jump_rise_s and self._swing_top[k] < c.jump_min_height_m
            if f.jump and not f.planted and low and self._swing_top[1 - k] >= c.slide_step_m:
                self._slid[k] = self._slid[1 - k] = True

    def _track_kicks(self, frame: StepFrame) -> None:
        """Each foot's current (or last) swing is a kick once it has raised the leg ``kick_deg`` two
        frames in a row (one ankle misplaced by the cameras is no kick)."""
        for k, f in enumerate(frame.feet):
            if f.lifted:
                self._kicked[k] = False
            up = not f.planted and f.raise_deg >= self.config.kick_deg  # NaN (unknown) compares False
            self._raised[k] = self._raised[k] + 1 if up else 0
            if self._raised[k] >= 2:
                self._kicked[k] = True

    def _allowance(self, rhythm: str | None = None, longest: float | None = None) -> float:
        """How long after the newest touch-down the next lift-off may come: when the person's rhythm
        says it is due (``pause_gain`` x the longest of their last three step intervals after the
        newest lift-off) + ``pause_margin_s``, within [min_allowance_s, ``longest`` or
        max_allowance_s]."""
        c = self.config
        if not self._intervals or not math.isfinite(self._bout_land_t):
            return c.first_allowance_s
        rhythm = rhythm or c.rhythm
        interval = max(self._intervals) if rhythm == "max" else float(np.median(self._intervals))
        due = self._last_lift_t + c.pause_gain * interval - self._bout_land_t
        cap = c.max_allowance_s if longest is None else longest
        return float(min(max(due + c.pause_margin_s, c.min_allowance_s), cap))

    def _split_allowance(self, k: int) -> float:
        """How long a pause with foot ``k`` out to the side may last: ``max_allowance_s``; after a
        step that opened ``split_width_m`` or more, as long as the person's own rhythm says (slow side
        steps rest with the foot out), up to ``split_allowance_s``."""
        c = self.config
        if not self._opened[k]:
            return c.max_allowance_s
        return max(c.max_allowance_s, self._allowance(longest=c.split_allowance_s))

    def _side_evidence(self, frame: StepFrame, ev: int | None) -> int | None:
        """The direction the newest step speaks for, read against the bout's side: the first opening
        step of a bout sets its side; an opening step to the other side is the way back (a
        step-touch returning to where it began) and speaks for the bout's side, until two of them
        come in a row (the person now steps to the other side)."""
        if ev not in (_LEFT, _RIGHT) or frame.stepping < 0:
            return ev
        lift = self._swing_lift[frame.stepping]
        if lift != self._side_lift:  # a new opening step
            self._side_lift = lift
            if ev == self._side:
                self._same, self._opposite = self._same + 1, 0
            elif self._side == _STILL:
                self._begin_side(ev)
            elif (1.0 if self._side == _RIGHT else -1.0) * self._home[
                frame.stepping
            ] > self.config.way_back_m:
                # the foot is out to the bout's side: on its way back home (counted as a step to the
                # other side: once home, the next one there turns the bout)
                self._same, self._opposite = 0, self._opposite + 1
                self._homing = (frame.stepping, lift)
            else:
                self._opposite += 1
                # after several steps the same way (travelling sideways) a step the other way is a
                # new direction; after one it may be the way back
                if self._opposite >= self.config.side_switch_steps or self._same >= self.config.travel_steps:
                    self._begin_side(ev)
                else:  # the way back: the next step out starts a new run
                    self._same = 0
        return self._side

    def _begin_side(self, side: int) -> None:
        """The bout's side steps begin here, to ``side``: its home is where the feet stand now."""
        self._side, self._opposite, self._same = side, 0, 1
        self._home, self._homing = [0.0, 0.0], (-1, math.nan)

    def _forget_side(self) -> None:
        """No side is known (a new bout takes the side of its own steps)."""
        self._side, self._side_lift, self._opposite, self._same = _STILL, math.nan, 0, 0
        self._homing = (-1, math.nan)

    def _check_homing(self, frame: StepFrame) -> None:
        """A step read as the way back home (``way_back_m``) is confirmed once the other foot steps;
        if the same foot steps back instead (a closing step), it was a step out to the other side and
        back: the bout turns to that side."""
        k, lift = self._homing
        if k < 0:
            return
        f, other = frame.feet[k], frame.feet[1 - k]
        if other.lifted:
            self._homing = (-1, math.nan)
        elif not f.planted and self._swing_lift[k] != lift and f.kind == "close":
            self._begin_side(_LEFT if self._side == _RIGHT else _RIGHT)
            if self._active and self._label in (_LEFT, _RIGHT):
                self._label = self._side

    def _out_to_side(self, k: int) -> bool:
        """Foot ``k`` stands out to the bout's side: its last step opened to that side and the other
        foot has not followed it."""
        return self._opened[k] and self._side == (_LEFT if k == 0 else _RIGHT)

    def _low_way_back(self, k: int) -> bool:
        """Foot ``k``'s swing (landing now) rose less than ``march_lift_m`` from where it stood out to
        the bout's side: part of its way back (``way_back_landing``), no march step."""
        c = self.config
        return c.way_back_landing and self._out_lift[k] and self._swing_top[k] < c.march_lift_m

    def _moving(self) -> str:
        """The reason of a bout's stepping frames: ``rhythm`` while the rhythm alone carries it,
        ``start-head`` while only the start head has been sure of it."""
        return "rhythm" if self._unknown else "start-head" if self._by_head else "stepping"

    def _count_rhythm(self, foot: int, lift_t: float, broken: bool) -> None:
        """A step of ``foot`` that lifted off at ``lift_t`` has landed: it continues the run of
        alternating steps (the other foot's step lifted ``rhythm_gap_s`` or less before) or starts a
        new one; a jump, a kick or a swing that turned the body ends the run."""
        run = self._run
        if broken:
            run.clear()
            return
        if run and not self._follows_run(foot, lift_t):
            run.clear()
        if not run and not lift_t - self._last_run_lift <= self.config.rhythm_gap_s:
            self._vetoed = False  # a new run of steps after a break in the stepping
        run.append((foot, lift_t))
        self._last_run_lift = lift_t

    def _continues_rhythm(self, foot: int, turn_deg: float) -> bool:
        """Foot ``foot``'s swing is the ``rhythm_steps``-th alternating step in a row."""
        c, run = self.config, self._run
        if (
            c.rhythm_steps == 0
            or self._vetoed
            or len(run) < c.rhythm_steps - 1
            or turn_deg > c.rhythm_turn_deg
        ):
            return False
        return self._follows_run(foot, self._swing_lift[foot])

    def _follows_run(self, foot: int, lift_t: float) -> bool:
        """A step of ``foot`` lifting off at ``lift_t`` follows the run's newest step: the other foot's,
        lifted 0.25 to ``rhythm_gap_s`` seconds before."""
        last_foot, last_lift = self._run[-1]
        return last_foot != foot and 0.25 <= lift_t - last_lift <= self.config.rhythm_gap_s

    def _turned(self, frame: StepFrame) -> float:
        """How far (degrees) the body turned within the last ``turn_window_s``, 0 if unknown."""
        if not math.isfinite(frame.yaw_deg):
            return 0.0
        ys = self._yaws
        ys.append((frame.t, frame.yaw_deg))
        while len(ys) > 1 and ys[1][0] <= frame.t - self.config.turn_window_s:
            ys.popleft()  # keep one entry at or before the window's start
        return abs(frame.yaw_deg - ys[0][1])

    def _step_turn(self, frame: StepFrame, k: int) -> float:
        """How far the body turned (degrees) during foot ``k``'s current or last swing, unwrapped (a
        spin turns more than 180); the tracker's own figure where the yaw was not known."""
        f = frame.feet[k]
        if f.planted or not (math.isfinite(frame.yaw_deg) and math.isfinite(self._lift_yaw[k])):
            return self._last_turn[k] if f.planted else f.turn_deg
        self._last_turn[k] = frame.yaw_deg - self._lift_yaw[k]
        return self._last_turn[k]

    def _start_direction(self, frame: StepFrame, ev: int | None, p: NDArray[np.float64]) -> int:
        """A new bout's direction: a step back from the side steps just before (the way back of an
        opening step to the other side, or a closing step) keeps their side; else the network
        weighted by the evidence."""
        k = frame.stepping
        if ev in (None, _FORWARD) and k >= 0 and self.config.split_memory_s > 0 and self._out_to_side(k):
            return self._side  # the foot out to the side steps back: the way back of the side steps
        side = self._side_evidence(frame, ev)
        if ev is None and self._side != _STILL:
            return self._side
        if ev in (_LEFT, _RIGHT) and side is not None and side != ev:
            return side
        return choose_direction(p, side, self.config)

    def _end(self, reason: str, evidence: str | None) -> GateVerdict:
        self._active = False
        self._label = _STILL
        # A bout that ended in a pause keeps the side of its steps (the next step may be the way
        # back); a broken rhythm keeps the person's own pauses too.
        if reason not in ("rhythm-broke", "network-still"):
            self._forget_side()
        if reason != "rhythm-broke":
            self._intervals.clear()
            self._last_lift_t = self._bout_land_t = math.nan
        self._bout_steps = 0
        self._unknown = False
        if reason != "rhythm-broke":  # the network (or a jump, a crouch, a turn ...) ended it
            self._run.clear()
        if reason == "network-still":  # the network has seen this person step and says stop: no
            self._vetoed = True  # rhythm of the same stepping overrides it (until a new run of steps)
        return GateVerdict(False, _STILL, reason, evidence, self._allowance(), math.nan)

    def update(
        self,
        frame: StepFrame,
        probs: NDArray[np.floating],
        t: float,
        start_probs: NDArray[np.floating] | None = None,
    ) -> GateVerdict:
        """One frame's verdict from its step evidence and the smoothed network probabilities
        (``start_probs``: the legs-only start head's, when the model has one)."""
        c = self.config
        p = np.asarray(probs, dtype=np.float64)
        p_full_still = float(p[_STILL])  # the full-body network's, whichever judge speaks below
        if self._by_head and 1.0 - p[_STILL] >= c.start_prob:
            self._by_head = False  # the full-body network is sure of the bout now
        if frame.crouched:
            self._crouch_t = t
        quiet = t - self._crouch_t < c.start_quiet_s or self._turned_last >= c.start_quiet_deg
        heard = False  # the start head speaks this frame
        if start_probs is not None and c.start_network and not self._active and not quiet:
            s = np.asarray(start_probs, dtype=np.float64)
            if s[_STILL] < p[_STILL]:  # no bout on: the surer of the two judges speaks
                p, heard = s, True
        p_move = float(1.0 - p[_STILL])
        ev = evidence_direction(frame)
        ev_name = ACTIONS[ev] if ev is not None else None
        for k, f in enumerate(frame.feet):
            if f.landed:
                self._land_seen[k] = t
        self._track_slides(frame)
        self._track_kicks(frame)
        jump = [self._jump(frame, k) for k in (0, 1)]
        no_step = [jump[k] or self._kicked[k] for k in (0, 1)]  # swings that are not steps
        landed_steps: list[float] = []  # max p(moving) of bout swings that ended now
        long_landed = False  # a swing that ended now lasted longer than a step's (max_step_swing_s)
        for k, f in enumerate(frame.feet):
            if f.lifted:
                gap = f.event_t - self._last_lift_t if math.isfinite(self._last_lift_t) else math.inf
                if gap <= c.max_interval_s:  # also the pause that broke a bout: the person's rhythm
                    if gap >= c.min_swing_s:
                        self._intervals.append(gap)
                elif not self._active:
                    self._intervals.clear()
                since = f.event_t - self._side_t
                out = self._out_to_side(k) and since <= c.split_memory_s  # the way back is due
                if not self._active and not since <= c.max_interval_s and not out:
                    self._forget_side()  # a side from a bout long over
                self._last_lift_t = f.event_t
                if self._active:
                    self._side_t = f.event_t
                other_lift = self._swing_lift[1 - k]  # NaN: the other foot's last swing has landed
                self._lift_in_air[k] = (
                    not frame.feet[1 - k].planted and other_lift < f.event_t - WELL_BEFORE_S
                    and self._swing_top[1 - k] >= c.start_air_m
                )  # fmt: skip
                self._swing_lift[k], self._swing_maxp[k] = f.event_t, p_move
                self._out_lift[k] = self._out_to_side(k)
                self._lift_yaw[k] = frame.yaw_deg
            elif not f.planted and math.isfinite(self._swing_lift[k]):
                self._swing_maxp[k] = max(self._swing_maxp[k], p_move)
            if f.landed and math.isfinite(f.lateral_m):
                self._home[k] += f.lateral_m
            if f.landed:
                self._opened[k] = f.kind == "open" and abs(f.lateral_m) >= c.split_width_m
                if f.kind == "close":
                    self._opened[1 - k] = False
            if f.landed and math.isfinite(self._swing_lift[k]):
                long_landed = long_landed or f.event_t - self._swing_lift[k] > c.max_step_swing_s
                self._count_rhythm(k, self._swing_lift[k], no_step[k] or abs(f.turn_deg) > c.rhythm_turn_deg)
                if not no_step[k]:
                    if self._active:
                        landed_steps.append(self._swing_maxp[k])
                    if self._active or self._swing_maxp[k] >= c.start_prob:  # a step of this person's
                        self._bout_land_t = f.event_t
                self._swing_lift[k] = math.nan
        swings = [
            k for k, f in enumerate(frame.feet)
            if not f.planted and f.known and not no_step[k] and math.isfinite(self._swing_lift[k])
        ]  # fmt: skip
        turn = [self._step_turn(frame, k) for k in (0, 1)]
        # a step that moved the foot forward or back without turning the body far walks (a curve)
        in_place = not any(
            f.known and abs(f.sagittal_m) >= c.turn_travel_m and abs(turn[k]) <= 2.0 * c.max_turn_deg
            for k, f in enumerate(frame.feet)
        )
        max_turn = c.max_turn_deg * (1.0 if in_place else 2.0)
        stepping = [
            k for k in swings
            if t - self._swing_lift[k] >= c.confirm_s and self._stance_ok(frame, k, p_full_still)
            and abs(turn[k]) <= max_turn
        ]  # fmt: skip
        pivot = any(abs(turn[k]) > max_turn for k in swings)
        turned = self._turned(frame)
        self._turned_last = turned
        if self._active:
            self._bout_steps += len(landed_steps)
        if self._active and self._bout_steps == len(landed_steps) == 1:
            self._first_foot = next((k for k, f in enumerate(frame.feet) if f.landed), -1)
        k0 = self._first_foot
        # the bout's one landed step was in place and the body has turned since its lift-off (the
        # smoothed facing follows the turn a little late): a pivot's first step, not a march's
        first_turned = (
            self._active and self._bout_steps == 1 and not swings and k0 >= 0
            and abs(frame.feet[k0].sagittal_m) < c.turn_travel_m
            and abs(frame.yaw_deg - self._lift_yaw[k0])
            >= max(c.first_turn_deg, c.first_turn_open_deg if frame.feet[k0].kind == "open" else 0.0)
        )  # fmt: skip
        # a march (a forward bout) that starts to turn is steering; side steps that turn the body are
        # turning on the spot
        steering = self._active and self._label == _FORWARD and 0 < c.steer_steps <= self._bout_steps
        # a foot's current swing, or the other's last one, turned the body: the steps are turning it
        swing_turning = bool(swings) and any(
            abs(turn[k]) >= c.swing_turn_deg for k, f in enumerate(frame.feet) if f.known
        )
        # every swing a high march step that has not turned the body: a turn just before has ended
        marching = bool(swings) and all(
            self._swing_top[k] >= c.march_lift_m and abs(turn[k]) < c.swing_turn_deg for k in swings
        )
        if swing_turning and turned > c.max_window_turn_deg and not steering and not marching:
            # steps in place while the body turns this fast: turning on the spot (walking a curve moves
            # the feet forward; an established bout that starts to turn is steering)
            pivot = pivot or in_place
        if self._active and self._label == _FORWARD:
            self._home, self._homing = [0.0, 0.0], (-1, math.nan)  # a march: the side steps' home is here
        self._check_homing(frame)
        jumping = any(not f.planted and jump[k] for k, f in enumerate(frame.feet))
        kicking = any(not f.planted and self._kicked[k] for k, f in enumerate(frame.feet))

        if frame.crouched:
            return self._end("crouched", ev_name)
        if not frame.upright:
            return self._end("not-upright", ev_name)
        if kicking:
            return self._end("kick", ev_name)
        if any(
            not f.planted
            and frame.feet[1 - k].planted
            and self._land_seen[1 - k] < self._swing_lift[k]  # it stood through the whole slide
            and f.sagittal_m <= -c.back_slide_m
            and self._swing_top[k] < c.back_slide_low_m
            for k, f in enumerate(frame.feet)
        ):  # NaN (unknown) compares False
            return self._end("step-back", ev_name)
        if jumping and not (
            self._active and 0 < c.jump_steps <= self._bout_steps and p[_STILL] < c.hold_still_prob
        ):  # an established bout the network is sure of goes on through a flight phase (running)
            return self._end("jump", ev_name)
        if pivot or first_turned:
            return self._end("pivot", ev_name)
        if not self._active:
            if p_full_still > c.run_still_prob:  # unless the full-body network sees a run
                stepping = [k for k in stepping if not self._lift_in_air[k]]
            turning_in_place = (
                not marching
                and turned >= c.start_turn_deg
                and all(abs(frame.feet[k].sagittal_m) < c.start_travel_m for k in stepping)
            )
            sure = bool(stepping) and max(self._swing_maxp[k] for k in stepping) >= c.start_prob
            rhythmic = any(self._continues_rhythm(k, abs(turn[k])) for k in stepping)
            standing_up = t - self._crouch_t < c.kneel_quiet_s and any(
                abs(frame.feet[k].split_m) >= c.kneel_split_m for k in stepping
            )  # NaN (unknown) compares False
            if standing_up:
                return GateVerdict(False, _STILL, "crouched", ev_name, self._allowance(), math.nan)
            if (sure or rhythmic) and not turning_in_place:
                self._unknown = not sure
                self._by_head = sure and heard
                self._active = True
                self._side_t = max(self._swing_lift[k] for k in stepping)  # the bout's first step
                self._label = self._start_direction(frame, ev, p)
                sided = ev in (_LEFT, _RIGHT) or self._label not in (_LEFT, _RIGHT)
                self._unsure_start = math.nan if sided else self._side_t
                self._bout_steps = 0  # landed steps of the bout
                return GateVerdict(True, self._label, self._moving(), ev_name, self._allowance(), math.nan)
            if not all(f.known for f in frame.feet):
                reason = "feet-unknown"
            elif stepping:
                reason = "network-still"
            else:
                reason = "lifting" if swings else "planted"
            return GateVerdict(False, _STILL, reason, ev_name, self._allowance(), math.nan)
        # a bout is on
        if landed_steps and max(landed_steps) >= c.start_prob:
            self._unknown = False  # the network knows these steps now
        if landed_steps and max(landed_steps) < c.stop_prob and not self._unknown:
            return self._end("network-still", ev_name)
        sideways = self._label in (_LEFT, _RIGHT) and self._side != _STILL  # seen stepping sideways
        # a side-step bout turns forward on a landed march step (if the network agrees), not on the
        # rising start of a side step, nor while the other foot steps sideways, nor on the landing of a
        # low rise of a foot that stood out to the side (part of its way back)
        landed = [f.kind for k, f in enumerate(frame.feet) if f.landed and not self._low_way_back(k)]
        sideways_swing = any(not f.planted and f.kind in SIDEWAYS_KINDS for f in frame.feet)
        march_landed = bool(landed) and all(k in ("vertical", "forward") for k in landed) and not long_landed
        if sideways and march_landed and not sideways_swing and choose_direction(p, _FORWARD, c) == _FORWARD:
            self._label = _FORWARD
        if swings:
            k = frame.stepping
            if sideways and any(
                prob < 1
                and p[_FORWARD] >= prob * p_move
                and any(self._swing_top[j] >= lift and frame.feet[j].kind != "open" for j in swings)
                for prob, lift in (
                    (c.march_sure_prob, c.march_lift_m),
                    (c.march_surest_prob, c.march_low_lift_m),
                )
            ):
                # a swing the network is sure marches (a high one, or a low one it is surer of): the
                # march begins on the way back, or from the side step's wide stance
                self._label = _FORWARD
            elif (
                sideways
                and ev == _FORWARD
                and k >= 0
                and c.march_confirm_s <= frame.feet[k].swing_s <= c.max_step_swing_s
                # a foot rising in place, not high, may be the way back of a foot out or the other
                # foot following it: not a march step until it lands
                and not (
                    c.split_memory_s > 0
                    and frame.feet[k].kind == "vertical"
                    and self._swing_top[k] < c.march_lift_m
                    and frame.feet[1 - k].planted
                    and (self._out_to_side(k) or self._opened[1 - k])
                )
            ):
                # a foot up this long without moving sideways is a march step, not a side step's rise
                # (up longer than a step's swing, it is the tracker missing a landing: no march step)
                if choose_direction(p, _FORWARD, c) == _FORWARD:
                    self._label = _FORWARD
            elif (
                stepping and k >= 0 and self._swing_lift[k] == self._unsure_start
                and frame.feet[k].kind in SIDEWAYS_KINDS
            ):  # fmt: skip
                # the bout's first step shows its side only now: read it as a start would have (the
                # way back of the side steps just before keeps their side)
                self._unsure_start = math.nan
                self._label = self._start_direction(frame, ev, p)
            elif stepping and ev is not None and not (sideways and ev == _FORWARD):
                side = self._side_evidence(frame, ev)
                if side == ev or self._label not in (_LEFT, _RIGHT):
                    self._label = choose_direction(p, side, c, self._label)
                # else: the way back of a side step: the bout keeps its side, whatever the network says
            elif (
                c.close_rechoose and stepping and k >= 0 and self._label == _FORWARD
                and frame.feet[k].kind == "close" and self._side != _STILL
            ):  # fmt: skip
                self._label = choose_direction(p, None, c, self._label)
            return GateVerdict(True, self._label, self._moving(), ev_name, self._allowance(), math.nan)
        if math.isnan(self._bout_land_t):
            self._bout_land_t = t
        k = frame.stepping
        split = (
            c.split_hold and k >= 0 and frame.both_planted and frame.feet[k].kind == "open" and not no_step[k]
        )
        if split and p[_STILL] < c.pause_still_prob:
            # a foot out to the side: the way back is due, however long the person pauses before it
            deadline = self._bout_land_t + self._split_allowance(k)
            if t <= deadline + 1e-9:
                return GateVerdict(True, self._label, "pause", ev_name, self._allowance(), deadline)
        deadline = self._bout_land_t + self._allowance()
        if self._unknown:  # the rhythm alone: the next lift-off by the person's usual rhythm
            deadline = self._bout_land_t + self._allowance("median")
            if t > deadline + 1e-9:
                return self._end("rhythm-broke", ev_name)
            return GateVerdict(True, self._label, "rhythm", ev_name, self._allowance(), deadline)
        if t > deadline + 1e-9:
            if p[_STILL] < c.hold_still_prob and t <= self._bout_land_t + c.max_allowance_s + 1e-9:
                # late for the rhythm, but the network is sure the bout goes on: a longer pause
                return GateVerdict(True, self._label, "pause", ev_name, self._allowance(), deadline)
            return self._end("rhythm-broke", ev_name)
        if p[_STILL] >= c.late_still_prob and t > self._bout_land_t + self._allowance("median") + 1e-9:
            return self._end("network-still", ev_name)  # late for the usual rhythm and the network agrees
        if p[_STILL] >= c.pause_still_prob and t - self._bout_land_t >= c.min_pause_s:
            return self._end("network-still", ev_name)  # the network sees the bout has ended
        return GateVerdict(True, self._label, "pause", ev_name, self._allowance(), deadline)
