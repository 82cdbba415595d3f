"""The blind2 script: the plan of a sequence, its stepping bouts and its per-frame ground truth.

A sequence starts with 2.0–2.6 s of standing (sometimes followed by a behaviour), then alternates
stepping bouts with still blocks. A still block is at least 1.5 s of standing with 0–2 behaviours
(``behaviours``), longer when the stepping share so far is above about 54 %. Each bout's kind is
chosen to balance the stepping frames toward 40 % forward, 30 % left, 30 % right, counted over the
whole set (``StepCounts``, shared by the sequences in order); a bout ends at least 1.6 s before the
end of the sequence.

Label rule: a bout is labelled from its first lift-off to its last touch-down frame (inclusive);
marching is ``forward``, side steps the side stepped toward relative to the facing at the bout's
start (the way back of an out-back bout keeps it). Everything else is ``still``, turns and their
pivot steps included. Tags name the bout or behaviour over its frames, ``""`` for plain standing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind2.behaviours import BEHAVIOURS
from pipeline.sim.blind2.body import Body, sample_body
from pipeline.sim.blind2.channels import Balance, Channels, resting_channels, sample_balance
from pipeline.sim.blind2.feet import FootTrack
from pipeline.sim.blind2.geometry import right_vec
from pipeline.sim.blind2.profiles import frames
from pipeline.sim.blind2.stepping import BoutPlan, plan_march, plan_side
from pipeline.sim.blind2.truth import SIDE_KINDS, STILL_BEHAVIOURS, Behaviour, Bout, Turn

STEP_SHARE = {"forward": 0.4, "left": 0.3, "right": 0.3}  # target shares of the stepping frames


@dataclass(slots=True)
class StepCounts:
    """Running counts shared by the sequences of a set, in order: stepping frames per label (to
    balance the bout kinds) and the magnitude band of the next turn."""

    frames: dict[str, int] = field(default_factory=lambda: {"forward": 0, "left": 0, "right": 0})
    turn_band: int = 0


class Planner:
    """Plans one sequence: draws the person, then writes foot events, channels, labels and tags."""

    __slots__ = (
        "balance",
        "behaviours",
        "body",
        "bouts",
        "channels",
        "counts",
        "cur",
        "feet",
        "labels",
        "n_frames",
        "rng",
        "tags",
        "turns",
    )

    def __init__(self, rng: np.random.Generator, n_frames: int, counts: StepCounts) -> None:
        if n_frames < 1:
            raise ValueError(f"n_frames must be at least 1, got {n_frames}")
        self.rng = rng
        self.n_frames = n_frames
        self.body: Body = sample_body(rng)
        self.counts = counts
        yaw0 = rng.uniform(-math.pi, math.pi)
        c = rng.uniform(-0.5, 0.5, 2)
        sw = self.body.stance_width_m
        self.feet = FootTrack((c - right_vec(yaw0) * sw / 2, c + right_vec(yaw0) * sw / 2), (yaw0, yaw0))
        self.cur = 0
        self.labels: NDArray[np.str_] = np.full(n_frames, "still", dtype="<U7")
        self.tags: NDArray[np.str_] = np.full(n_frames, "", dtype="<U18")
        self.bouts: list[Bout] = []
        self.turns: list[Turn] = []
        self.behaviours: list[Behaviour] = []
        self.channels: Channels = resting_channels(rng, n_frames)
        self.balance: Balance = sample_balance(rng)

    # ---- time ----------------------------------------------------------------------------------
    def stand(self, seconds: float) -> None:
        """Stand still for ``seconds`` (to the end at most)."""
        self.cur = min(self.n_frames, self.cur + frames(seconds))

    def tag(self, i0: int, n: int, tag: str) -> None:
        """Record a still behaviour over n frames from i0 and move on past it."""
        i1 = min(self.n_frames, i0 + n)
        self.tags[i0:i1] = tag
        self.behaviours.append(Behaviour(tag, i0, i1 - 1))
        self.cur = i1

    def duration(self, room: int, lo_s: float, hi_s: float) -> int:
        """A random length of lo_s…hi_s seconds, in frames, at most ``room``."""
        d = frames(self.rng.uniform(lo_s, hi_s))
        return min(d, room)

    # ---- the plan ------------------------------------------------------------------------------
    def plan(self, step_target: float = 0.5) -> None:
        """Fill the whole sequence with standing, still blocks and stepping bouts."""
        r = self.rng
        self.stand(r.uniform(2.0, 2.6))
        if r.random() < 0.3:
            self.still_block(first=True)
        step_frames = 0
        while self.n_frames - self.cur > frames(3.0):
            a0 = self.cur
            n = self.bout()
            step_frames += n
            if n == 0:  # nothing fitted: stand instead
                self.still_block()
                if self.cur == a0:
                    break
                continue
            # a still block after the bout, longer when stepping is above its target share
            frac = step_frames / max(self.cur, 1)
            self.still_block(extra=frac > step_target + 0.04)
        self.cur = self.n_frames

    def still_block(self, extra: bool = False, first: bool = False) -> None:
        """At least 1.5 s of standing and/or still behaviours."""
        r = self.rng
        start = self.cur
        nbeh = 0 if (r.random() < 0.2 and not first) else 1
        if extra and r.random() < 0.7:
            nbeh += 1
        self.stand(r.uniform(0.2, 0.8))
        for _ in range(nbeh):
            if self.n_frames - self.cur < frames(3.0):
                break
            self.behaviour()
            self.stand(r.uniform(0.2, 1.0))
        min_len = frames(1.5) if nbeh else frames(r.uniform(1.5, 4.0))
        if self.cur - start < min_len:
            self.cur = min(self.n_frames, start + min_len)

    def behaviour(self) -> None:
        """One random still behaviour (turns weigh 2, weight shifts 1.6, the others 1)."""
        r = self.rng
        names = list(STILL_BEHAVIOURS)
        p = np.array([1.0] * len(names))
        p[names.index("turn")] = 2.0
        p[names.index("weight-shift")] = 1.6
        name = names[r.choice(len(names), p=p / p.sum())]
        room = self.n_frames - self.cur - frames(0.6)
        BEHAVIOURS[name](self, room)

    # ---- stepping bouts ------------------------------------------------------------------------
    def choose_label(self) -> str:
        """The label furthest below its target share of the stepping frames (with a little noise)."""
        r, c = self.rng, self.counts.frames
        tot = c["forward"] + c["left"] + c["right"] + 1
        score = {k: STEP_SHARE[k] - c[k] / tot + r.normal(0, 0.04) for k in STEP_SHARE}
        return max(score, key=lambda k: score[k])

    def bout(self) -> int:
        """Plan and commit one stepping bout (up to 4 tries); its length in frames, 0 if none fitted."""
        r = self.rng
        room_end = self.n_frames - frames(1.6)
        for _attempt in range(4):
            label = self.choose_label()
            snap = self.feet.snapshot()
            if label == "forward":
                res: BoutPlan | None = plan_march(self, self.cur)
            else:
                kind = str(r.choice(list(SIDE_KINDS), p=[0.36, 0.36, 0.28]))
                res = plan_side(self, self.cur, label, kind)
            if res is not None and res.bout.end <= room_end:
                self.commit(res)
                return res.bout.end - res.bout.start + 1
            self.feet.restore(snap)
        return 0

    def commit(self, plan: BoutPlan) -> None:
        """Write a planned bout's labels, tags and channels, and move on past it."""
        bout = plan.bout
        a, b = bout.start, bout.end
        self.labels[a : b + 1] = bout.label
        self.tags[a : b + 1] = bout.tag
        self.counts.frames[bout.label] += b - a + 1
        plan.apply_channels()
        self.bouts.append(bout)
        self.cur = b + 1
