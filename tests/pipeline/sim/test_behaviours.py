"""The still library, behaviour by behaviour: feet planted unless the behaviour moves them,
both feet together in a jump, a knee on the floor when kneeling, labels still, tags right."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.sim.behaviours import LIBRARY
from pipeline.sim.motion import UserMotion, body_from_height, simulate_user
from pipeline.sim.script import STILL_BEHAVIOURS, MotionScript, Segment
from pipeline.skeleton import BONES, J

FPS = 30.0
ANKLES = [J["l_ankle"], J["r_ankle"]]
RIGID = [
    (a, b) for a, b in BONES if {a, b} not in ({J["l_shoulder"], J["l_hip"]}, {J["r_shoulder"], J["r_hip"]})
]
KNEES = [J["l_knee"], J["r_knee"]]
HEIGHTS = (1.45, 1.75, 2.0)


def _behave(
    name: str, height: float, seed: int, intensity: float | None = None, dur: float = 4.0
) -> UserMotion:
    segs = (
        Segment("still", 1.0, gestures=()),
        Segment("still", dur, behaviour=name, intensity=intensity),
        Segment("still", 1.0, gestures=()),
    )
    return simulate_user(
        MotionScript(segs, start_xy_m=(0.1, 0.2), start_yaw_deg=-40.0),
        body_from_height(height),
        FPS,
        seed=seed,
    )


def planted_slide_m(m: UserMotion) -> np.ndarray:
    """(T-1, 2) how far each ankle moves over the floor between two frames in which that foot is planted."""
    step = np.linalg.norm(np.diff(m.joints_m[:, ANKLES, :2], axis=0), axis=-1)
    return np.where(m.contacts[1:] & m.contacts[:-1], step, 0.0)


def test_the_library_covers_every_still_behaviour_of_the_script_format() -> None:
    gestures = {"idle", "look-around", "point", "wave"}
    assert set(LIBRARY) | gestures == set(STILL_BEHAVIOURS)


@pytest.mark.parametrize("name", sorted(LIBRARY))
@pytest.mark.parametrize("height", HEIGHTS)
def test_each_behaviour_is_physical_still_and_returns_to_standing(name: str, height: float) -> None:
    m = _behave(name, height, seed=int(height * 10))
    assert set(m.labels) == {"still"}, f"{name} is still"
    seg = slice(30, 150)
    assert set(m.tags[seg]) <= {name, "stand-up"} and m.tags[40] == name
    assert set(m.tags[:30]) == {""} and set(m.tags[150:]) == {""}
    slide = planted_slide_m(m)
    assert slide.max() < 1e-9, f"{name}: a planted foot slid {slide.max() * 1000:.2f} mm"
    lengths = np.stack([np.linalg.norm(m.joints_m[:, a] - m.joints_m[:, b], axis=-1) for a, b in RIGID], 1)
    assert np.ptp(lengths, axis=0).max() < 1e-6, f"{name}: a bone changed length"
    assert m.joints_m[:, KNEES, 2].min() > 0.02, f"{name}: a knee went through the floor"
    assert m.joints_m[:, ANKLES, 2].min() > 0.9 * body_from_height(height).ankle_height_m - 1e-3
    assert np.all(np.isfinite(m.joints_m))
    moving_feet = ~m.contacts
    if name not in ("kneel", "kneel-forward", "lunge", "jump", "step-back"):
        assert not moving_feet.any(), f"{name} keeps both feet planted"
    # back to standing where it started (a step back stands where it stepped to): the same feet,
    # the pelvis at its standing height
    if name != "step-back":
        assert np.allclose(
            m.joints_m[-1, ANKLES, :2], m.joints_m[0, ANKLES, :2], atol=0.25 if name == "jump" else 1e-6
        )
    pelvis_z = m.joints_m[:, [J["l_hip"], J["r_hip"]], 2].mean(axis=1)
    assert abs(pelvis_z[-1] - pelvis_z[0]) < 0.03, f"{name}: not standing again at the end"
    hips = m.joints_m[:, [J["l_hip"], J["r_hip"]]].mean(axis=1)
    assert np.linalg.norm(np.diff(hips, axis=0), axis=1).max() < 3.0 / FPS, f"{name}: the pelvis jumped"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_jump_leaves_and_lands_with_both_feet_together(seed: int) -> None:
    m = _behave("jump", 1.75, seed, intensity=float(seed) / 2)
    off = ~m.contacts
    assert off.any(), "the feet leave the floor"
    assert np.array_equal(off[:, 0], off[:, 1]), "both feet leave and land in the same frames"
    flights = np.flatnonzero(np.diff(np.concatenate([[0], off[:, 0].astype(int), [0]])))
    durations = (flights[1::2] - flights[::2]) / FPS
    assert np.all((durations > 0.15) & (durations < 0.5)), f"flight times {durations}"
    z = m.joints_m[:, ANKLES, 2]
    assert (z[off[:, 0]] - z[0]).min(axis=1).max() > 0.05, "both ankles clear the floor in flight"


@pytest.mark.parametrize("height", HEIGHTS)
def test_kneeling_puts_one_knee_on_the_floor_and_the_feet_step_only_to_kneel(height: float) -> None:
    m = _behave("kneel", height, seed=3, dur=5.0)
    knees = m.joints_m[:, KNEES, 2]
    low = knees.min(axis=1)
    assert low.min() < 0.09 * height / 1.75, f"the lowest knee only came down to {low.min():.3f} m"
    assert np.sum(low < 0.1 * height / 1.75) > 0.8 * FPS, "the knee stays down for a while"
    lifts = np.flatnonzero((m.contacts[:-1] & ~m.contacts[1:]).any(axis=1))
    assert len(lifts) == 2, f"one step back and one forward, got {len(lifts)} lift-offs"
    assert "stand-up" in m.tags and m.tags.index("stand-up") > m.tags.index("kneel")


@pytest.mark.parametrize("height", HEIGHTS)
def test_kneeling_forward_steps_the_front_foot_out_and_back(height: float) -> None:
    m = _behave("kneel-forward", height, seed=4, dur=5.0)
    assert m.joints_m[:, KNEES, 2].min() < 0.09 * height / 1.75, "a knee on the floor"
    lifts = np.flatnonzero((m.contacts[:-1] & ~m.contacts[1:]).any(axis=1))
    assert len(lifts) == 2, f"one step out and one back, got {len(lifts)} lift-offs"
    (foot,) = {int(np.flatnonzero(~m.contacts[i + 1])[0]) for i in lifts}  # the same foot both times
    facing = np.array([-np.sin(np.radians(-40.0)), np.cos(np.radians(-40.0))])  # the script's start yaw
    ankle = m.joints_m[:, ANKLES[foot], :2]
    ahead = (ankle[lifts[1]] - ankle[0]) @ facing
    assert ahead > 0.3 * height / 1.75, f"the front foot stepped {ahead:.2f} m forward"
    other = m.joints_m[:, ANKLES[1 - foot], :2]
    assert np.allclose(other, other[0], atol=1e-9), "the rear foot stays where it stood"
    assert "stand-up" in m.tags and m.tags.index("stand-up") > m.tags.index("kneel-forward")


@pytest.mark.parametrize("height", HEIGHTS)
def test_a_lunge_steps_one_foot_out_ahead_and_back_with_the_body_onto_it(height: float) -> None:
    short = _behave("lunge", height, seed=5, intensity=0.0, dur=3.0)
    far = _behave("lunge", height, seed=5, intensity=1.0, dur=3.0)
    facing = np.array([-np.sin(np.radians(-40.0)), np.cos(np.radians(-40.0))])  # the script's start yaw
    reach = []
    for m in (short, far):
        lifts = np.flatnonzero((m.contacts[:-1] & ~m.contacts[1:]).any(axis=1))
        assert len(lifts) == 2, f"one step out and one back, got {len(lifts)} lift-offs"
        (foot,) = {int(np.flatnonzero(~m.contacts[i + 1])[0]) for i in lifts}  # the same foot both times
        ankle, other = m.joints_m[:, ANKLES[foot], :2], m.joints_m[:, ANKLES[1 - foot], :2]
        held = (lifts[0] + lifts[1]) // 2
        reach.append(float((ankle[held] - ankle[0]) @ facing))
        assert np.allclose(other, other[0], atol=1e-9), "the other foot stays where it stood"
        hips = m.joints_m[:, [J["l_hip"], J["r_hip"]]].mean(axis=1)
        mid = 0.5 * (ankle[held] + other[held])
        assert (hips[held, :2] - mid) @ facing > 0.02, "the body is onto the front foot"
        assert hips[held, 2] < hips[0, 2] - 0.01, "the front knee bends"
        wrists = m.joints_m[held, [J["l_wrist"], J["r_wrist"]], :2]
        assert ((wrists - hips[held, :2]) @ facing).max() > 0.4 * height / 1.75, "an arm reaches out ahead"
    scale = height / 1.75
    assert 0.27 * scale < reach[0] < 0.33 * scale and 0.55 * scale < reach[1] < 0.65 * scale, reach


@pytest.mark.parametrize("height", HEIGHTS)
def test_stepping_back_moves_both_feet_back_and_stays(height: float) -> None:
    near = _behave("step-back", height, seed=6, intensity=0.0)
    far = _behave("step-back", height, seed=6, intensity=1.0)
    facing = np.array([-np.sin(np.radians(-40.0)), np.cos(np.radians(-40.0))])  # the script's start yaw
    backs = []
    for m in (near, far):
        lifts = np.flatnonzero((m.contacts[:-1] & ~m.contacts[1:]).any(axis=1))
        assert len(lifts) == 2, f"one step back and the other foot after it, got {len(lifts)} lift-offs"
        feet = {int(np.flatnonzero(~m.contacts[i + 1])[0]) for i in lifts}
        assert feet == {0, 1}, "each foot steps once"
        moved = (m.joints_m[-1, ANKLES, :2] - m.joints_m[0, ANKLES, :2]) @ facing
        assert np.allclose(moved, moved[0], atol=0.02), f"the feet end side by side again: {moved}"
        backs.append(-float(moved.mean()))
        assert set(m.labels) == {"still"}
    scale = height / 1.75
    assert 0.24 * scale < backs[0] < backs[1] < 0.51 * scale, f"intensity steps further back: {backs}"


@pytest.mark.parametrize("name", ["crouch", "squat"])
def test_crouch_and_squat_go_down_and_stand_up(name: str) -> None:
    shallow = _behave(name, 1.75, seed=5, intensity=0.0)
    deep = _behave(name, 1.75, seed=5, intensity=1.0)
    drop = [m.joints_m[0, J["l_hip"], 2] - m.joints_m[:, J["l_hip"], 2].min() for m in (shallow, deep)]
    assert 0.1 < drop[0] < drop[1], f"intensity deepens the {name}: {drop}"
    tags = np.array(deep.tags)
    rise = np.flatnonzero(tags == "stand-up")
    assert rise.size > 0.3 * FPS and rise.min() > np.flatnonzero(tags == name).max() - 1
    z = deep.joints_m[rise, J["l_hip"], 2]
    assert z[-1] > z[0], "the stand-up frames rise"


def test_tiptoe_lifts_the_heels_but_not_the_toes() -> None:
    m = _behave("tiptoe", 1.75, seed=1, intensity=1.0)
    rise = m.joints_m[:, ANKLES, 2] - m.joints_m[0, ANKLES, 2]
    assert 0.03 < rise.max() < 0.09 and m.contacts.all()


def test_a_library_behaviour_cannot_also_turn() -> None:
    with pytest.raises(InputError, match="cannot turn"):
        Segment("still", 2.0, behaviour="kneel", turn_deg=30.0)
    assert Segment("still", 2.0, behaviour="look-around", turn_deg=30.0).yaw_change_deg == 30.0
