"""Step evidence on hand-made skeletons whose foot contacts are known by construction: contact and
lift/touch-down timing, the stepping foot's displacement in the body frame, jumps, crouches,
noise, dropped joints, unknown floor height and body size."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.recognition.steps import KINDS, StepConfig, StepTracker, step_evidence
from pipeline.skeleton import J

from .kinematic import Scene, Swing, kick, march, noisy, render

FPS = 30.0


def _run(scene: Scene, sigma: float = 0.012, drop: float = 0.02, seed: int = 0):  # type: ignore[no-untyped-def]
    joints, contacts = render(scene)
    return step_evidence(noisy(joints, sigma, drop, seed), FPS), contacts


def _kinds(ev, foot: int) -> list[str]:  # type: ignore[no-untyped-def]
    swinging = ~ev.planted[:, foot]
    return [KINDS[k] for k in ev.kind[swinging, foot]]


@pytest.mark.parametrize("sigma", [0.0, 0.012, 0.03])
def test_standing_still_never_lifts(sigma: float) -> None:
    ev, _ = _run(Scene(20.0, wave=True), sigma=sigma)
    assert len(ev.lifts) == 0, f"noise {sigma} m: lifts at {ev.lifts[:, 0]}"
    assert ev.planted.all() and not ev.crouched.any()


def test_single_frame_outliers_are_not_steps() -> None:
    joints, _ = render(Scene(10.0))
    j = noisy(joints, 0.012, 0.0, 3)
    rng = np.random.default_rng(3)
    for i in rng.choice(len(j), 20, replace=False):
        j[i, 15:17] += rng.normal(0.0, 0.15, (2, 3))  # 15 cm triangulation outliers on the ankles
    ev = step_evidence(j, FPS)
    assert len(ev.lifts) == 0


@pytest.mark.parametrize(
    ("joint", "dz"),
    [("l_knee", -0.19), ("r_knee", 0.15), ("l_ankle", -0.06), ("r_ankle", 0.05)],
)
def test_an_outlier_in_the_first_frame_is_not_a_step(joint: str, dz: float) -> None:
    """Tracking begins (a person walks in, or is found again) with a triangulation outlier in its
    first frame: the foot is anchored at the median of its first three points, and its knee-ankle
    baseline too, so the standing foot does not look lifted (before: a knee 19 cm low made the foot
    5 cm high for 0.3 s, a lift-off, and the network's start head moved the person)."""
    joints, _ = render(Scene(4.0))
    j = noisy(joints, 0.005, 0.0, 5)
    j[0, J[joint], 2] += dz
    ev = step_evidence(j, FPS)
    assert len(ev.lifts) == 0, f"a lift-off at {ev.lifts[:, 0]}"
    assert np.nanmax(np.abs(ev.height_m[4:])) < 0.03, "the standing feet are at their level again"


@pytest.mark.parametrize(
    ("height", "floor", "peak"),
    [(1.75, 0.0, 0.10), (1.48, 0.0, 0.06), (1.98, 0.45, 0.06), (1.75, -0.3, 0.04)],
)
def test_marching_lifts_and_lands_when_the_feet_do(height: float, floor: float, peak: float) -> None:
    swings = march(1.0, 16, 0.6, 0.35, peak=peak)
    ev, contacts = _run(Scene(12.0, swings, height_m=height, floor_z=floor, yaw_deg=35.0))
    found = 0
    for s in swings:  # each true step: one lift-off of that foot within 0.15 s, its touch-down too
        lift = ev.lifts[(ev.lifts[:, 1] == s.foot) & (np.abs(ev.lifts[:, 0] - s.t0) < 0.15)]
        tol = 0.15 if peak >= 0.05 else 0.2  # a low foot hovers near the floor before it lands
        land = ev.lands[(ev.lands[:, 1] == s.foot) & (np.abs(ev.lands[:, 0] - s.t1) < tol)]
        found += len(lift) == 1 and len(land) == 1
    assert len(ev.lifts) <= len(swings), f"no extra steps: {ev.lifts[:, 0]}"
    # a 4 cm lift is 3.3 sigma of the 1.2 cm noise: most, not all, are seen
    need = len(swings) if peak >= 0.05 else round(0.8 * len(swings))
    assert found >= need, f"{found} of {len(swings)} steps found with their timing"
    assert (ev.planted == contacts).mean() > (0.85 if peak >= 0.05 else 0.8)
    for foot in (0, 1):
        kinds = _kinds(ev, foot)
        assert kinds.count("vertical") > 0.6 * len(kinds), kinds
    assert np.allclose(np.median(ev.leg_m), 0.86 * height / 1.75, rtol=0.06), "leg length from the skeleton"


@pytest.mark.parametrize("yaw", [0.0, 120.0, -75.0])
def test_side_step_out_and_back_opens_then_closes(yaw: float) -> None:
    swings = (
        Swing(0, 1.0, 1.45, lateral=-0.25, peak=0.05),
        Swing(0, 1.9, 2.35, lateral=0.25, peak=0.05),
        Swing(1, 3.0, 3.45, lateral=0.3, peak=0.04),
        Swing(1, 3.9, 4.35, lateral=-0.3, peak=0.04),
    )
    ev, _ = _run(Scene(5.5, swings, yaw_deg=yaw))
    assert len(ev.lifts) == 4
    left, right = _kinds(ev, 0), _kinds(ev, 1)
    # out to the person's own left: open (lateral < 0), then back: close
    t = np.arange(len(ev.planted)) / FPS
    out_l = (~ev.planted[:, 0]) & (t < 1.6)
    assert np.median(ev.lateral_m[out_l, 0]) < -0.1 and "open" in left and "close" in left
    back_l = (~ev.planted[:, 0]) & (t > 1.8) & (t < 2.5)
    assert [KINDS[k] for k in ev.kind[back_l, 0]][-1] == "close"
    out_r = (~ev.planted[:, 1]) & (t < 3.6)
    assert np.median(ev.lateral_m[out_r, 1]) > 0.1 and "open" in right


def test_step_together_and_shuffle_without_a_lift() -> None:
    swings = (Swing(1, 1.0, 1.5, lateral=0.3, peak=0.0), Swing(0, 1.8, 2.3, lateral=0.3, peak=0.0))
    ev, _ = _run(Scene(3.5, swings))
    assert len(ev.lifts) == 2, "a slide with no lift is a step"
    t = np.arange(len(ev.planted)) / FPS
    lead = [KINDS[k] for k in ev.kind[(~ev.planted[:, 1]) & (t < 1.6), 1]]
    trail = [KINDS[k] for k in ev.kind[(~ev.planted[:, 0]) & (t > 1.7), 0]]
    assert lead[-1] == "open" and trail[-1] == "close", (lead, trail)


def test_forward_walking_steps_are_forward() -> None:
    swings = tuple(Swing(i % 2, 1.0 + 0.5 * i, 1.4 + 0.5 * i, sagittal=0.6, peak=0.05) for i in range(6))
    ev, _ = _run(Scene(5.0, swings, yaw_deg=200.0))
    assert len(ev.lifts) == 6
    kinds = _kinds(ev, 0) + _kinds(ev, 1)
    assert kinds.count("forward") > 0.5 * len(kinds)


def test_a_jump_is_both_feet_together() -> None:
    joints, _ = render(Scene(5.0, jumps=((1.0, 1.4, 0.15), (3.0, 3.3, 0.08))))
    tr = StepTracker()
    frames = [tr.update(f, i / FPS) for i, f in enumerate(noisy(joints, 0.012, 0.02))]
    lifts = [(fr.t, k) for fr in frames for k in (0, 1) if fr.feet[k].lifted]
    assert len(lifts) == 4
    for fr in frames:  # the first foot up sees the other one rising: never a lone step
        for k in (0, 1):
            f, other = fr.feet[k], fr.feet[1 - k]
            if not f.planted:
                assert f.jump or (other.planted and other.rising) or not other.planted, fr.t
    assert all(fr.feet[0].jump and fr.feet[1].jump for fr in frames if not fr.both_planted and fr.t > 1.2)


def test_crouching_and_kneeling_low_are_crouched_with_feet_planted() -> None:
    ev, _ = _run(Scene(8.0, crouch=((1.0, 6.0, 0.4),)))
    t = np.arange(len(ev.crouched)) / FPS
    assert ev.crouched[(t > 2.0) & (t < 5.0)].all()
    assert not ev.crouched[t < 0.9].any()
    assert all(ev.jump[~ev.planted]), "only the feet moving together as the body rises"


def test_a_slow_rise_moves_the_anchor_not_a_step() -> None:
    joints, _ = render(Scene(6.0))
    j = joints.copy()
    j[:, :, 2] += np.clip((np.arange(len(j)) / FPS - 1.0) / 3.0, 0, 1)[:, None] * 0.05  # 5 cm over 3 s
    ev = step_evidence(noisy(j, 0.01), FPS)
    assert len(ev.lifts) == 0


def test_a_foot_unknown_for_long_is_unknown() -> None:
    joints, _ = render(Scene(4.0))
    j = joints.copy()
    j[60:90, 15] = np.nan
    ev = step_evidence(j, FPS)
    assert ev.known[50, 0] and not ev.known[85, 0] and ev.known[95, 0] and ev.known[:, 1].all()
    assert len(ev.lifts) == 0, "a foot that reappears where it was has not stepped"


def test_streaming_equals_the_whole_sequence_and_checks_input() -> None:
    joints, _ = render(Scene(3.0, march(0.5, 4, 0.5, 0.3)))
    tr = StepTracker()
    frames = [tr.update(f, i / FPS) for i, f in enumerate(joints)]
    ev = step_evidence(joints, FPS)
    assert [f.feet[0].planted for f in frames] == ev.planted[:, 0].tolist()
    assert frames[-1].to_dict()["feet"][0]["foot"] == "left"  # type: ignore[index]
    with pytest.raises(ValueError, match="increase"):
        tr.update(joints[0], 0.0)
    with pytest.raises(ValueError, match=r"\(17, 3\)"):
        tr.update(np.zeros((16, 3)), 10.0)
    with pytest.raises(ValueError, match="lift_up"):
        StepConfig(lift_up=0.0)


def _jog(t0: float, steps: int, period: float, swing: float, peak: float) -> tuple[Swing, ...]:
    """Running in place: the feet alternate every ``period`` / 2 and each stays up ``swing`` seconds,
    so both are in the air for swing - period / 2 (flight) and each stands only period - swing."""
    starts = [t0 + i * period / 2 for i in range(steps)]
    return tuple(Swing(i % 2, s, s + swing, peak=peak) for i, s in enumerate(starts))


@pytest.mark.parametrize(("period", "swing"), [(0.7, 0.5), (0.6, 0.43)])
def test_running_feet_land_in_their_short_stances(period: float, swing: float) -> None:
    """A jog's stance lasts 0.17 s: too short for the smoothed ankle to come to rest, so the touch-down
    is read from the raw foot point of the last three frames (and no running step is a jump)."""
    swings = _jog(1.0, 14, period, swing, 0.15)
    ev, _ = _run(Scene(6.0, swings), sigma=0.005, drop=0.0)
    landed = [
        s for s in swings
        if len(ev.lands[(ev.lands[:, 1] == s.foot) & (np.abs(ev.lands[:, 0] - s.t1) < 0.12)]) == 1
    ]  # fmt: skip
    lifted = [
        s for s in swings
        if len(ev.lifts[(ev.lifts[:, 1] == s.foot) & (np.abs(ev.lifts[:, 0] - s.t0) < 0.12)]) == 1
    ]  # fmt: skip
    assert len(landed) >= len(swings) - 1, f"{len(landed)} of {len(swings)} touch-downs seen"
    assert len(lifted) >= len(swings) - 1, f"{len(lifted)} of {len(swings)} lift-offs seen"
    assert not ev.jump.any(), "the feet of a jog leave the floor in turn: no jump"


def test_a_fast_foot_is_followed_not_taken_for_an_outlier() -> None:
    """A sprinting foot moves 30 cm between frames: it is where the foot was heading, not an outlier;
    the same 30 cm off the foot's path in one frame still is one (the outliers test above)."""
    swings = (Swing(1, 1.0, 1.4, sagittal=1.6, peak=0.35), Swing(1, 2.5, 2.9, sagittal=-1.6, peak=0.35))
    ev, _ = _run(Scene(4.0, swings), sigma=0.003, drop=0.0)
    for s in swings:
        land = ev.lands[ev.lands[:, 1] == 1][:, 0]
        assert np.min(np.abs(land - s.t1)) < 0.1, f"touch-downs at {land}, the foot landed at {s.t1}"
        inside = slice(round((s.t0 + 0.1) * FPS), round((s.t1 - 0.05) * FPS))
        moved = np.abs(np.diff(ev.sagittal_m[inside, 1]))
        assert (moved > 0.01).all(), f"the foot is followed every frame, not in jumps: {np.round(moved, 2)}"
        i = round((s.t1 + 0.3) * FPS)  # after the touch-down: the step's whole displacement
        assert abs(ev.sagittal_m[i, 1] - s.sagittal) < 0.1, (
            f"the right foot's step measured {ev.sagittal_m[i, 1]:.2f} m, it went {s.sagittal:.2f} m"
        )
    assert len(ev.lifts) == 2 and len(ev.lands) == 2, f"lifts {ev.lifts}, lands {ev.lands}"


def _straddle(width_m: float) -> np.ndarray:
    """Step each foot ``width_m`` out sideways, legs kept straight: the pelvis drops as the legs
    spread (a wide side step or a straddle, no knee bent; the knees 1 cm in front of the
    hip-ankle line)."""
    out = (Swing(0, 1.0, 1.5, lateral=-width_m), Swing(1, 2.0, 2.5, lateral=width_m))
    joints, _ = render(Scene(6.0, out))
    j = joints.copy()
    hips, knees, ankles = (J["l_hip"], J["r_hip"]), (J["l_knee"], J["r_knee"]), (J["l_ankle"], J["r_ankle"])
    leg = np.linalg.norm(joints[0, hips[0]] - joints[0, ankles[0]])
    for i in range(len(j)):
        off = max(np.linalg.norm(j[i, hips[k], :2] - j[i, ankles[k], :2]) for k in (0, 1))
        drop = (j[i, hips[0], 2] - j[i, ankles[0], 2]) - np.sqrt(max(leg**2 - off**2, 0.0))
        upper = [n for n in range(j.shape[1]) if n not in (*knees, *ankles)]
        j[i, upper, 2] -= max(drop, 0.0)
        for k in (0, 1):
            j[i, knees[k]] = 0.5 * (j[i, hips[k]] + j[i, ankles[k]]) + np.array([0.0, 0.01, 0.0])
    return j


def test_a_wide_stance_with_straight_legs_is_no_crouch() -> None:
    """The pelvis drops below the crouch ratio when the feet are far apart, without any knee bent:
    not a crouch. The same pelvis height with bent knees (the crouch test above) is one."""
    j = _straddle(0.6)
    t = np.arange(len(j)) / FPS
    ev = step_evidence(noisy(j, 0.012, 0.02), FPS)
    assert ev.pelvis_ratio[t > 3.0].max() < StepConfig().crouch_ratio, "the pelvis is that low"
    assert not ev.crouched.any()
    strict = step_evidence(noisy(j, 0.012, 0.02), FPS, StepConfig(crouch_straight=1.0))
    assert strict.crouched[t > 3.0].all(), "by the pelvis alone it would be a crouch"
    with pytest.raises(ValueError, match="crouch_straight"):
        StepConfig(crouch_straight=0.0)


@pytest.mark.parametrize("sideways", [False, True])
def test_a_kick_raises_the_leg_a_march_step_does_not(sideways: bool) -> None:
    """The leg's raise (hip to ankle, from straight down, forward or to the side): a kick's reaches
    its height; standing legs hang (the gate's kick rule, ``test_bout.py``, rests on this)."""
    swing = Swing(1, 1.0, 1.9, peak=0.05)
    joints, _ = render(Scene(3.0, (swing,)))
    kicked = kick(joints, swing, 80.0, sideways)
    tr = StepTracker()
    frames = [tr.update(f, i / FPS) for i, f in enumerate(noisy(kicked, 0.012))]
    raise_r = np.array([f.feet[1].raise_deg for f in frames])
    raise_l = np.array([f.feet[0].raise_deg for f in frames])
    t = np.arange(len(frames)) / FPS
    assert 72.0 < raise_r.max() < 88.0, raise_r.max()
    assert raise_r[t < 0.9].max() < 12.0 and raise_l.max() < 12.0, "standing legs hang"
    assert frames[45].to_dict()["feet"][1]["raise_deg"] == pytest.approx(raise_r[45], abs=0.06)


@pytest.mark.parametrize("duration_s", [0.5, 0.6])
def test_a_slow_low_slide_is_reported_as_a_step(duration_s: float) -> None:
    """A shuffle without a visible lift: the right foot slides 8 cm out and back, four times, each
    slide taking half a second. Each slide is a step the tracker reports (a lift-off, then a
    touch-down in a later frame, sideways): its lift-off is back-dated to where the slide began, and
    with ``defer_landing`` off it landed in the same frame and no step was ever reported (0 of 4)."""
    swings = tuple(
        Swing(1, 2.0 + 1.5 * i, 2.0 + 1.5 * i + duration_s, lateral=0.08 if i % 2 == 0 else -0.08, peak=0.0)
        for i in range(4)
    )
    joints, _ = render(Scene(9.0, swings))
    j = noisy(joints, 0.012, 0.02, 0)
    ev = step_evidence(j, FPS)
    assert len(ev.lifts) == len(ev.lands) == 4, (ev.lifts, ev.lands)
    assert (ev.lifts[:, 1] == 1).all()
    for (lift, _), (land, _), sw in zip(ev.lifts, ev.lands, swings, strict=True):
        assert sw.t0 - 0.2 <= lift < land <= sw.t1 + 0.4, (lift, land, sw)
    kinds = {KINDS[k] for k in ev.kind[:, 1][~ev.planted[:, 1]]}
    assert kinds & {"open", "close"}, kinds
    unseen = step_evidence(j, FPS, StepConfig(defer_landing=False))
    assert len(unseen.lifts) < 4


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_quick_way_back_and_out_again_is_two_steps(seed: int) -> None:
    """Side steps out and back: the right foot stands 18 cm out, comes back beside the left one,
    reaches the floor there as it turns and goes straight out again (the step out begins two frames
    before the way back has settled), three times. The way back and the step out are two steps
    each (the turnaround splits the swing, ``StepConfig.turn_split``): the way back lands beside the
    other foot ("close"), the step out lifts off there and lands out ("open"). Merged (the split
    off), they cancel (fewer touch-downs; the step looks like a march). A dance's quick tap, out
    and straight back, and the same forwards (a treadmill's stance sliding back) stay one swing:
    only a turnaround beside the other foot splits."""

    def turns(lateral: float, sagittal: float) -> tuple[Swing, ...]:
        out = [Swing(1, 1.5, 1.9, lateral=lateral, sagittal=sagittal, peak=0.06)]
        for i in range(3):
            t0 = 2.5 + 1.5 * i
            out.append(Swing(1, t0, t0 + 0.4, lateral=-lateral, sagittal=-sagittal, peak=0.06))
            out.append(Swing(1, t0 + 0.333, t0 + 0.733, lateral=lateral, sagittal=sagittal, peak=0.06))
        return tuple(out)

    joints, _ = render(Scene(8.0, turns(0.18, 0.0)))
    j = noisy(joints, 0.012, 0.02, seed)
    ev = step_evidence(j, FPS)
    assert len(ev.lands) == 7 and (ev.lands[:, 1] == 1).all(), ev.lands
    for i in range(3):  # each way back touched down where it turned; each step out lifted there
        t_turn = 2.5 + 1.5 * i + 0.37
        assert any(abs(t - t_turn) <= 0.15 for t, _ in ev.lands), (t_turn, ev.lands)
        assert any(abs(t - t_turn) <= 0.2 for t, _ in ev.lifts), (t_turn, ev.lifts)
    kinds = [KINDS[ev.kind[round(t * FPS), 1]] for t, _ in ev.lands[1:]]
    assert kinds == ["close", "open"] * 3, kinds
    merged = step_evidence(j, FPS, StepConfig(turn_split=False))
    assert len(merged.lands) < 7, merged.lands

    for lateral, sagittal in ((0.0, 0.18), (0.18, 0.0)):  # forwards; a tap out and straight back
        swings = tuple(
            sw
            for i in range(3)
            for sw in (
                Swing(1, 2.0 + 1.5 * i, 2.4 + 1.5 * i, lateral=lateral, sagittal=sagittal, peak=0.06),
                Swing(1, 2.333 + 1.5 * i, 2.733 + 1.5 * i, lateral=-lateral, sagittal=-sagittal, peak=0.06),
            )
        )
        jo = noisy(render(Scene(8.0, swings))[0], 0.012, 0.02, seed)
        on, off = step_evidence(jo, FPS), step_evidence(jo, FPS, StepConfig(turn_split=False))
        assert len(on.lands) == len(off.lands), (lateral, sagittal, on.lands, off.lands)
