"""Random routines of the gait model: a body stepping, walking and standing about in the CAVE.

``generate_routine(GaitConfig(...), seed)`` draws a body (height and proportions), a
personal style, a start position within ``radius_m`` of the centre facing any direction,
and then behaviours one after another with transitions between them, until
``duration_s`` is filled. Walks and runs first turn (pivot steps) towards a point on the
far side of the centre, so the person stays in the room.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pipeline.sim.gait import standing
from pipeline.sim.gait.anthropometry import Body, BodyConfig, sample_body
from pipeline.sim.gait.kinematics import Ch, forward
from pipeline.sim.gait.stepping import GaitParams, MarchParams, SideParams, gait, march, side_steps
from pipeline.sim.gait.support import Programme, Solved, solve
from pipeline.sim.gait.track import DEG, Style, Track, neutral, sample_style
from pipeline.skeleton import J, SkeletonSequence

SOURCE = "gait"
# Bumped whenever the same seed and settings would give other motion (sets on disk are remade).
MODEL_VERSION = 2

# Behaviour -> relative weight (how often it is chosen).
DEFAULT_MIX: tuple[tuple[str, float], ...] = (
    ("march", 4.0),
    ("side", 4.0),
    ("walk", 0.8),
    ("run", 0.3),
    ("stand", 1.0),
    ("weight-shift", 0.6),
    ("sway", 0.4),
    ("dance", 0.3),
    ("wave", 0.4),
    ("point", 0.3),
    ("stretch", 0.2),
    ("look-around", 0.4),
    ("turn", 0.6),
    ("crouch", 0.4),
    ("squat", 0.3),
    ("kneel", 0.3),
    ("bend", 0.4),
    ("lean", 0.3),
    ("tiptoe", 0.3),
    ("jump", 0.3),
)
BEHAVIOURS = tuple(name for name, _ in DEFAULT_MIX)
SIDE_KINDS = ("side-step-out-back", "step-together", "step-touch", "shuffle")
# Stepping in place and what a person does standing between bouts: marching, side steps out and
# back or step-touch, gestures, turns and looking around (no walking, running or deep postures).
IN_PLACE_MIX: tuple[tuple[str, float], ...] = (
    ("march", 4.0),
    ("side", 4.0),
    ("stand", 1.0),
    ("wave", 0.6),
    ("point", 0.4),
    ("stretch", 0.3),
    ("look-around", 0.5),
    ("turn", 1.0),
    ("weight-shift", 0.4),
)
IN_PLACE_SIDE_KINDS = ("side-step-out-back", "step-touch")


@dataclass(frozen=True, slots=True)
class GaitConfig:
    """What a routine contains. Ranges are (low, high), drawn uniformly per bout."""

    fps: float = 30.0
    duration_s: float = 60.0
    body: BodyConfig = field(default_factory=BodyConfig)
    radius_m: float = 1.0
    mix: tuple[tuple[str, float], ...] = DEFAULT_MIX
    cadence: tuple[float, float] = (0.5, 2.6)  # marching, steps per second
    knee_lift_m: tuple[float, float] = (0.03, 0.30)
    side_width_m: tuple[float, float] = (0.08, 0.45)
    pause_prob: float = 0.25  # chance of a 0.2-1.0 s pause after a step of a bout
    side_kinds: tuple[str, ...] = SIDE_KINDS  # the kinds of side step drawn from
    noise_m: float = 0.0  # Gaussian noise added to every joint coordinate
    dropout: float = 0.0  # share of joints set to NaN

    def __post_init__(self) -> None:
        if not (np.isfinite(self.fps) and 5 <= self.fps <= 240):
            raise ValueError(f"fps must be 5..240, got {self.fps}")
        if not (np.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be positive, got {self.duration_s}")
        unknown = [name for name, _ in self.mix if name not in BEHAVIOURS]
        if unknown:
            raise ValueError(f"unknown behaviours {unknown}; known: {list(BEHAVIOURS)}")
        if not self.side_kinds or any(k not in SIDE_KINDS for k in self.side_kinds):
            raise ValueError(
                f"side_kinds must be a non-empty subset of {list(SIDE_KINDS)}, got {self.side_kinds}"
            )
        if not any(w > 0 for _, w in self.mix) or any(w < 0 for _, w in self.mix):
            raise ValueError("mix weights must be >= 0 with at least one > 0")
        for name in ("cadence", "knee_lift_m", "side_width_m"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                raise ValueError(f"{name} must be a range 0 < low <= high, got {(lo, hi)}")
        if not (0 <= self.pause_prob <= 1 and 0 <= self.dropout < 1 and self.noise_m >= 0):
            raise ValueError("pause_prob in [0, 1], dropout in [0, 1), noise_m >= 0")
        if not self.radius_m >= 0:
            raise ValueError(f"radius_m must be >= 0, got {self.radius_m}")


@dataclass(frozen=True, slots=True)
class GaitTake:
    """A generated routine with everything that made it (for tests and inspection)."""

    body: Body
    style: Style
    programme: Programme
    solved: Solved
    sequence: SkeletonSequence


class _Routine:
    def __init__(self, config: GaitConfig, rng: np.random.Generator) -> None:
        self.config, self.rng = config, rng
        self.body = sample_body(config.body, rng)
        self.style = sample_style(rng)
        r = config.radius_m * np.sqrt(rng.random())
        angle = rng.uniform(0, 2 * np.pi)
        self.start_xy = (float(r * np.cos(angle)), float(r * np.sin(angle)))
        self.track = Track(config.fps, neutral(self.style, rng.uniform(-np.pi, np.pi)))
        names = [n for n, _ in config.mix]
        weights = np.array([w for _, w in config.mix], dtype=float)
        self.names, self.p = names, weights / weights.sum()

    def position(self) -> tuple[np.ndarray, float]:
        """Pelvis (x, y) at the end of the track so far, and the heading."""
        solved = solve(self.body, self.track.build(), self.config.fps, self.start_xy)
        return solved.pelvis[-1, :2], float(self.track.last[Ch.YAW])

    def rest(self) -> None:
        """A transition: back to a (slightly varied) resting pose, maybe a short stand."""
        row = neutral(self.style, float(self.track.last[Ch.YAW]))
        row[Ch.FOOT_YAW_L] = self.track.last[Ch.FOOT_YAW_L]
        row[Ch.FOOT_YAW_R] = self.track.last[Ch.FOOT_YAW_R]
        row[Ch.HEAD_YAW] = self.rng.uniform(-10, 10) * DEG
        self.track.ease(row, self.rng.uniform(0.2, 0.6))
        self.square_up()
        if self.rng.random() < 0.5:
            self.track.hold(self.rng.uniform(0.1, 1.2))

    def square_up(self) -> None:
        """After a walk, a kneel or a turn the feet may stand where the resting angles do not
        put them; the foot that is furthest off steps (lands where the angles say), up to twice."""
        for _ in range(2):
            solved = solve(self.body, self.track.build(), self.config.fps, self.start_xy)
            rel = forward(self.body, self.track.last[None])
            off = [
                float(np.linalg.norm((solved.pelvis[-1] + rel.ankle[0, s] - solved.joints[-1, ankle])[:2]))
                for s, ankle in ((0, J["l_ankle"]), (1, J["r_ankle"]))
            ]
            side = int(np.argmax(off))
            if off[side] < 0.03:
                return
            seconds, lift = self.rng.uniform(0.3, 0.5), self.rng.uniform(0.02, 0.06)
            standing.step(self.track, self.body, side, seconds, lift, self.track.last, tag="")

    def run(self) -> None:
        n_total = round(self.config.duration_s * self.config.fps)
        self.track.hold(self.rng.uniform(0.3, 1.0))
        while len(self.track) < n_total:
            name = str(self.rng.choice(self.names, p=self.p))
            self.behaviour(name)
            self.rest()

    def behaviour(self, name: str) -> None:
        rng, body, track, cfg = self.rng, self.body, self.track, self.config
        if name == "march":
            march(track, body, self.march_params(), rng)
        elif name == "side":
            side_steps(track, body, self.side_params(), rng)
        elif name in ("walk", "run"):
            self.travel(run=name == "run")
        elif name == "stand":
            track.hold(rng.uniform(0.5, 3.0))
        elif name in ("weight-shift", "dance"):
            standing.weight_shift(track, body, rng, dance=name == "dance")
        elif name == "sway":
            standing.sway(track, body, rng)
        elif name in ("wave", "point", "stretch"):
            standing.arms(track, rng, name)
        elif name == "look-around":
            standing.look_around(track, rng)
        elif name == "turn":
            standing.turn(track, body, rng)
        elif name in ("crouch", "squat"):
            standing.crouch(track, rng, deep=name == "squat")
        elif name == "kneel":
            standing.kneel(track, body, rng)
        elif name == "bend":
            standing.bend(track, rng)
        elif name == "lean":
            standing.lean(track, body, rng)
        elif name == "tiptoe":
            standing.tiptoe(track, body, rng)
        elif name == "jump":
            standing.jump(track, body, rng)
        else:  # pragma: no cover - GaitConfig checks the names
            raise ValueError(f"unknown behaviour {name!r}")
        del cfg

    def march_params(self) -> MarchParams:
        rng, cfg = self.rng, self.config
        cadence = rng.uniform(*cfg.cadence)
        return MarchParams(
            cadence=cadence,
            knee_lift_m=rng.uniform(*cfg.knee_lift_m),
            steps=int(rng.integers(2, 21)),
            lead=int(rng.integers(2)),
            swing_share=rng.uniform(0.55, 0.85),
            knee_extra=rng.uniform(0, 35) * DEG,
            arm_swing=(rng.uniform(10, 40) if rng.random() < 0.65 else rng.uniform(0, 4)) * DEG,
            asymmetry=rng.uniform(0, 0.35) if rng.random() < 0.4 else 0.0,
            irregularity=rng.uniform(0, 0.25),
            pause_prob=cfg.pause_prob,
            sway_m=rng.uniform(0.0, 0.05),
            hike=rng.uniform(0, 4) * DEG,
            toe_off=-rng.uniform(0, 20) * DEG,
            land_pitch=-rng.uniform(0, 10) * DEG if rng.random() < 0.5 else 0.0,
        )

    def side_params(self) -> SideParams:
        rng, cfg = self.rng, self.config
        kind = str(rng.choice(cfg.side_kinds))
        direction = int(rng.integers(2))
        width = rng.uniform(*cfg.side_width_m)
        cycles = int(rng.integers(1, 7))
        if kind in ("step-together", "shuffle"):
            # Travelling sideways: go the way that stays in the room, and not too far.
            cycles = min(cycles, max(1, int(1.2 / width)))
            pos, yaw = self.position()
            right = np.array([np.cos(yaw), np.sin(yaw)])
            ahead = pos + right * (1 if direction == 1 else -1) * width * cycles
            if np.linalg.norm(ahead) > cfg.radius_m + 0.6:
                direction = 1 - direction
        return SideParams(
            direction=direction,
            kind=kind,
            width_m=width,
            cycles=cycles,
            swing_s=rng.uniform(0.25, 0.6),
            dwell_s=rng.uniform(0.05, 0.5),
            lift_m=rng.uniform(0.02, 0.12),
            sway_m=rng.uniform(0.0, 0.04),
            weight_share=rng.uniform(0.0, 0.5),
            pause_prob=cfg.pause_prob,
            touch_pitch=-rng.uniform(5, 30) * DEG,
        )

    def travel(self, run: bool) -> None:
        """Turn towards a point across the room, then walk or run there."""
        rng, cfg = self.rng, self.config
        pos, yaw = self.position()
        target = -pos / max(np.linalg.norm(pos), 1e-6) * rng.uniform(0.3, 1.0) * max(cfg.radius_m, 0.3)
        if np.linalg.norm(pos) < 0.3:
            angle = rng.uniform(0, 2 * np.pi)
            target = pos + np.array([np.cos(angle), np.sin(angle)]) * rng.uniform(0.8, 1.5)
        heading = float(np.arctan2(-(target - pos)[0], (target - pos)[1]))  # yaw 0 faces +Y
        delta = (heading - yaw + np.pi) % (2 * np.pi) - np.pi
        if abs(delta) > 20 * DEG:
            standing.turn(self.track, self.body, rng, angle=delta)
            self.rest()
        distance = float(np.linalg.norm(target - pos))
        cadence = rng.uniform(2.6, 3.2) if run else rng.uniform(1.4, 2.2)
        scale = rng.uniform(0.6, 1.0) if run else rng.uniform(0.5, 1.15)
        lead = int(rng.integers(2))
        # The shortest bout (ramps in and out) with shorter strides if it would overshoot much.
        probe_len = self._travel_length(GaitParams(cadence, scale, 0, run, self.style.arm_swing, lead))
        if probe_len > distance + 0.25:
            scale = max(0.3, scale * (distance + 0.25) / probe_len)
        params = GaitParams(cadence, scale, 0, run, self.style.arm_swing, lead)
        # Grow the bout by whole strides while it still fits the distance.
        for cycles in range(1, 4):
            trial = GaitParams(cadence, scale, cycles, run, self.style.arm_swing, lead)
            if self._travel_length(trial) > distance + 0.25:
                break
            params = trial
        gait(self.track, self.body, params)

    def _travel_length(self, params: GaitParams) -> float:
        probe = Track(self.config.fps, self.track.last)
        gait(probe, self.body, params)
        solved = solve(self.body, probe.build(), self.config.fps)
        return float(np.linalg.norm(solved.pelvis[-1, :2] - solved.pelvis[0, :2]))


def simulate_routine(config: GaitConfig, seed: int) -> GaitTake:
    """A random routine and everything that made it."""
    rng = np.random.default_rng(seed)
    routine = _Routine(config, rng)
    routine.run()
    n = round(config.duration_s * config.fps)
    full = routine.track.build()
    prog = Programme(
        full.angles[:n], full.contact[:n], full.slide[:n], full.home[:n], full.labels[:n], full.tags[:n]
    )
    solved = solve(routine.body, prog, config.fps, routine.start_xy)
    joints = solved.joints.copy()
    if config.noise_m > 0:
        joints += rng.normal(0.0, config.noise_m, joints.shape)
    if config.dropout > 0:
        joints[rng.random(joints.shape[:2]) < config.dropout] = np.nan
    seq = SkeletonSequence(
        joints, config.fps, prog.labels, prog.tags, prog.contact.copy(), SOURCE
    )
    return GaitTake(routine.body, routine.style, prog, solved, seq)


def generate_routine(config: GaitConfig, seed: int) -> SkeletonSequence:
    """A random routine as a SPEC skeleton sequence with labels, tags and contacts."""
    return simulate_routine(config, seed).sequence
