"""The stepping-bout gate on hand-made skeletons with known contacts and a network whose output
is given: one command per bout through the pauses, the rhythm's end, no movement while both feet
stay planted, jumps, crouches, the network's veto, and the direction from the evidence."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pipeline.recognition.bout import BoutGate, GateConfig, choose_direction
from pipeline.recognition.steps import FootState, StepFrame, StepTracker
from pipeline.skeleton import ACTIONS

from .kinematic import ANKLES, Scene, Swing, kick, march, noisy, render

FPS = 30.0
S, F, L, R = 0, 1, 2, 3
FWD = np.array([0.1, 0.7, 0.1, 0.1])  # a network sure it is forward movement


def _gate(
    scene: Scene, probs: np.ndarray | list[np.ndarray], sigma: float = 0.012, config: GateConfig | None = None
):  # type: ignore[no-untyped-def]
    joints, contacts = render(scene)
    tr, gate = StepTracker(), BoutGate(config)
    out = []
    for i, frame in enumerate(noisy(joints, sigma, 0.02)):
        sf = tr.update(frame, i / FPS)
        p = probs[i] if isinstance(probs, list) else probs
        out.append(gate.update(sf, p, i / FPS))
    return np.array([v.label for v in out]), out, contacts


RHYTHM_ONLY = GateConfig(hold_still_prob=0.0)  # the rhythm rule alone (FWD never says still)


def test_a_slow_bout_is_one_command_through_its_pauses() -> None:
    swings = march(1.0, 10, 1.0, 0.4)  # 0.6 s both feet down between steps
    labels, verdicts, _ = _gate(Scene(13.0, swings), FWD, config=RHYTHM_ONLY)
    t = np.arange(len(labels)) / FPS
    first_lift, last_land = swings[0].t0, swings[-1].t1
    inside = (t > first_lift + 0.3) & (t < last_land)
    after_second = t > swings[1].t0 + 0.3  # the rhythm is known from the second step on
    assert (labels[inside & after_second] == F).all(), "held through every pause once the rhythm is known"
    assert (labels[inside] == F).mean() > 0.95
    assert (labels[t < first_lift] == S).all()
    stop = t[(t > last_land) & (labels == S)][0] - last_land
    # due one interval (1.0 s) x 1.1 after the last lift-off, + 0.15 s: 0.85 s after the touch-down
    assert stop < 1.0 * 1.1 + 0.15 - 0.4 + 0.1, f"stopped {stop:.2f} s after the last touch-down"
    changes = int(np.sum(labels[1:] != labels[:-1]))
    assert changes <= 4, f"{changes} command changes for one bout"
    assert {v.reason for v in verdicts} >= {"planted", "stepping", "pause", "rhythm-broke"}


def _with_one_long_pause(n_after: int) -> tuple[Swing, ...]:
    """A march every 0.6 s (0.3 s swings), one 0.9 s pause after the 4th step, then ``n_after`` steps."""
    return march(1.0, 4, 0.6, 0.3) + march(1.0 + 3 * 0.6 + 1.2, n_after, 0.6, 0.3)


def test_a_longer_pause_holds_while_the_network_is_sure_the_bout_goes_on() -> None:
    swings = _with_one_long_pause(4)
    t_pause = (swings[3].t1, swings[4].t0)
    for config, commands in ((GateConfig(), 1), (RHYTHM_ONLY, 2)):
        labels, _, _ = _gate(Scene(8.0, swings), FWD, config=config)
        t = np.arange(len(labels)) / FPS
        held = labels[(t > t_pause[0]) & (t < t_pause[1])]
        runs = int(np.sum((labels[1:] != S) & (labels[:-1] == S)))
        assert runs == commands, (
            f"{config.hold_still_prob=}: {runs} commands for a bout with a 0.9 s pause "
            f"(held {np.mean(held == F):.0%} of the pause)"
        )


def test_a_stop_after_an_irregular_bout_comes_at_the_usual_rhythm_when_the_network_agrees() -> None:
    # after the long pause the longest of the last three intervals is 1.2 s, the median 0.6 s
    swings = _with_one_long_pause(2)
    last_land = swings[-1].t1
    n = round(8.0 * FPS)
    stopping = np.array([0.5, 0.3, 0.1, 0.1])  # the network leaning to still, not sure (< 0.75)
    probs = [FWD if i / FPS < last_land else stopping for i in range(n + 1)]
    stops = {}
    for name, config in (
        ("default", GateConfig()),
        ("longest interval only", GateConfig(late_still_prob=1.0)),
    ):
        labels, _, _ = _gate(Scene(8.0, swings), probs, config=config)
        t = np.arange(len(labels)) / FPS
        stops[name] = t[(t > last_land) & (labels == S)][0] - last_land
    # due 0.6 s after the last lift-off (0.3 s after the touch-down) + 0.2 s margin + tracker delay
    assert stops["default"] <= 0.3 + 0.2 + 0.2, stops
    assert stops["longest interval only"] > stops["default"] + 0.3, stops


def test_the_bout_ends_when_the_rhythm_breaks() -> None:
    swings = march(1.0, 12, 0.5, 0.32)  # a brisk march, then standing
    labels, _, _ = _gate(Scene(10.0, swings), FWD, config=RHYTHM_ONLY)
    t = np.arange(len(labels)) / FPS
    start = t[labels == F][0] - swings[0].t0
    stop = t[(t > swings[-1].t1) & (labels == S)][0] - swings[-1].t1
    assert start <= 0.3, f"start {start:.2f} s after the first lift-off"
    assert stop <= 0.5, f"stop {stop:.2f} s after the last touch-down (pauses of 0.18 s)"
    assert (labels[(t > swings[1].t0) & (t < swings[-1].t1)] == F).all()


@pytest.mark.parametrize(
    "scene",
    [
        Scene(8.0, crouch=((1.0, 6.0, 0.4),)),  # crouch and stand up
        Scene(6.0, jumps=((1.0, 1.4, 0.15), (3.0, 3.35, 0.1))),  # jump landings
        Scene(8.0, wave=True),  # gestures with planted feet
        Scene(8.0, heel_rise=((1.0, 6.0, 0.06),)),  # tiptoes
    ],
    ids=["crouch", "jump", "wave", "tiptoe"],
)
def test_no_movement_while_the_feet_stay_planted_or_move_together(scene: Scene) -> None:
    labels, _, _ = _gate(scene, FWD)  # even with a network sure it is moving
    assert (labels == S).all(), f"moving in {np.mean(labels != S):.1%} of frames"


STILL_NET = np.array([0.95, 0.03, 0.01, 0.01])  # a network sure the person stands still


def test_the_network_vetoes_steps_it_does_not_call_movement() -> None:
    """Two steps the network calls still are no bout; without the rhythm rule, neither is a march."""
    labels, verdicts, _ = _gate(Scene(4.0, march(1.0, 2, 0.6, 0.35)), STILL_NET)
    assert (labels == S).all()
    assert "network-still" in {v.reason for v in verdicts}
    labels, _, _ = _gate(Scene(7.0, march(1.0, 8, 0.6, 0.35)), STILL_NET, config=GateConfig(rhythm_steps=0))
    assert (labels == S).all()


def test_a_rhythm_of_alternating_steps_is_a_bout_even_when_the_network_does_not_know_it() -> None:
    """A low march (the feet rise 5 cm) that the network calls still: from the third alternating
    step on, the rhythm alone is a forward bout, held through the steps, ended by the person's own
    rhythm (the network's stops do not apply), and the count starts anew after it."""
    swings = march(1.0, 8, 0.6, 0.35, peak=0.05)
    labels, verdicts, _ = _gate(Scene(8.0, swings), STILL_NET)
    t = np.arange(len(labels)) / FPS
    third = swings[2]
    start = t[labels == F][0]
    assert third.t0 + 0.1 <= start <= third.t0 + 0.35, (
        f"started at {start:.2f} s, third lift-off {third.t0} s"
    )
    assert (labels[(t > third.t0 + 0.35) & (t < swings[-1].t1)] == F).all()
    assert (labels[t < third.t0] == S).all()
    stop = t[(t > swings[-1].t1) & (labels == S)][0] - swings[-1].t1
    # the next lift-off was due 0.6 s after the last one, 0.25 s after its touch-down, + 0.2 s
    assert stop <= 0.6 - 0.35 + 0.2 + 0.15, f"stopped {stop:.2f} s after the last touch-down"
    assert {v.reason for v in verdicts if v.active} == {"rhythm"}, "the step strip says why it moves"


@pytest.mark.parametrize("per_step_deg", [10.0, 20.0])
def test_turning_steps_the_network_calls_still_are_no_rhythm(per_step_deg: float) -> None:
    """Alternating pivot steps of a turn on the spot (each turning the body) that the network calls
    still never start a bout, however many there are."""
    swings = march(1.0, 8, 0.6, 0.35, peak=0.04)
    joints, _ = _turned(Scene(7.0, swings), per_step_deg)
    assert (_gate_joints(joints, STILL_NET) == S).all()


def test_a_confident_start_then_a_still_network_for_a_whole_swing_ends_the_bout() -> None:
    swings = march(1.0, 8, 0.6, 0.35)
    n = round(7.0 * FPS)
    probs = [FWD if i / FPS < 2.0 else np.array([0.97, 0.01, 0.01, 0.01]) for i in range(n)]
    labels, _, _ = _gate(Scene(7.0, swings), probs)
    t = np.arange(n) / FPS
    assert (labels[(t > 1.4) & (t < 2.0)] == F).all() and (labels[t > 3.5] == S).all()


@pytest.mark.parametrize(("foot", "side", "want"), [(0, -1.0, L), (1, 1.0, R)])
def test_the_opening_foot_gives_the_side_and_the_closing_step_keeps_it(
    foot: int, side: float, want: int
) -> None:
    swings = []
    for i in range(4):  # step-together: the leading foot opens, the trailing foot follows
        t0 = 1.0 + 1.0 * i
        swings.append(Swing(foot, t0, t0 + 0.4, lateral=0.3 * side, peak=0.05))
        swings.append(Swing(1 - foot, t0 + 0.5, t0 + 0.9, lateral=0.3 * side, peak=0.03))
    unsure = np.array([0.1, 0.4, 0.25, 0.25])  # a network leaning to forward
    labels, _, _ = _gate(Scene(6.5, tuple(swings), yaw_deg=70.0), unsure)
    moving = labels[labels != S]
    assert (moving == want).mean() > 0.9, f"{ACTIONS[want]}: {np.bincount(moving, minlength=4)}"
    off = _gate(Scene(6.5, tuple(swings), yaw_deg=70.0), unsure, config=GateConfig(evidence_direction=False))[
        0
    ]
    assert (off[off != S] == F).mean() > 0.9, "without the evidence the network's lean wins"


def test_choose_direction_and_config_checks() -> None:
    p = np.array([0.2, 0.5, 0.2, 0.1])
    assert choose_direction(p, None, GateConfig()) == F
    assert choose_direction(p, L, GateConfig()) == L
    assert choose_direction(p, R, GateConfig(evidence_direction=False)) == F
    with pytest.raises(ValueError, match="start_prob"):
        GateConfig(start_prob=1.5)
    with pytest.raises(ValueError, match="min_allowance_s"):
        GateConfig(min_allowance_s=2.0, max_allowance_s=1.0)
    with pytest.raises(ValueError, match="side_switch_steps"):
        GateConfig(side_switch_steps=0)
    with pytest.raises(ValueError, match="travel_steps"):
        GateConfig(travel_steps=0)
    with pytest.raises(ValueError, match="first_turn_deg"):
        GateConfig(first_turn_deg=0.0)
    with pytest.raises(ValueError, match="first_turn_open_deg"):
        GateConfig(first_turn_open_deg=-1.0)
    for name in ("split_allowance_s", "split_width_m", "split_memory_s", "kneel_quiet_s", "kneel_split_m"):
        for bad in (-0.1, float("nan"), float("inf")):
            with pytest.raises(ValueError, match=name):
                GateConfig(**{name: bad})
    with pytest.raises(ValueError, match="rise_wait_s"):
        GateConfig(rise_wait_s=-0.1)
    with pytest.raises(ValueError, match="rise_lead_m"):
        GateConfig(rise_lead_m=float("nan"))
    for bad in (-0.01, float("nan")):
        with pytest.raises(ValueError, match="way_back_m must be >= 0"):
            GateConfig(way_back_m=bad)
    assert GateConfig(way_back_m=float("inf")).way_back_m == float("inf")  # inf: the rule off
    with pytest.raises(ValueError, match="run_swing_s"):
        GateConfig(run_swing_s=-0.1)
    with pytest.raises(ValueError, match="run_still_prob"):
        GateConfig(run_still_prob=1.2)
    assert GateConfig(run_swing_s=float("inf")).run_swing_s == float("inf")  # inf: no limit


def test_a_foot_still_up_long_after_the_other_landed_is_a_step_not_a_jump() -> None:
    # both feet leave together (the tracker's jump sign), but the left lands at 1.25 s while the
    # right stays up until 2.0 s: no two-footed jump lands like that (running, a missed touch-down)
    swings = (Swing(0, 1.0, 1.25, peak=0.12), Swing(1, 1.0, 2.0, peak=0.25), *march(2.4, 4, 0.6, 0.3))
    for air, moves_early in ((0.3, True), (float("inf"), False)):
        labels, verdicts, _ = _gate(Scene(6.0, swings), FWD, config=GateConfig(jump_air_s=air))
        t = np.arange(len(labels)) / FPS
        early = (t > 1.5) & (t < 2.0)  # the left has landed (~1.4 s), the right is still up
        assert bool((labels[early] == F).any()) is moves_early, (
            f"{air=}: {[v.reason for v, e in zip(verdicts, early, strict=True) if e]}"
        )


def _step_touch(foot: int, side: float, t0: float, cycles: int) -> list[Swing]:
    """A step-touch that returns: the leading foot opens, the trailing foot joins it, then the
    trailing foot steps back out to the other side (the way back) and the leading foot closes up."""
    out = []
    for c in range(cycles):
        t = t0 + 2.4 * c
        out += [
            Swing(foot, t, t + 0.4, lateral=0.3 * side, peak=0.05),
            Swing(1 - foot, t + 0.6, t + 1.0, lateral=0.3 * side, peak=0.04),
            Swing(1 - foot, t + 1.2, t + 1.6, lateral=-0.3 * side, peak=0.04),
            Swing(foot, t + 1.8, t + 2.2, lateral=-0.3 * side, peak=0.05),
        ]
    return out


@pytest.mark.parametrize(("foot", "side", "want", "other"), [(1, 1.0, R, L), (0, -1.0, L, R)])
def test_the_way_back_of_a_side_step_keeps_its_side(foot: int, side: float, want: int, other: int) -> None:
    """Half the steps of a returning step-touch open to the other side; the bout is one command to
    the side it leads with, even while the network reads the way back as the other side."""
    swings = _step_touch(foot, side, 1.0, 3)
    n = round(9.0 * FPS)
    lead = np.full(4, 0.04)
    lead[want] = 0.88
    back = np.full(4, 0.04)
    back[other] = 0.88  # the network sure the way back is the other side
    t = np.arange(n) / FPS
    in_back = np.zeros(n, dtype=bool)
    for s in swings[2::4]:
        in_back |= (t >= s.t0) & (t < s.t0 + 1.0)
    probs = [back if in_back[i] else lead for i in range(n)]
    labels, _, _ = _gate(Scene(9.0, tuple(swings), yaw_deg=-40.0), probs)
    bout = labels[(t > swings[0].t0 + 0.3) & (t < swings[-1].t1)]
    assert (bout == want).mean() > 0.9, f"{ACTIONS[want]} bout: {np.bincount(bout, minlength=4)}"
    assert not (bout == other).any(), "the way back never turns the command to the other side"


def test_side_steps_that_change_side_turn_the_bout() -> None:
    """Out-and-back steps of the right foot, then of the left foot, in one bout: after two steps out
    to the right, the first step out to the left turns the command left at once; after a single
    step out to the right, the first step left may be the way back and the second one turns it."""
    out_back = [1.0 if i % 2 == 0 else -1.0 for i in range(6)]
    unsure = np.array([0.1, 0.3, 0.3, 0.3])
    for n_right, late in ((4, False), (2, True)):
        firsts = out_back[:n_right]
        right = [Swing(1, 1.0 + 0.9 * i, 1.4 + 0.9 * i, lateral=0.3 * b) for i, b in enumerate(firsts)]
        t0 = right[-1].t1 + 0.5
        left = [Swing(0, t0 + 0.9 * i, t0 + 0.4 + 0.9 * i, lateral=-0.3 * b) for i, b in enumerate(out_back)]
        t_left = t0
        duration = left[-1].t1 + 1.5
        t = np.arange(round(duration * FPS)) / FPS
        labels, _, _ = _gate(Scene(duration, tuple(right + left)), unsure)
        assert (labels[(t > 1.3) & (t < t_left)] == R).mean() > 0.9
        turn = left[2].t0 if late else left[0].t0
        assert (labels[(t > turn + 0.3) & (t < left[-1].t1)] == L).mean() > 0.9, f"{n_right} steps right"
        if late:
            assert (labels[(t > left[0].t0 + 0.3) & (t < turn)] == R).mean() > 0.9, "one step late"


def _turned(
    scene: Scene, per_step_deg: float, from_step: int = 0, to_step: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The scene's joints, the whole body turning about the vertical by ``per_step_deg`` during each
    swing from the ``from_step``-th on (to the ``to_step``-th, excluded), about the planted foot
    (which stays where it is)."""
    joints, contacts = render(scene)
    t = np.arange(len(joints)) / FPS
    yaw = np.zeros(len(joints))
    for sw in scene.swings[from_step:to_step]:
        yaw += np.radians(per_step_deg) * np.clip((t - sw.t0) / (sw.t1 - sw.t0), 0.0, 1.0)
    rot, shift = np.eye(2), np.zeros(2)  # world = rot @ body + shift
    out = joints.copy()
    for i in range(len(joints)):
        d = yaw[i] - yaw[i - 1] if i else 0.0
        if d:
            stance = ANKLES[0] if contacts[i, 0] else ANKLES[1]
            pivot = rot @ joints[i - 1, stance, :2] + shift  # the planted ankle, where it stands
            c, s_ = np.cos(d), np.sin(d)
            r = np.array([[c, -s_], [s_, c]])
            rot, shift = r @ rot, r @ (shift - pivot) + pivot
        out[i, :, :2] = joints[i, :, :2] @ rot.T + shift
    return out, yaw


def _gate_joints(joints: np.ndarray, probs: np.ndarray, config: GateConfig | None = None) -> np.ndarray:
    tr, gate = StepTracker(), BoutGate(config)
    return np.array(
        [gate.update(tr.update(f, i / FPS), probs, i / FPS).label for i, f in enumerate(noisy(joints, 0.01))]
    )


INF = float("inf")
# the lone first step's turn rule only
NO_WINDOW_RULE = GateConfig(max_window_turn_deg=INF, start_turn_deg=INF, max_turn_deg=INF)
NO_TURN_RULE = GateConfig(max_window_turn_deg=INF, first_turn_deg=INF, start_turn_deg=INF)  # no turning rule


def test_rhythmic_pivot_steps_that_turn_the_body_are_still() -> None:
    """A turn on the spot in small pivot steps (each swing turning the body 20 degrees, less than the
    one-swing pivot rule's 30) is no movement, even with a network sure it is forward; without the
    turning rule the same steps are a forward bout."""
    swings = march(1.0, 8, 0.6, 0.35)  # 160 degrees in 4.6 s
    joints, _ = _turned(Scene(7.0, swings), 20.0)
    t = np.arange(len(joints)) / FPS
    during = (t > swings[0].t0) & (t < swings[-1].t1 + 0.5)
    labels = _gate_joints(joints, FWD)
    assert (labels[during] != S).mean() < 0.1, f"{100 * (labels[during] != S).mean():.0f} % moving"
    assert (_gate_joints(joints, FWD, NO_TURN_RULE)[during] == F).mean() > 0.6, "the rule is what stops it"


def test_a_march_that_starts_to_turn_steers_and_a_walk_on_a_curve_goes_on() -> None:
    """Marching that turns after four straight steps is steering: one forward bout throughout (a
    bout of fewer than ``steer_steps`` steps would end). Walking a curve moves the feet forward
    with every step: not a turn on the spot, however fast the body turns."""
    swings = march(1.0, 12, 0.6, 0.35)
    joints, _ = _turned(Scene(9.0, swings), 12.0, from_step=4)  # then 20 degrees/s
    t = np.arange(len(joints)) / FPS
    inside = (t > swings[0].t0 + 0.3) & (t < swings[-1].t1)
    assert (_gate_joints(joints, FWD)[inside] == F).mean() > 0.95
    assert (_gate_joints(joints, FWD, GateConfig(steer_steps=0))[inside] == F).mean() < 0.7
    walk = tuple(Swing(i % 2, 1.0 + 0.5 * i, 1.4 + 0.5 * i, sagittal=0.6, peak=0.08) for i in range(10))
    joints, _ = _turned(Scene(7.0, walk), 15.0)  # 37 degrees/s, from the first step
    t = np.arange(len(joints)) / FPS
    inside = (t > walk[0].t0 + 0.3) & (t < walk[-1].t1)
    assert (_gate_joints(joints, FWD)[inside] == F).mean() > 0.9
    sharp, _ = _turned(Scene(7.0, walk), 35.0)  # each step turns more than a pivot step in place may
    assert (_gate_joints(sharp, FWD)[inside] == F).mean() > 0.9
    assert (_gate_joints(sharp, FWD, GateConfig(turn_travel_m=10.0))[inside] == F).mean() < 0.3
    in_place = GateConfig(turn_travel_m=10.0)  # every step read as in place: the walk is a turn
    assert (_gate_joints(joints, FWD, in_place)[inside] == F).mean() < 0.7


def test_the_turning_rule_checks_its_settings() -> None:
    for bad in (
        {"turn_window_s": -1.0},
        {"max_window_turn_deg": 0.0},
        {"steer_steps": -1},
        {"slide_step_m": -0.1},
        {"jump_rise_s": float("nan")},
        {"march_lift_m": 0.0},
        {"march_lift_m": float("nan")},
        {"rhythm_steps": 1},
        {"rhythm_gap_s": 0.0},
    ):
        with pytest.raises(ValueError, match=next(iter(bad))):
            GateConfig(**bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("stay_s", [1.3, 2.5])
def test_a_one_step_side_bout_keeps_its_side_for_the_way_back_after_a_pause(stay_s: float) -> None:
    """The right foot steps out to the right and stays there 1.3 or 2.5 s: with no rhythm of the
    person's yet the split stance holds ``max_allowance_s`` and the bout ends; the way back is a new
    bout to the right, even with a network that reads it as a step to the left (the side of a foot
    standing out is kept for its way back, ``split_memory_s``, also after more than
    ``max_interval_s``)."""
    out = Swing(1, 1.0, 1.4, lateral=0.3, peak=0.05)
    back = Swing(1, 1.4 + stay_s, 1.8 + stay_s, lateral=-0.3, peak=0.05)
    duration = back.t1 + 1.4
    n = round(duration * FPS)
    t = np.arange(n) / FPS
    lead, wrong = np.array([0.1, 0.05, 0.05, 0.8]), np.array([0.1, 0.1, 0.7, 0.1])
    probs = [wrong if t[i] > back.t0 - 0.2 else lead for i in range(n)]
    labels, verdicts, _ = _gate(Scene(duration, (out, back)), probs)
    assert (labels[(t > 1.2) & (t < 1.4)] == R).all()
    reasons = {v.reason for v in verdicts[round(1.4 * FPS) : round(back.t0 * FPS)]}
    assert "rhythm-broke" in reasons, reasons
    way_back = labels[(t > back.t0 + 0.2) & (t < back.t1)]
    assert (way_back == R).mean() > 0.9, f"way back: {np.bincount(way_back, minlength=4)}"
    if stay_s > 2.2:  # lift-offs 2.9 s apart, more than max_interval_s: without the foot's memory
        # the side is forgotten
        forgot, _, _ = _gate(Scene(duration, (out, back)), probs, config=GateConfig(split_memory_s=0.0))
        assert (forgot[(t > back.t0 + 0.2) & (t < back.t1)] != R).any()


def test_a_step_over_a_sliding_stance_is_no_jump() -> None:
    """Walking on a treadmill (or a march whose stance foot slides back): the stance foot slides
    back along the floor while the other swings forward, lifted 10 cm. Both leave "contact" together,
    which the tracker calls a jump; the gate reads a foot that stays low for ``jump_rise_s`` while
    the other clearly rises as a step over a sliding stance, not a jump."""
    swings = []
    for i in range(10):
        t0, f = 1.0 + 0.6 * i, i % 2
        swings += [
            Swing(f, t0, t0 + 0.4, sagittal=0.3, peak=0.1),
            Swing(1 - f, t0, t0 + 0.5, sagittal=-0.3, peak=0.0),
        ]
    t = np.arange(round(8.0 * FPS)) / FPS
    walking = (t > 1.5) & (t < 7.0)
    labels, _, _ = _gate(Scene(8.0, tuple(swings)), FWD)
    jump_only, verdicts, _ = _gate(
        Scene(8.0, tuple(swings)), FWD, config=GateConfig(slide_step_m=float("inf"))
    )
    assert (labels[walking] == F).mean() > 0.5
    assert (jump_only[walking] == F).mean() < 0.1, "without the rule the slides are jumps"
    assert "jump" in {v.reason for v in verdicts}


def test_a_run_goes_on_through_a_flight_the_tracker_reads_as_a_jump() -> None:
    """Running in place: swings of 0.45 s every 0.35 s, and once a foot lifts only 0.1 s after the
    other (a skip): the tracker sees both feet take off together, a jump. An established bout (four
    landed steps) that the network is sure of goes on; a jump from standing still ends nothing it
    has not started (the jump scenes above)."""
    swings, t = [], 1.0
    for i in range(12):
        swings.append(Swing(i % 2, t, t + 0.45, peak=0.15))
        t += 0.1 if i == 6 else 0.35
    scene = Scene(t + 1.5, tuple(swings))
    sure = np.array([0.02, 0.94, 0.02, 0.02])
    labels, _, _ = _gate(scene, sure)
    always_ends, old, _ = _gate(scene, sure, config=GateConfig(jump_steps=0))
    tt = np.arange(len(labels)) / FPS
    inside = (tt > swings[0].t0 + 0.3) & (tt < swings[-1].t1)
    assert (labels[inside] == F).all()
    assert "jump" in {v.reason for v in old}, "the skip is a jump to the tracker"
    assert (always_ends[inside] == F).mean() < 0.9
    with pytest.raises(ValueError, match="jump_steps"):
        GateConfig(jump_steps=-1)


def test_a_lone_first_step_that_turned_the_body_is_no_bout() -> None:
    """A slow turn on the spot: single pivot steps 1.2 s apart, each turning the body 8 degrees (too
    little for the turning rule's 10 degrees in 0.7 s). Each step alone started a bout that the first
    step's hold kept for 0.8 s; once the body has turned 7 degrees since a bout's lone first step
    (in place), the bout ends. A march's first step (no turn) keeps its hold."""
    swings = march(1.0, 5, 1.2, 0.4)
    joints, _ = _turned(Scene(8.0, swings), 8.0)
    t = np.arange(len(joints)) / FPS
    after = np.zeros(len(t), dtype=bool)
    for sw in swings:
        after |= (t > sw.t1 + 0.5) & (t < sw.t0 + 1.2)  # from 0.5 s after each touch-down to the next lift
    labels = _gate_joints(joints, FWD)
    held = _gate_joints(joints, FWD, GateConfig(first_turn_deg=float("inf")))
    assert (labels[after] == S).mean() > 0.9, f"{100 * (labels[after] != S).mean():.0f} % moving"
    assert (held[after] == F).mean() > 0.5, "without the rule each step's hold is movement"
    march_joints, _ = _turned(Scene(8.0, swings), 0.0)
    straight = _gate_joints(march_joints, FWD)
    assert (straight[after & (t < swings[1].t0)] == F).all(), "a march's first step holds"


def test_a_lone_wide_side_step_that_turns_the_body_a_little_is_no_pivot() -> None:
    """A slow side step 0.3 m to the right whose wide stance turns the body 10 degrees (hips and
    shoulders follow the foot a little) keeps its bout through the hold (``first_turn_open_deg`` 15);
    with the in-place threshold (7) it ended as a pivot, and a 25-degree turn still does."""
    swings = (Swing(1, 1.0, 1.5, lateral=0.3, peak=0.05),)
    t = np.arange(round(3.0 * FPS)) / FPS
    hold = (t > 1.6) & (t < 2.1)
    joints, _ = _turned(Scene(3.0, swings), 10.0)
    labels = _gate_joints(joints, RIGHT, NO_WINDOW_RULE)
    assert (labels[hold] == R).all(), f"{np.bincount(labels[hold], minlength=4)}"
    strict = _gate_joints(joints, RIGHT, replace(NO_WINDOW_RULE, first_turn_open_deg=7.0))
    assert (strict[hold] == S).any(), "with 7 degrees the wide step's turn reads as a pivot"
    pivot, _ = _turned(Scene(3.0, swings), 25.0)
    assert (_gate_joints(pivot, RIGHT, NO_WINDOW_RULE)[hold] == S).any(), "a wide pivot step is still a pivot"


def test_a_step_in_place_right_after_the_body_turned_starts_no_bout() -> None:
    """Turning on the spot by twisting first and stepping after: the body turns 25 degrees in 0.5 s
    with both feet down, then one foot steps in place (no turn during the swing, so the swing rules
    do not see it). While the body turned 10 degrees or more within 0.7 s, a step in place starts no
    bout, even with a network sure it is forward; without the rule it is a forward bout."""
    swings = march(1.5, 1, 1.0, 0.4)
    joints, _ = render(Scene(3.5, swings))
    t = np.arange(len(joints)) / FPS
    yaw = np.radians(25.0) * np.clip((t - 0.9) / 0.5, 0.0, 1.0)
    centre = joints[0, list(ANKLES), :2].mean(axis=0)
    for i in range(len(joints)):
        c, s_ = np.cos(yaw[i]), np.sin(yaw[i])
        joints[i, :, :2] = (joints[i, :, :2] - centre) @ np.array([[c, -s_], [s_, c]]).T + centre
    labels = _gate_joints(joints, FWD)
    without = _gate_joints(joints, FWD, GateConfig(start_turn_deg=INF))
    assert (labels == S).all()
    assert (without[(t > 1.7) & (t < 2.5)] == F).all(), "without the rule the step is a bout"
    with pytest.raises(ValueError, match="start_turn_deg"):
        GateConfig(start_turn_deg=0.0)


def test_a_kick_is_no_step_and_holds_no_pause() -> None:
    """Kicks from standing (front, then to the side; the leg raised 80 degrees), with a network sure
    it is forward: a kick's first frames may start a bout, but once the leg is up kick_deg the bout
    ends, and its landing is no step: nothing is held after it (without the rule, the first step's
    hold kept each kick moving for most of a second after it landed). A swing that raises the leg
    40 degrees (more than any march step or stride measured: real walks 25, running 29, our second
    motion model's high-knee marches 44) is still a step."""
    kicks = (Swing(1, 1.0, 1.9, peak=0.05), Swing(0, 4.0, 4.9, peak=0.05), Swing(1, 7.0, 7.9, peak=0.05))
    joints, _ = render(Scene(10.0, kicks))
    for i, sw in enumerate(kicks):
        joints = kick(joints, sw, 80.0, sideways=i == 2)
    t = np.arange(len(joints)) / FPS
    after = np.zeros(len(t), dtype=bool)
    up = np.zeros(len(t), dtype=bool)
    for sw in kicks:
        after |= (t > sw.t1 + 0.1) & (t < sw.t1 + 1.5)
        up |= (t > sw.t0 + 0.35) & (t < sw.t1 - 0.35)  # the leg is raised more than 55 degrees
    labels = _gate_joints(joints, FWD)
    assert (labels[after] == S).all(), f"{(labels[after] != S).sum()} frames moving after the kicks"
    assert (labels[up] == S).all()
    without = _gate_joints(joints, FWD, GateConfig(kick_deg=INF))
    assert (without[after] == F).mean() > 0.3, "without the rule each kick holds a pause"
    march_ = march(1.0, 8, 0.8, 0.45)
    raised, _ = render(Scene(8.0, march_))
    for sw in march_:
        raised = kick(raised, sw, 40.0)
    labels = _gate_joints(raised, FWD)
    inside = (t[: len(labels)] > march_[1].t0) & (t[: len(labels)] < march_[-1].t1)
    assert (labels[inside] == F).all(), "a leg raised 40 degrees steps"
    with pytest.raises(ValueError, match="kick_deg"):
        GateConfig(kick_deg=0.0)


def test_one_misplaced_ankle_is_no_kick() -> None:
    """A march whose swinging ankle the cameras misplace for one frame in every swing (1.5 m
    forward, as if the leg were raised 60 degrees): still one bout."""
    swings = march(1.0, 8, 0.8, 0.45)
    joints, _ = render(Scene(8.0, swings))
    t = np.arange(len(joints)) / FPS
    for sw in swings:
        i = round((sw.t0 + 0.2) * FPS)
        joints[i, ANKLES[sw.foot], 1] += 1.5
    labels = _gate_joints(joints, FWD)
    inside = (t > swings[1].t0) & (t < swings[-1].t1)
    assert (labels[inside] == F).all(), f"{(labels[inside] != F).sum()} frames not forward"


def test_a_restart_whose_first_step_shows_its_side_late_keeps_the_side_before() -> None:
    """A step-touch to the right (the right foot out, the left foot follows), a pause that breaks
    the rhythm, then the left foot steps out to the left: the way back, a new bout to the right. That
    foot rises before it moves sideways, so the bout starts on the network's word (here: left) while
    the step still looks like a march step; once it shows its side, the start rule reads it as the
    way back, as for a way back that shows its side at once."""
    out = Swing(1, 1.0, 1.4, lateral=0.3, peak=0.05)
    touch = Swing(0, 1.6, 2.0, lateral=0.3, peak=0.04)
    back = Swing(0, 3.4, 3.9, lateral=-0.2, peak=0.12)  # up first, sideways later
    n = round(5.5 * FPS)
    t = np.arange(n) / FPS
    lead, wrong = np.array([0.1, 0.05, 0.05, 0.8]), np.array([0.1, 0.1, 0.7, 0.1])
    probs = [wrong if t[i] > 3.2 else lead for i in range(n)]
    labels, verdicts, _ = _gate(Scene(5.5, (out, touch, back)), probs)
    assert "rhythm-broke" in {v.reason for v in verdicts[round(2.0 * FPS) : round(3.4 * FPS)]}
    first = next(v for v in verdicts[round(3.4 * FPS) :] if v.active)
    assert (first.evidence, first.label) == ("forward", L), "the scene starts the bout before the side shows"
    way_back = labels[(t > back.t0 + 0.25) & (t < back.t1 + 0.3)]
    assert (way_back == R).mean() > 0.9, f"way back: {np.bincount(way_back, minlength=4)}"


def _out_and_back(t_outs: tuple[float, ...], last_back: bool = True) -> tuple[Swing, ...]:
    """Out-and-back side steps of the right foot: out (0.25 m to the right) at each of ``t_outs`` and
    back 0.6 s later (``last_back=False``: the last one stays out); 0.4 s swings."""
    swings: list[Swing] = []
    for i, t0 in enumerate(t_outs):
        swings.append(Swing(1, t0, t0 + 0.4, lateral=0.25, peak=0.06))
        if last_back or i < len(t_outs) - 1:
            swings.append(Swing(1, t0 + 0.6, t0 + 1.0, lateral=-0.25, peak=0.06))
    return tuple(swings)


RIGHT = np.array([0.1, 0.05, 0.05, 0.8])  # a network sure of a step to the right
UNSURE = np.array([0.5, 0.05, 0.05, 0.4])  # ... and one that is not sure the bout goes on


def test_a_pause_with_a_foot_out_holds_until_the_way_back() -> None:
    """Out-and-back steps every 0.6 s, then a 0.9 s pause with the foot out (longer than the rhythm
    allows) while the network is unsure: the feet apart say the way back is still to come, so the
    bout is one command; without that rule the rhythm breaks in the pause."""
    out, back = 0.25, -0.25
    swings = tuple(
        Swing(1, t0, t0 + 0.4, lateral=d, peak=0.06)
        for t0, d in ((1.0, out), (1.6, back), (2.2, out), (3.5, back), (4.1, out), (4.7, back))
    )  # the foot out from 2.6 s to 3.5 s
    n = round(6.0 * FPS)
    t = np.arange(n) / FPS
    probs = [UNSURE if 2.7 <= t[i] < 3.5 else RIGHT for i in range(n)]
    labels, verdicts, _ = _gate(Scene(6.0, swings), probs)
    bout = (t > 1.3) & (t < 5.1)
    assert (labels[bout] == R).all(), f"{np.bincount(labels[bout], minlength=4)}"
    held = [v for v, ti in zip(verdicts, t, strict=True) if 3.0 < ti < 3.4]
    assert all(v.reason == "pause" and v.deadline_s > 3.7 for v in held), "held to max_allowance_s"
    plain, verdicts, _ = _gate(Scene(6.0, swings), probs, config=GateConfig(split_hold=False))
    assert (plain[bout] == S).any(), "without the rule the bout breaks in the pause"
    assert {"rhythm-broke", "network-still"} & {
        v.reason for v in verdicts[round(2.6 * FPS) : round(3.5 * FPS)]
    }


@pytest.mark.parametrize("gap_s", [2.0, 0.6])
def test_slow_side_steps_rest_with_the_foot_out_as_long_as_their_rhythm(gap_s: float) -> None:
    """Out-and-back steps whose lift-offs come ``gap_s`` apart, then a rest of 1.6 s with the foot
    out while the network is unsure: a person stepping every 2 s (0.5 steps/s) rests that long
    between steps (their rhythm allows it, up to ``split_allowance_s``), so the bout holds; a person
    stepping every 0.6 s has stopped, so it ends at ``max_allowance_s``, as before."""
    out, back, swing = 0.25, -0.25, 0.4
    t_lifts = [1.0 + i * gap_s for i in range(5)]  # out, back, out, back, out
    swings = [
        Swing(1, t0, t0 + swing, lateral=out if i % 2 == 0 else back, peak=0.06)
        for i, t0 in enumerate(t_lifts)
    ]
    land = swings[-1].t1
    rest_end = land + 1.6
    swings.append(Swing(1, rest_end, rest_end + swing, lateral=back, peak=0.06))
    duration = rest_end + 1.5
    t = np.arange(round(duration * FPS)) / FPS
    probs = [UNSURE if land + 0.1 <= ti < rest_end else RIGHT for ti in t]
    labels, _, _ = _gate(Scene(duration, tuple(swings)), probs)
    rest = (t > land + 0.2) & (t < rest_end - 0.1)
    if gap_s > 1.0:
        assert (labels[rest] == R).all(), f"{np.bincount(labels[rest], minlength=4)}"
        flat, _, _ = _gate(Scene(duration, tuple(swings)), probs, config=GateConfig(split_allowance_s=1.2))
        assert (flat[rest] == S).any(), "without split_allowance_s the rest ends the bout"
    else:
        assert (labels[rest] == S).any(), "a quick stepper resting 1.6 s has stopped"


@pytest.mark.parametrize(
    ("after", "latest_s"), [(UNSURE, 1.2 + 0.1), (np.array([0.9, 0.03, 0.03, 0.04]), 0.35)]
)
def test_a_foot_left_out_ends_the_bout_at_the_longest_pause_or_when_the_network_is_sure(
    after: np.ndarray, latest_s: float
) -> None:
    """The last step out stays out: the bout ends at most ``max_allowance_s`` after it landed (the
    person's rhythm, 0.6 s from out to back, allows no longer), and as soon as a network sure that
    the person has stopped says so."""
    swings = _out_and_back((1.0, 2.2), last_back=False)
    n = round(5.0 * FPS)
    t = np.arange(n) / FPS
    land = swings[-1].t1
    probs = [after if t[i] >= land + 0.05 else RIGHT for i in range(n)]
    labels, _, _ = _gate(Scene(5.0, swings), probs)
    assert (labels[(t > 1.3) & (t < land)] == R).all()
    stop = t[(t > land) & (labels == S)][0] - land
    assert stop <= latest_s, f"stopped {stop:.2f} s after the foot landed out"
    if after is UNSURE:
        assert stop >= 0.9, f"stopped {stop:.2f} s after the foot landed out: the split stance did not hold"


def test_side_steps_that_turn_the_body_are_a_turn_not_steering() -> None:
    """Out-and-back side steps that start turning the body after four steps turn on the spot: the
    bout ends (a march that turns the same way steers and goes on)."""
    swings = _out_and_back((1.0, 2.2, 3.4, 4.6, 5.8))
    joints, _ = _turned(Scene(8.0, swings), 12.0, from_step=4)
    t = np.arange(len(joints)) / FPS
    probs = RIGHT
    labels = _gate_joints(joints, probs)
    assert (labels[(t > 1.3) & (t < swings[3].t1)] == R).all()
    turning = (t > swings[5].t0) & (t < swings[-1].t1)
    assert (labels[turning] == S).mean() > 0.7, f"{np.bincount(labels[turning], minlength=4)}"


def test_a_march_right_after_a_turn_on_the_spot_starts_with_its_first_high_step() -> None:
    """Four low pivot steps turn the body 100 degrees, then a march starts at once: the march's first
    step rises 12 cm without turning the body, so the turn just before neither vetoes its start nor
    ends the bout; the pivots stay still. Without the rule the march waits for the turn to leave
    the 0.7 s window."""
    pivots = tuple(Swing(i % 2, 1.0 + 0.5 * i, 1.35 + 0.5 * i, peak=0.03) for i in range(4))
    marching = march(pivots[-1].t1 + 0.05, 8, 0.55, 0.35, peak=0.12)
    scene = Scene(8.0, pivots + marching)
    joints, _ = _turned(scene, 25.0, to_step=len(pivots))
    t = np.arange(len(joints)) / FPS
    for config in (None, GateConfig(march_lift_m=INF)):
        labels = _gate_joints(joints, FWD, config)
        assert (labels[t < pivots[-1].t1] == S).all(), "the turn on the spot is still"
        start = t[(t > marching[0].t0) & (labels == F)][0] - marching[0].t0
        if config is None:
            assert start <= 0.4, f"the march started {start:.2f} s after its first lift-off"
            assert (labels[(t > marching[0].t0 + 0.4) & (t < marching[-1].t1)] == F).all()
        else:
            assert start > 0.4, f"without the rule the march started {start:.2f} s after its first lift-off"


def _frames(events: list[tuple[float, float, str]], until: float) -> list[StepFrame]:
    """Step frames of the right foot's swings (lift-off, touch-down, kind at touch-down; moving
    sideways to the right while up unless the kind says otherwise), the left foot planted."""
    out = []
    kind, lift, land = "none", math.nan, math.nan
    for i in range(round(until * FPS)):
        t = i / FPS
        up = next(((a, b, k) for a, b, k in events if a <= t < b), None)
        lifted = up is not None and abs(t - up[0]) < 0.5 / FPS
        landed = any(abs(t - b) < 0.5 / FPS for _, b, _ in events)
        if lifted and up is not None:
            lift = up[0]
        if landed:
            land = t
            kind = next(k for _, b, k in events if abs(t - b) < 0.5 / FPS)
        elif up is not None:
            kind = "open" if up[2] == "open" or t - up[0] < 0.3 else "vertical"
        right = FootState(
            True, up is None, False, lifted, landed, t, 0.05 if up is not None else 0.0,
            t - up[0] if up is not None else 0.0, 0.2 if kind == "open" else 0.0, 0.0, 0.05, kind, False,
        )  # fmt: skip
        left = FootState(True, True, False, False, False, math.nan, 0.0, 0.0, 0.0, 0.0, 0.0, "none", False)
        out.append(StepFrame(t, (left, right), 0.9, False, 1.0, 1 if math.isfinite(lift) else -1, lift, land))
    return out


def test_a_swing_too_long_for_a_step_does_not_turn_a_side_bout_forward() -> None:
    """Side steps to the right, then the right foot read as off the floor for 1.4 s, landing where it
    left (the tracker missed the landing of a step out between: out, a pause, back) while the network
    wavers towards forward: that "swing" is no march step and the bout stays right; with any swing
    counting as a step, the march-step rule turns the bout forward there."""
    events = [(1.0, 1.4, "open"), (1.6, 2.0, "open"), (2.2, 3.6, "vertical"), (3.7, 4.1, "open")]
    frames = _frames(events, 4.5)
    wavering = np.array([0.05, 0.2, 0.23, 0.52])  # forward x evidence_weight beats right
    probs = [wavering if 3.4 <= f.t < 3.7 else RIGHT for f in frames]
    alone = GateConfig(way_back_landing=False)  # this rule alone (the foot out rising low is a way back too)
    for config, want_forward in ((alone, False), (replace(alone, max_step_swing_s=float("inf")), True)):
        gate = BoutGate(config)
        verdicts = [gate.update(f, p, f.t) for f, p in zip(frames, probs, strict=True)]
        labels = np.array([v.label for v in verdicts])
        t = np.array([f.t for f in frames])
        assert verdicts[round(3.6 * FPS)].evidence == "forward", "the long swing landed as a vertical step"
        bout = labels[(t > 1.2) & (t < 4.1)]
        assert (bout != S).all(), f"one bout: {np.bincount(bout, minlength=4)}"
        assert (bout == F).any() == want_forward, (
            f"{config.max_step_swing_s}: {np.bincount(bout, minlength=4)}"
        )


def _shuffle(lead: int, side: float, t0: float, pairs: int, width: float = 0.2) -> list[Swing]:
    """A side shuffle that travels ``pairs`` lead-and-follow steps to ``side`` and returns to its
    place: then the trailing foot leads, opening to the other side, and the leading foot follows."""
    out, t = [], t0
    for direction, first in ((side, lead), (-side, 1 - lead)):
        for _ in range(pairs):
            out += [
                Swing(first, t, t + 0.35, lateral=width * direction, peak=0.04),
                Swing(1 - first, t + 0.5, t + 0.85, lateral=width * direction, peak=0.04),
            ]
            t += 1.0
    return out


@pytest.mark.parametrize(("lead", "side", "want", "other"), [(1, 1.0, R, L), (0, -1.0, L, R)])
def test_a_shuffle_that_returns_to_its_place_is_one_command(
    lead: int, side: float, want: int, other: int
) -> None:
    """Two pairs of shuffle steps out to a side and two back, in one bout, the network sure of the
    other side on the way back: the feet are out to the bout's side until they are home, so every
    step back is the way back and the command holds. Without the rule (``way_back_m`` inf) the way
    back, after two steps out the same way, reads as travelling to the other side."""
    swings = _shuffle(lead, side, 1.0, 2)
    duration = swings[-1].t1 + 1.0
    t = np.arange(round(duration * FPS)) / FPS
    back_from = swings[4].t0
    sure = {want: np.full(4, 0.04), other: np.full(4, 0.04)}
    sure[want][want] = sure[other][other] = 0.88
    probs = [sure[other] if ti >= back_from else sure[want] for ti in t]
    bout = (t > swings[0].t0 + 0.3) & (t < swings[-1].t1)
    for config, holds in ((GateConfig(), True), (GateConfig(way_back_m=float("inf")), False)):
        labels, _, _ = _gate(Scene(duration, tuple(swings), yaw_deg=25.0), probs, config=config)
        assert not (labels[bout] == S).any(), f"one bout: {np.bincount(labels[bout], minlength=4)}"
        assert (labels[bout] == want).all() == holds, (
            f"way_back_m={config.way_back_m}: {np.bincount(labels[bout], minlength=4)}"
        )
        if not holds:
            assert (labels[(t > back_from + 0.3) & (t < swings[-1].t1)] == other).mean() > 0.9


def test_after_travelling_a_step_out_and_back_towards_the_start_turns_the_bout() -> None:
    """Step-together to the left for two pairs (the feet end 0.4 m left of where they began), then
    the right foot steps out to the right and back, twice. Its first step out looks like the way
    back home; once the same foot closes again it was a step out to the right: the command turns
    right there, with the network unsure."""
    left = _shuffle(0, -1.0, 1.0, 2)[:4]  # the way out only
    t0 = left[-1].t1 + 0.3
    right = [
        Swing(1, t0 + 0.8 * i, t0 + 0.8 * i + 0.35, lateral=0.25 * (1 if i % 2 == 0 else -1))
        for i in range(4)
    ]
    swings = tuple(left + right)
    duration = right[-1].t1 + 1.0
    t = np.arange(round(duration * FPS)) / FPS
    unsure = np.array([0.1, 0.3, 0.3, 0.3])
    labels, _, _ = _gate(Scene(duration, swings, yaw_deg=-60.0), unsure)
    assert (labels[(t > left[0].t0 + 0.3) & (t < left[-1].t1)] == L).mean() > 0.9
    closing = right[1]
    turned = labels[(t > closing.t0 + 0.3) & (t < right[-1].t1)]
    assert (turned == R).mean() > 0.9, f"{np.bincount(turned, minlength=4)}"


def test_a_closing_step_inside_a_forward_bout_lets_the_network_choose_the_side() -> None:
    """A step out to the right, a straight-up step of the other foot that the network takes for
    marching (the bout turns forward), then the right foot sliding back low towards the other one
    while the network is sure of right: a march does not close, so the bout goes back to the side
    the network names; with ``close_rechoose`` off it stays forward through the closing step (no
    other step evidence speaks)."""
    out = Swing(1, 1.0, 1.4, lateral=0.25, peak=0.06)
    up = Swing(0, 1.7, 2.1, peak=0.12)
    back = Swing(1, 2.4, 2.8, lateral=-0.25, peak=0.03)  # low: it shows as closing from the start
    duration = 4.0
    t = np.arange(round(duration * FPS)) / FPS
    right = np.array([0.04, 0.08, 0.04, 0.84])
    probs = [FWD if up.t0 <= ti < back.t0 else right for ti in t]
    closing = (t > back.t0 + 0.25) & (t < back.t1)
    for config, want in ((GateConfig(), R), (GateConfig(close_rechoose=False), F)):
        labels, _, _ = _gate(Scene(duration, (out, up, back), yaw_deg=15.0), probs, config=config)
        assert (labels[(t > up.t0 + 0.3) & (t < up.t1)] == F).all(), "the straight-up step reads as marching"
        assert (labels[closing] == want).all(), (
            f"close_rechoose={config.close_rechoose}: {np.bincount(labels[closing], minlength=4)}"
        )


def test_a_march_that_begins_on_the_way_back_from_a_side_step_turns_the_bout_at_once() -> None:
    """Two side steps out to the left and back, then the left foot steps out again and comes back
    with a high knee lift (15 cm: the first step of a march) while the network is sure of forward,
    then the right foot marches: the bout turns forward during that high way back. The same high way
    back while the network still names the side keeps the side (a side step lifted high), and with
    ``march_sure_prob`` 1 the bout keeps the side until a march step shows without moving sideways."""
    side = [
        Swing(0, 1.0, 1.35, lateral=-0.25, peak=0.04),
        Swing(0, 1.6, 1.95, lateral=0.25, peak=0.04),
        Swing(0, 2.2, 2.55, lateral=-0.25, peak=0.04),
    ]
    back = Swing(0, 2.8, 3.25, lateral=0.25, peak=0.15)  # the way back, high: the march begins
    march = [Swing(1, 3.5, 3.9, peak=0.15), Swing(0, 4.2, 4.6, peak=0.15)]
    duration = 5.2
    t = np.arange(round(duration * FPS)) / FPS
    left = np.array([0.04, 0.08, 0.84, 0.04])
    sure = np.array([0.04, 0.86, 0.06, 0.04])  # forward: 0.9 of the moving probability
    scene = Scene(duration, (*side, back, *march))
    during = (t > back.t0 + 0.25) & (t < back.t1)
    for probs_back, config, want in (
        (sure, GateConfig(), F),
        (left, GateConfig(), L),
        (FWD, GateConfig(), L),  # forward only 0.78 of the moving probability: not sure enough
        (sure, GateConfig(march_sure_prob=1.0), L),
    ):
        probs = [probs_back if ti >= back.t0 else left for ti in t]
        labels, _, _ = _gate(scene, probs, config=config)
        assert (labels[(t > 1.2) & (t < back.t0)] == L).all(), "the side steps are left"
        got = np.bincount(labels[during], minlength=4)
        assert got[want] >= 0.8 * during.sum(), f"{config.march_sure_prob}, {probs_back}: {got}"
    with pytest.raises(ValueError, match="march_sure_prob"):
        GateConfig(march_sure_prob=1.5)


def test_a_march_from_a_side_steps_wide_stance_turns_the_bout_on_its_low_first_steps() -> None:
    """A step out to the right leaves the feet 0.3 m apart; a march begins there with two low steps
    (7 cm) that bring the feet together (each a closing step), then marches in place. The network is
    sure of forward (0.95 of its moving probability) from the first of them: the bout turns forward
    during it. Not when the network is only 0.85 sure (a low swing needs ``march_surest_prob``),
    nor for a swing 3 cm high (below ``march_low_lift_m``), nor with ``march_surest_prob`` 1."""
    out = Swing(1, 1.0, 1.4, lateral=0.30, peak=0.04)
    duration = 4.6
    t = np.arange(round(duration * FPS)) / FPS
    right = np.array([0.04, 0.06, 0.04, 0.86])
    surest = np.array([0.02, 0.93, 0.02, 0.03])
    sure = np.array([0.02, 0.83, 0.02, 0.13])  # forward 0.85 of the moving probability
    for peak, probs_march, config, want in (
        (0.07, surest, GateConfig(), F),
        (0.07, sure, GateConfig(), R),
        (0.03, surest, GateConfig(), R),
        (0.07, surest, GateConfig(march_surest_prob=1.0), R),
    ):
        first = Swing(0, 1.8, 2.2, lateral=0.15, peak=peak)  # the left foot in, towards the right one
        second = Swing(1, 2.5, 2.9, lateral=-0.15, peak=peak)  # the right foot in
        march = (Swing(0, 3.2, 3.6, peak=peak), Swing(1, 3.9, 4.3, peak=peak))
        probs = [probs_march if ti >= first.t0 else right for ti in t]
        labels, _, _ = _gate(Scene(duration, (out, first, second, *march)), probs, config=config)
        assert (labels[(t > out.t0 + 0.3) & (t < first.t0)] == R).all(), "the step out is right"
        during = (t > first.t0 + 0.25) & (t < first.t1)
        got = np.bincount(labels[during], minlength=4)
        assert got[want] >= 0.8 * during.sum(), (
            f"peak {peak}, {probs_march}, {config.march_surest_prob}: {got}"
        )
    with pytest.raises(ValueError, match="march_surest_prob"):
        GateConfig(march_surest_prob=1.5)
    with pytest.raises(ValueError, match="march_low_lift_m"):
        GateConfig(march_low_lift_m=0.0)


@pytest.mark.parametrize(
    ("peak", "other_swings", "ends"), [(0.03, False, True), (0.15, False, False), (0.03, True, False)]
)
def test_a_foot_sliding_back_low_ends_the_bout(peak: float, other_swings: bool, ends: bool) -> None:
    """A march, a step forward, then the other foot sliding 35 cm back low (the rear leg of a kneel
    going down) while the network is sure of forward: the bout ends once the foot is 22 cm back and
    stays ended; with ``back_slide_m`` off it goes on through the slide. A foot going back as far but
    lifted high (15 cm), or sliding back while the other foot swings (a treadmill's belt carrying the
    stance foot), is not the kneel's slide and ends nothing by this rule."""
    march = [Swing(k % 2, 1.0 + 0.5 * k, 1.35 + 0.5 * k, peak=0.12) for k in range(4)]
    ahead = Swing(0, 3.0, 3.4, sagittal=0.2, peak=0.05)
    slide = Swing(1, 3.6, 4.3, sagittal=-0.35, peak=peak)
    swings = (*march, ahead, slide) + ((Swing(0, 3.5, 3.9, peak=0.12),) if other_swings else ())
    duration = 4.8
    scene = Scene(duration, swings)
    t = np.arange(round(duration * FPS)) / FPS
    labels, verdicts, _ = _gate(scene, FWD)
    back = next((i for i, v in enumerate(verdicts) if v.reason == "step-back"), None)
    assert (labels[(t > 1.3) & (t < 3.4)] == F).all(), "the march and the step forward move"
    if ends:
        assert back is not None and t[back] < slide.t1, "the slide ends the bout before it lands"
        after = np.bincount(labels[back:], minlength=4)
        assert (labels[back:] == S).all(), f"still from the slide on: {after}"
    else:
        assert back is None, f"step-back at {t[back]:.2f} s"
    off, _, _ = _gate(scene, FWD, config=GateConfig(back_slide_m=float("inf")))
    during = (t > slide.t0 + 0.2) & (t < slide.t1)
    assert (off[during] == F).all(), f"rule off: the bout goes on ({np.bincount(off[during], minlength=4)})"
    with pytest.raises(ValueError, match="back_slide_low_m must be > 0"):
        GateConfig(back_slide_low_m=0.0)
    with pytest.raises(ValueError, match=r"^back_slide_m must be > 0"):
        GateConfig(back_slide_m=-0.1)


def test_a_new_side_forgets_a_way_home_still_pending() -> None:
    """A shuffle that travels two pairs to the right; the left foot then steps left three times (the
    first two the way home, the third beyond it: the bout turns left) and closes back. That closing
    step belongs to the new left side; it must not be read as the first way-home step's foot stepping
    back (which turned the bout right again while that reading was left pending)."""
    swings = _shuffle(1, 1.0, 1.0, 2)[:4]  # the way out only: the feet end 0.4 m to the right
    t0 = swings[-1].t1 + 0.15
    lefts = [Swing(0, t0 + 0.7 * i, t0 + 0.7 * i + 0.35, lateral=-0.2, peak=0.04) for i in range(3)]
    back = Swing(0, lefts[-1].t1 + 0.35, lefts[-1].t1 + 0.7, lateral=0.2, peak=0.04)
    duration = back.t1 + 1.5
    t = np.arange(round(duration * FPS)) / FPS
    labels, _, _ = _gate(
        Scene(duration, (*swings, *lefts, back), yaw_deg=20.0), np.array([0.1, 0.3, 0.3, 0.3])
    )
    for s in lefts[:2]:
        assert (labels[(t > s.t0 + 0.2) & (t < s.t1)] == R).all(), "the way home keeps the side"
    for s in (lefts[2], back):
        seen = labels[(t > s.t0 + 0.2) & (t < s.t1)]
        assert (seen == L).all(), f"step at {s.t0:.2f} s: {np.bincount(seen, minlength=4)}"


def _gate_with_start(
    scene: Scene, probs: list[np.ndarray], start: np.ndarray, config: GateConfig
) -> tuple[np.ndarray, list]:  # type: ignore[type-arg]
    joints, _ = render(scene)
    tr, gate = StepTracker(), BoutGate(config)
    out = [
        gate.update(tr.update(frame, i / FPS), probs[i], i / FPS, start)
        for i, frame in enumerate(noisy(joints, 0.012, 0.02))
    ]
    return np.array([v.label for v in out]), out


def test_the_start_head_may_start_a_bout_but_only_the_full_network_holds_and_ends_it() -> None:
    """Two judges (a model with a start head): while no bout is on, the surer of the two speaks, so
    a march the full-body network calls still starts on its first step when the legs-only head is
    sure; once the bout is on only the full-body network counts: a whole swing it calls still ends
    the bout (the start head, sure of movement throughout, does not hold it). Without the start head
    (or with ``start_network`` off) no step starts a bout. The rhythm rule is off here."""
    swings = march(1.0, 8, 0.6, 0.35)
    n = round(7.0 * FPS)
    t = np.arange(n) / FPS
    config = GateConfig(rhythm_steps=0)
    still = [STILL_NET] * n
    labels, _ = _gate_with_start(Scene(7.0, swings), still, STILL_NET, config)
    assert (labels == S).all(), "two judges calling still: no bout"
    off = GateConfig(rhythm_steps=0, start_network=False)
    labels, _ = _gate_with_start(Scene(7.0, swings), still, FWD, off)
    assert (labels == S).all(), "the start head switched off is not read"
    labels, verdicts = _gate_with_start(Scene(7.0, swings), still, FWD, config)
    first = t[labels == F][0]
    assert swings[0].t0 + 0.1 <= first <= swings[0].t0 + 0.35, f"started at {first:.2f} s"
    ended = [v.reason for v, tt in zip(verdicts, t, strict=True) if swings[1].t1 <= tt < swings[2].t0]
    assert "network-still" in ended, f"the full network's veto ends the bout: {set(ended)}"
    assert (labels[(t >= swings[1].t1 + 0.05) & (t < swings[2].t0)] == S).all()
    assert "start-head" in {v.reason for v in verdicts if v.active}, "the step strip says who started it"
    # a full network sure of the movement holds the bout through every step and pause
    sure = [FWD] * n
    labels, verdicts = _gate_with_start(Scene(7.0, swings), sure, STILL_NET, config)
    assert (labels[(t > swings[0].t0 + 0.35) & (t < swings[-1].t1)] == F).all(), "the start head is not read"
    assert "start-head" not in {v.reason for v in verdicts}
    # a full network unsure at first (p(moving) 0.5), sure from 3 s on: the step strip's reason turns
    # from the start head's word to a step the full-body network knows
    unsure = np.array([0.5, 0.3, 0.1, 0.1])
    mixed = [unsure if i / FPS < 3.0 else FWD for i in range(n)]
    labels, verdicts = _gate_with_start(Scene(7.0, swings), mixed, FWD, config)
    reasons = np.array([v.reason for v in verdicts])
    early = (t > swings[0].t0 + 0.35) & (t < swings[0].t1)
    assert (reasons[early] == "start-head").all(), set(reasons[early])
    assert (reasons[(t > 3.2) & (labels == F)] != "start-head").all()
    assert "stepping" in set(reasons[t > 3.2])


def test_the_start_head_is_quiet_after_a_crouch_and_while_the_body_turns() -> None:
    """Standing up from a kneel or a squat brings a foot back, and a turn on the spot pivots: the
    full-body network knows those, the legs-only start head less. It is not read for
    ``start_quiet_s`` after the body was crouched nor while the body has turned ``start_quiet_deg``
    within ``turn_window_s``; the full-body network's judgement (still) stands."""
    config = GateConfig(rhythm_steps=0)
    loud = GateConfig(rhythm_steps=0, start_quiet_s=0.0, start_quiet_deg=INF)
    # crouched 0.5-1.5 s (ramps included), a step 0.6 s after it, another 2.5 s after it
    crouch = Scene(6.0, (Swing(0, 2.1, 2.45), Swing(1, 4.0, 4.35)), crouch=((0.5, 1.5, 0.4),))
    n = round(6.0 * FPS)
    t = np.arange(n) / FPS
    labels, verdicts = _gate_with_start(crouch, [STILL_NET] * n, FWD, config)
    assert any(v.reason == "crouched" for v in verdicts), "the scene crouches"
    assert (labels[t < 3.5] == S).all(), "the step right after the crouch starts nothing"
    assert (labels[(t > 4.15) & (t < 4.35)] == F).all(), "a step well after it does (the start head)"
    labels, _ = _gate_with_start(crouch, [STILL_NET] * n, FWD, loud)
    assert (labels[(t > 2.3) & (t < 2.45)] == F).all(), "without the quiet time the first step starts"
    # pivot steps turning the body 8 degrees each: the turn is under way from the second swing on
    swings = march(1.0, 4, 0.6, 0.35, peak=0.04)
    joints, _ = _turned(Scene(4.0, swings), 8.0)
    n = len(joints)

    def run(cfg: GateConfig) -> np.ndarray:
        tr, gate = StepTracker(), BoutGate(cfg)
        frames = noisy(joints, 0.01)
        return np.array(
            [gate.update(tr.update(f, i / FPS), STILL_NET, i / FPS, FWD).label for i, f in enumerate(frames)]
        )

    quiet = run(replace(config, start_turn_deg=INF, max_window_turn_deg=INF, first_turn_deg=INF))
    noisy_start = run(replace(loud, start_turn_deg=INF, max_window_turn_deg=INF, first_turn_deg=INF))
    later = np.arange(n) / FPS > swings[1].t0
    assert (quiet[later] == S).all(), f"{np.mean(quiet[later] != S):.0%} of the turn's later frames moving"
    assert (noisy_start[later] != S).any(), "with the start head always read the pivots start bouts"
    for bad in ({"start_quiet_s": -1.0}, {"start_quiet_s": INF}, {"start_quiet_deg": -1.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            GateConfig(**bad)


def _standing_up(split_m: float, step_at: float, crouched_until: float = 1.0) -> list[StepFrame]:
    """Kneeling (crouched) until ``crouched_until``, then standing with the right foot ``split_m``
    ahead of the left (negative: behind); at ``step_at`` it steps 0.4 s forward to beside it."""
    out = []
    for i in range(round((step_at + 1.5) * FPS)):
        t = i / FPS
        up = step_at <= t < step_at + 0.4
        lifted, landed = abs(t - step_at) < 0.5 / FPS, abs(t - step_at - 0.4) < 0.5 / FPS
        moved = -split_m * min(max((t - step_at) / 0.4, 0.0), 1.0)
        right = FootState(
            known=True, planted=not up, rising=False, lifted=lifted, landed=landed,
            event_t=step_at if lifted else (step_at + 0.4 if landed else math.nan),
            height_m=0.05 if up else 0.0, swing_s=t - step_at if up else 0.0, lateral_m=0.0,
            sagittal_m=moved, vertical_m=0.05, kind="forward" if t >= step_at else "none", jump=False,
            split_m=split_m if t >= step_at else math.nan,
        )  # fmt: skip
        left = FootState(True, True, False, False, False, math.nan, 0.0, 0.0, 0.0, 0.0, 0.0, "none", False)
        low = t < crouched_until
        out.append(StepFrame(t, (left, right), 0.9, low, 0.6 if low else 1.0, 1 if t >= step_at else -1,
                             step_at if t >= step_at else math.nan, math.nan))  # fmt: skip
    return out


@pytest.mark.parametrize(
    ("split_m", "step_at", "starts"),
    [(-0.45, 1.3, False), (0.45, 1.3, False), (-0.45, 2.7, True), (-0.1, 1.3, True)],
)
def test_standing_up_from_a_kneel_brings_the_feet_together_without_a_bout(
    split_m: float, step_at: float, starts: bool
) -> None:
    """After kneeling (crouched until 1.0 s) the foot that stood 0.45 m behind (or ahead of) the
    other steps back beside it while a network calls it forward: within ``kneel_quiet_s`` (1.5 s) of
    the crouch that is standing up, no bout; later, or from feet side by side (0.1 m), a step starts
    one as always. With the rule off the stand-up step starts a bout (blind7's kneels: 55 % of their
    frames were movement, half of them the stand-up)."""
    frames = _standing_up(split_m, step_at)

    def labels(config: GateConfig) -> np.ndarray:
        gate = BoutGate(config)
        return np.array([gate.update(f, FWD, f.t).label for f in frames])

    got = labels(GateConfig())
    assert (got != S).any() == starts, got
    if not starts:
        assert (labels(GateConfig(kneel_quiet_s=0.0)) != S).any(), (
            "without the rule the stand-up step starts a bout"
        )


def test_the_low_rise_of_a_foot_out_to_the_side_is_its_way_back_not_a_march_step() -> None:
    """Two steps out to the right and back, a third out; the bout ends in a long pause with the foot
    out. The foot then comes home in two parts: it rises 6 cm in place (moving 4 cm inwards) and
    lands, then slides home low. The network leans forward at the rise. The new bout takes the side
    of the foot out at its start and keeps it when that rise lands and through the slide home (the
    way back is a side step's, not a march); with ``way_back_landing`` off the landing turned the
    bout forward for the rest of it."""
    side = [
        Swing(1, 1.0, 1.35, lateral=0.25, peak=0.05),
        Swing(1, 1.6, 1.95, lateral=-0.25, peak=0.05),
        Swing(1, 2.2, 2.55, lateral=0.25, peak=0.05),
    ]
    rise = Swing(1, 4.5, 4.9, lateral=-0.04, peak=0.06)
    home = Swing(1, 5.2, 5.6, lateral=-0.21, peak=0.005)
    duration = 6.5
    t = np.arange(round(duration * FPS)) / FPS
    leaning = np.array([0.04, 0.55, 0.1, 0.31])  # forward, not sure of it
    probs = [
        RIGHT if ti < 3.2 else np.array([0.95, 0.02, 0.01, 0.02]) if ti < rise.t0 else leaning for ti in t
    ]
    scene = Scene(duration, (*side, rise, home))
    after = (t > rise.t1 + 0.15) & (t < home.t1)  # from the rise's landing to the end of the slide home
    for config, want in ((GateConfig(), R), (GateConfig(way_back_landing=False), F)):
        labels, _, _ = _gate(scene, probs, config=config)
        assert (labels[(t > 1.2) & (t < 2.5)] == R).all(), "the side steps are right"
        assert (labels[(t > 3.4) & (t < rise.t0)] == S).all(), "the bout ended in the pause"
        got = np.bincount(labels[after], minlength=4)
        assert got[want] == after.sum(), f"way_back_landing={config.way_back_landing}: {got}"


def test_a_foot_sliding_out_while_the_other_leg_kicks_starts_no_bout() -> None:
    """A kick with the right leg (raised 80 degrees), and while it is up the left foot slides 0.2-0.4 m
    out to the side, flat on the floor, until after the kick has landed; then the person stands with
    the feet apart (a real dancer's ending, CMU 131_02, `test_real_motion.py`). The slide lifted off
    while the other foot was up in the air (``start_air_m``), so it starts no bout, with a network
    sure of movement (p(still) 0.1); without the rule it started one that the pause held for more
    than a second. A network sure of a run (p(still) at most ``run_still_prob``) may still start one:
    a run's feet overlap in the air."""
    kick_ = Swing(1, 1.0, 1.8, peak=0.05)
    sure_run = np.array([0.02, 0.94, 0.02, 0.02])
    for t0, lateral in ((1.3, -0.2), (1.4, -0.3), (1.5, -0.4)):
        slide = Swing(0, t0, 2.4, lateral=lateral, peak=0.0)
        joints, _ = render(Scene(4.5, (kick_, slide)))
        joints = kick(joints, kick_, 80.0)
        t = np.arange(len(joints)) / FPS
        after = t > kick_.t1 + 0.2
        labels = _gate_joints(joints, FWD)
        without = _gate_joints(joints, FWD, GateConfig(start_air_m=INF))
        assert (labels[after] == S).all(), f"slide at {t0} s: {(labels[after] != S).sum()} frames moving"
        assert (without[after] != S).sum() / FPS > 1.0, "without the rule the slide starts a bout"
        assert (_gate_joints(joints, sure_run)[after] != S).any(), "a network sure of a run starts one"
    with pytest.raises(ValueError, match="start_air_m"):
        GateConfig(start_air_m=-0.01)
