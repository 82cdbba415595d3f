"""The blind generator (pipeline.sim.blind): physics of its motion, its label rules, its files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pipeline.sim.blind import (
    Body,
    Generated,
    NoiseConfig,
    SequenceConfig,
    Style,
    generate_sequence,
    generate_set,
    sample_body,
    sample_style,
    write_set,
)
from pipeline.sim.blind.__main__ import main
from pipeline.sim.blind.script import MOVING_LABELS, Bout, Move, frame_labels, stepping_runs
from pipeline.sim.blind.timing import LAWS, progress, swing_height
from pipeline.skeleton import ACTIONS, LABELS, J, load_npz

FPS = 30.0
STEP_TAGS = {"march", "side-step-out-back", "step-touch", "shuffle"}
RIGID = {
    "thigh": (("l_hip", "l_knee"), ("r_hip", "r_knee")),
    "shank": (("l_knee", "l_ankle"), ("r_knee", "r_ankle")),
    "upper arm": (("l_shoulder", "l_elbow"), ("r_shoulder", "r_elbow")),
    "forearm": (("l_elbow", "l_wrist"), ("r_elbow", "r_wrist")),
    "hips": (("l_hip", "r_hip"),),
    "shoulders": (("l_shoulder", "r_shoulder"),),
    "face": (
        ("nose", "l_eye"),
        ("nose", "r_eye"),
        ("l_eye", "l_ear"),
        ("r_eye", "r_ear"),
        ("l_ear", "r_ear"),
    ),
}


def runs(values: tuple[str, ...] | list[str]) -> list[tuple[str, int, int]]:
    """(value, first, last) of each run of equal values."""
    out: list[tuple[str, int, int]] = []
    for k, v in enumerate(values):
        if out and out[-1][0] == v:
            out[-1] = (v, out[-1][1], k)
        else:
            out.append((v, k, k))
    return out


def facing_from_hips(joints: np.ndarray) -> np.ndarray:
    """Yaw (deg, 0 = +Y, counter-clockwise) the hips face: the left→right hip vector turned by +90°."""
    v = joints[:, J["r_hip"], :2] - joints[:, J["l_hip"], :2]
    return np.degrees(np.arctan2(v[:, 1], v[:, 0]))  # right vector (cos a, sin a) belongs to yaw a


def angle_diff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    return np.abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


@pytest.fixture(scope="module")
def people() -> list[Generated]:
    """Four random 60 s people (the set generator's own draws)."""
    return generate_set(count=4, duration_s=60.0, seed=11)


@pytest.fixture(scope="module")
def programme() -> Generated:
    """One person doing every kind of activity once, in a fixed order."""
    rng = np.random.default_rng(5)
    acts = (
        "march",
        "out-back-right",
        "step-touch-left",
        "shuffle-right",
        "wave",
        "point",
        "reach",
        "look-around",
        "turn",
        "weight-shift",
        "stretch",
        "bow",
        "squat",
        "stand",
        "out-back-left",
        "step-touch-right",
    )
    cfg = SequenceConfig(duration_s=120.0, yaw_deg=-120.0, centre_xy=(0.3, -0.4), activities=acts)
    return generate_sequence(cfg, sample_body(rng, 1.7), sample_style(rng), NoiseConfig(), rng)


def everyone(people: list[Generated], programme: Generated) -> list[Generated]:
    return [*people, programme]


# ---- configuration -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Body(height_m=1.0), "height_m"),
        (lambda: Body(height_m=1.7, thigh_ratio=0.4), "thigh_ratio"),
        (lambda: Body(height_m=float("nan")), "height_m"),
        (lambda: Style(cadence_hz=3.0), "cadence_hz"),
        (lambda: Style(march_lift_m=0.5), "march_lift_m"),
        (lambda: Style(law="bouncy"), "law"),
        (lambda: Style(peak_frac=0.6, hold_frac=0.3), "peak_frac"),
        (lambda: NoiseConfig(noise_m=-0.01), "noise_m"),
        (lambda: NoiseConfig(dropout=0.7), "dropout"),
        (lambda: SequenceConfig(duration_s=1.0), "duration_s"),
        (lambda: SequenceConfig(centre_xy=(0.9, 0.9)), "centre_xy"),
        (lambda: SequenceConfig(yaw_deg=270.0), "yaw_deg"),
        (lambda: SequenceConfig(activities=("moonwalk",)), "activities"),
        (lambda: Move(0, 10, 11, (0, 0), (0, 0), 0, 0, 0.05, "cosine", 0.4, 0, 0.1, 0), "on_f"),
        (lambda: Move(2, 10, 20, (0, 0), (0, 0), 0, 0, 0.05, "cosine", 0.4, 0, 0.1, 0), "foot"),
        (lambda: Bout("march", "forward", 0, 10), "needs foot moves"),
        (lambda: Bout("x", "jump", 0, 10), "label"),
    ],
)
def test_bad_configs_are_refused(make, match) -> None:
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize(
    "make",
    [
        lambda: Body(height_m=1.48),
        lambda: Body(height_m=1.98, thigh_ratio=0.27),
        lambda: Style(),
        lambda: Style(cadence_hz=0.6, march_lift_m=0.03, arm_swing_deg=0.0),
        lambda: Style(cadence_hz=2.4, march_lift_m=0.25, law="quick"),
        lambda: NoiseConfig(noise_m=0.0, dropout=0.0),
        lambda: SequenceConfig(duration_s=5.0, centre_xy=(0.6, -0.7), activities=("wave",)),
    ],
)
def test_good_configs_are_accepted(make) -> None:
    make()


def test_sampled_styles_stay_in_bounds() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        sample_style(rng)  # Style.__post_init__ checks every field
        sample_body(rng, float(rng.uniform(1.48, 1.98)))


@pytest.mark.parametrize("law", LAWS)
def test_timing_laws_go_from_0_to_1_monotonically(law: str) -> None:
    x = np.linspace(0.0, 1.0, 201)
    p = progress(law, x)
    assert p[0] == pytest.approx(0.0) and p[-1] == pytest.approx(1.0), law
    assert np.all(np.diff(p) >= -1e-12), f"{law} goes backwards"
    h = swing_height(law, x, 0.4, 0.1)
    assert h.max() == pytest.approx(1.0) and h[0] == pytest.approx(0.0) and h[-1] == pytest.approx(0.0)


# ---- physics -------------------------------------------------------------------------------------


def stance_slides(ankle: np.ndarray, contact: np.ndarray) -> list[tuple[int, float]]:
    """(first frame, largest distance from where it landed) of each contact period of one foot."""
    out = []
    for down, first, last in runs(list(contact)):
        if down:
            out.append((first, float(np.linalg.norm(ankle[first : last + 1] - ankle[first], axis=1).max())))
    return out


def test_the_slide_check_sees_a_sliding_foot() -> None:
    ankle = np.zeros((40, 3))
    ankle[25:, 0] = np.linspace(0.0, 0.02, 15)  # slides 2 cm while down
    contact = np.r_[np.ones(10, bool), np.zeros(10, bool), np.ones(20, bool)]
    assert stance_slides(ankle, contact) == [(0, 0.0), (20, pytest.approx(0.02))]


def test_stance_feet_do_not_slide(people, programme) -> None:
    for g in everyone(people, programme):
        ankle_h = g.body.length("ankle_ratio")
        for foot, name in ((0, "l_ankle"), (1, "r_ankle")):
            a = g.clean.joints_m[:, J[name]]
            for first, slide in stance_slides(a, g.clean.contact[:, foot]):
                assert slide < 0.01, (
                    f"{g.sequence.source}: {name} slides {slide:.4f} m in stance from {first}"
                )
            down = g.clean.contact[:, foot]
            assert np.allclose(a[down, 2], ankle_h, atol=1e-9), f"{name} in contact but off the floor"


def test_swing_feet_clear_the_floor_by_their_lift(people, programme) -> None:
    n_moves = 0
    for g in everyone(people, programme):
        ankle_h = g.body.length("ankle_ratio")
        for m in g.script.moves:
            z = (
                g.clean.joints_m[m.off_f + 1 : m.on_f, J["l_ankle" if m.foot == 0 else "r_ankle"], 2]
                - ankle_h
            )
            assert not g.clean.contact[m.off_f + 1 : m.on_f, m.foot].any(), "a swinging foot is in contact"
            assert g.clean.contact[m.off_f, m.foot] and g.clean.contact[m.on_f, m.foot], "lift-off/touch-down"
            assert z.min() > 0.0, f"swing foot at or below the floor at {m.off_f}"
            assert z.max() >= 0.9 * m.lift_m, f"peak {z.max():.3f} m < lift {m.lift_m:.3f} m at {m.off_f}"
            assert z.max() <= m.lift_m + 1e-9, f"peak {z.max():.3f} m above lift {m.lift_m:.3f} m"
            n_moves += 1
    assert n_moves > 100


def test_march_lifts_follow_the_style(people) -> None:
    for g in people:
        lifts = [m.lift_m for b in g.script.bouts if b.tag == "march" for m in b.moves]
        assert lifts, "every random person marches"
        assert min(lifts) >= 0.03 and max(lifts) <= 0.25
        assert np.median(lifts) == pytest.approx(g.style.march_lift_m, rel=0.2)


def test_bones_keep_their_length(people, programme) -> None:
    for g in everyone(people, programme):
        jt = g.clean.joints_m
        for bone, pairs in RIGID.items():
            for a, b in pairs:
                d = np.linalg.norm(jt[:, J[a]] - jt[:, J[b]], axis=1)
                assert d.max() - d.min() < 1e-6, f"{bone} {a}-{b} varies by {d.max() - d.min():.2e} m"
        thigh = np.linalg.norm(jt[:, J["l_hip"]] - jt[:, J["l_knee"]], axis=1)
        assert thigh.mean() == pytest.approx(g.body.length("thigh_ratio"))
        shank = np.linalg.norm(jt[:, J["r_knee"]] - jt[:, J["r_ankle"]], axis=1)
        assert shank.mean() == pytest.approx(g.body.length("shank_ratio"))


def test_knees_bend_forwards_and_stay_between_floor_and_hip(people) -> None:
    for g in people:
        jt = g.clean.joints_m
        fwd = np.stack([-np.sin(np.radians(g.clean.yaw_deg)), np.cos(np.radians(g.clean.yaw_deg))], axis=1)
        for side in ("l", "r"):
            hip, knee, ankle = (jt[:, J[f"{side}_{n}"]] for n in ("hip", "knee", "ankle"))
            mid = 0.5 * (hip + ankle)
            ahead = np.sum((knee - mid)[:, :2] * fwd, axis=1)
            assert ahead.min() > -0.02, f"{side} knee bends backwards by {-ahead.min():.3f} m"
            assert np.all(knee[:, 2] < hip[:, 2]) and np.all(knee[:, 2] > 0.0)


def test_standing_body_has_human_proportions(people) -> None:
    for g in people:
        first = g.clean.joints_m[0]
        h = g.body.height_m
        assert first[J["nose"], 2] == pytest.approx(0.92 * h, rel=0.05), "nose height"
        assert first[J["l_shoulder"], 2] == pytest.approx(0.818 * h, rel=0.06), "shoulder height"
        assert first[J["r_hip"], 2] == pytest.approx(0.53 * h, rel=0.06), "hip height"
        assert first[J["l_wrist"], 2] < first[J["l_hip"], 2], "arms hang down at rest"


def test_facing_matches_the_configured_yaw(people, programme) -> None:
    for g in everyone(people, programme):
        hips = facing_from_hips(g.clean.joints_m)
        assert angle_diff(hips[0], g.config.yaw_deg) < 2.0, (
            f"starts facing {hips[0]:.1f}, asked {g.config.yaw_deg}"
        )
        assert angle_diff(g.clean.yaw_deg[0], g.config.yaw_deg) < 0.5
        err = angle_diff(hips, g.clean.yaw_deg)
        assert err.max() < 10.0, f"hips face {err.max():.1f}° away from the truth"
        # the nose is in front of the ears unless the head is turned far round
        ears = 0.5 * (g.clean.joints_m[:, J["l_ear"]] + g.clean.joints_m[:, J["r_ear"]])
        fwd = np.stack([-np.sin(np.radians(hips)), np.cos(np.radians(hips))], axis=1)
        ahead = np.sum((g.clean.joints_m[:, J["nose"], :2] - ears[:, :2]) * fwd, axis=1)
        p = g.script.posture
        turned = np.abs(p.head_yaw_deg + p.trunk_twist_deg) > 60.0
        bent = g.style.trunk_lean_deg + g.style.head_pitch_deg + p.trunk_pitch_deg + p.head_pitch_deg > 60.0
        assert np.all(ahead[~turned & ~bent] > 0.0), "the face looks backwards"


def test_a_turn_changes_the_facing_and_keeps_the_place(programme) -> None:
    g = programme
    (turn,) = [b for b in g.script.bouts if b.tag == "turn"]
    before, after = g.clean.yaw_deg[turn.start_f], g.clean.yaw_deg[min(turn.end_f + 15, len(g.sequence) - 1)]
    assert angle_diff(before, after) > 35.0, "a turn turns"
    assert angle_diff(facing_from_hips(g.clean.joints_m[[turn.end_f + 15]])[0], after) < 10.0
    mid0 = g.clean.joints_m[turn.start_f, [J["l_ankle"], J["r_ankle"]], :2].mean(axis=0)
    mid1 = g.clean.joints_m[turn.end_f, [J["l_ankle"], J["r_ankle"]], :2].mean(axis=0)
    assert np.linalg.norm(mid1 - mid0) < 0.05, "turning on the spot"


def test_people_stay_near_their_place(people) -> None:
    for g in people:
        assert math.hypot(*g.config.centre_xy) <= 1.0
        pelvis = g.clean.pelvis_m[:, :2]
        assert np.linalg.norm(pelvis, axis=1).max() < 1.5
        assert np.linalg.norm(pelvis - np.asarray(g.config.centre_xy), axis=1).max() < 0.6


# ---- behaviours ----------------------------------------------------------------------------------


def bout_of(g: Generated, tag: str) -> Bout:
    return next(b for b in g.script.bouts if b.tag == tag)


def test_standing_behaviours_keep_the_feet_down_and_look_right(programme) -> None:
    g = programme
    jt = g.clean.joints_m
    for tag in ("wave", "point", "reach", "look-around", "weight-shift", "stretch", "bow", "squat", ""):
        b = bout_of(g, tag)
        assert g.clean.contact[b.start_f : b.end_f + 1].all(), f"{tag or 'standing'} lifts a foot"
    b = bout_of(g, "wave")
    k = (b.start_f + b.end_f) // 2
    assert (
        max(
            jt[k, J["l_wrist"], 2] - jt[k, J["l_shoulder"], 2],
            jt[k, J["r_wrist"], 2] - jt[k, J["r_shoulder"], 2],
        )
        > 0.1
    )
    b = bout_of(g, "stretch")
    k = (b.start_f + b.end_f) // 2
    assert min(jt[k, J["l_wrist"], 2], jt[k, J["r_wrist"], 2]) > jt[k, J["nose"], 2], (
        "stretch: hands above the head"
    )
    b = bout_of(g, "squat")
    z = g.clean.pelvis_m[b.start_f : b.end_f + 1, 2]
    assert z[0] - z.min() > 0.12, f"squat drops the pelvis only {z[0] - z.min():.3f} m"
    b = bout_of(g, "bow")
    fwd = np.array(
        [-np.sin(np.radians(g.clean.yaw_deg[b.start_f])), np.cos(np.radians(g.clean.yaw_deg[b.start_f]))]
    )
    neck = 0.5 * (jt[:, J["l_shoulder"]] + jt[:, J["r_shoulder"]])
    lean = ((neck - g.clean.pelvis_m)[b.start_f : b.end_f + 1, :2] @ fwd).max()
    assert lean > 0.12, f"bow leans the shoulders only {lean:.3f} m forwards"
    b = bout_of(g, "weight-shift")
    mid = 0.5 * (jt[:, J["l_ankle"]] + jt[:, J["r_ankle"]])
    shift = np.linalg.norm((g.clean.pelvis_m - mid)[b.start_f : b.end_f + 1, :2], axis=1).max()
    assert shift > 0.02, f"weight shift moves the pelvis only {shift:.3f} m"


def test_side_steps_go_the_labelled_way(people, programme) -> None:
    checked = 0
    for g in everyone(people, programme):
        jt, labels = g.clean.joints_m, g.sequence.labels
        assert labels is not None
        for label, first, _last in runs(labels):
            if label not in ("left", "right"):
                continue
            # the first lifting foot, its lift-off and touch-down frames
            lifted = [f for f in (0, 1) if g.clean.contact[first - 1, f] and not g.clean.contact[first, f]]
            assert len(lifted) == 1, f"{label} run at {first} does not start with one foot's lift-off"
            foot = lifted[0]
            land = first + int(np.argmax(g.clean.contact[first:, foot]))
            ankle = J["l_ankle" if foot == 0 else "r_ankle"]
            hips = facing_from_hips(jt[[first - 1]])[0]
            right = np.array([math.cos(math.radians(hips)), math.sin(math.radians(hips))])
            lateral = float((jt[land, ankle, :2] - jt[first - 1, ankle, :2]) @ right)
            sign = 1.0 if label == "right" else -1.0
            assert sign * lateral > 0.07, f"{label} run at {first}: foot moves {lateral:+.3f} m to the right"
            assert foot == (1 if label == "right" else 0), f"{label} run led by the other foot"
            checked += 1
    assert checked >= 10


def test_marching_steps_in_place(people, programme) -> None:
    for g in everyone(people, programme):
        for b in g.script.bouts:
            if b.tag != "march":
                continue
            for m in b.moves:
                moved = np.linalg.norm(np.subtract(m.end_xy, m.start_xy))
                assert moved < 0.05, f"a march step moves the foot {moved:.3f} m"
            assert {m.foot for m in b.moves} == {0, 1}, "marching alternates the feet"


# ---- labels --------------------------------------------------------------------------------------


def test_labels_follow_the_rules(people, programme) -> None:
    for g in everyone(people, programme):
        seq, c = g.sequence, g.clean.contact
        assert seq.labels is not None and seq.tags is not None
        assert set(seq.labels) <= set(ACTIONS)
        assert (list(seq.labels), list(seq.tags)) == frame_labels(g.script)
        for label, first, last in runs(seq.labels):
            if label == "still":
                continue
            assert any(c[first - 1, f] and not c[first, f] for f in (0, 1)), (
                f"{label} at {first}: no lift-off"
            )
            assert any(c[last, f] and not c[last - 1, f] for f in (0, 1)), f"{label} to {last}: no touch-down"
            both = c[first : last + 1].all(axis=1)
            longest = max((e - s + 1 for v, s, e in runs(list(both)) if v), default=0)
            assert longest <= FPS * 1.0, f"{label} at {first} keeps its label {longest / FPS:.2f} s standing"
            assert set(seq.tags[first : last + 1]) <= STEP_TAGS
        airborne = ~c.all(axis=1)
        for k in np.flatnonzero(airborne):
            assert seq.labels[k] in MOVING_LABELS or seq.tags[k] == "turn", (
                f"frame {k}: a foot is up, label still"
            )
        for k, (label, tag) in enumerate(zip(seq.labels, seq.tags, strict=True)):
            assert (label in MOVING_LABELS) == (tag in STEP_TAGS), (
                f"frame {k}: label {label} with tag {tag!r}"
            )


def test_a_long_pause_splits_a_bout_and_a_short_one_does_not() -> None:
    def step(off: int, on: int) -> Move:
        return Move(1, off, on, (0, 0), (0.2, 0), 0, 0, 0.05, "cosine", 0.4, 0, 0.1, 0)

    short = Bout(
        "side-step-out-back", "right", 0, 100, (step(10, 25), step(25 + 29, 70))
    )  # 30 frames = 1.0 s
    assert stepping_runs(short, FPS) == [(11, 70)]
    long = Bout("side-step-out-back", "right", 0, 100, (step(10, 25), step(25 + 30, 70)))  # 31 frames down
    assert stepping_runs(long, FPS) == [(11, 25), (56, 70)]


def test_every_person_does_all_three_movements(people) -> None:
    for g in people:
        assert g.sequence.labels is not None and g.sequence.tags is not None
        assert set(g.sequence.labels) == set(ACTIONS), g.sequence.source
        assert "turn" in g.sequence.tags
        standing = set(g.sequence.tags) - STEP_TAGS - {"", "turn"}
        assert len(standing) >= 2, f"only {standing} while standing"


# ---- files and noise -----------------------------------------------------------------------------


def test_write_set_writes_spec_files(tmp_path: Path) -> None:
    paths = write_set(tmp_path / "a", count=2, duration_s=12.0, seed=5)
    assert [p.name for p in paths] == ["blind_5_00.npz", "blind_5_01.npz"]
    with np.load(paths[0]) as raw:
        assert set(raw.files) >= {"joints", "fps", "labels", "tags", "contacts"}
        assert raw["joints"].shape == (360, 17, 3) and raw["contacts"].dtype == np.bool_
        assert float(raw["fps"]) == FPS
    for p in paths:
        seq = load_npz(p)
        assert len(seq) == 360 and seq.contacts is not None and seq.contacts.shape == (360, 2)
        assert set(seq.labels or ()) <= set(LABELS)
        nan = np.isnan(seq.joints_m).any(axis=2).mean()
        assert 0.015 < nan < 0.025, f"dropped fraction {nan:.3f}"
        assert np.isnan(seq.joints_m).any(axis=2).sum() == np.isnan(seq.joints_m).sum() / 3, (
            "whole joints drop"
        )
    again = write_set(tmp_path / "b", count=2, duration_s=12.0, seed=5)
    other = write_set(tmp_path / "c", count=2, duration_s=12.0, seed=6)
    a, b, c = (load_npz(p[0]) for p in (paths, again, other))
    assert np.array_equal(a.joints_m, b.joints_m, equal_nan=True) and a.labels == b.labels, (
        "same seed, same set"
    )
    assert not np.array_equal(a.joints_m, c.joints_m, equal_nan=True), "another seed, another set"


def test_noise_has_the_configured_size(people) -> None:
    g = people[0]
    diff = g.sequence.joints_m - g.clean.joints_m
    ok = ~np.isnan(diff)
    assert diff[ok].std() == pytest.approx(0.012, rel=0.05)
    assert np.isnan(g.sequence.joints_m).any(axis=2).mean() == pytest.approx(0.02, abs=0.002)
    quiet = generate_sequence(
        g.config, g.body, g.style, NoiseConfig(noise_m=0.0, dropout=0.0), np.random.default_rng(0)
    )
    assert not np.isnan(quiet.sequence.joints_m).any()
    assert np.array_equal(quiet.sequence.joints_m, quiet.clean.joints_m)


def test_a_set_spreads_people_over_the_ranges() -> None:
    gs = generate_set(count=12, duration_s=6.0, seed=3, noise=NoiseConfig(0.0, 0.0))
    heights = sorted(g.body.height_m for g in gs)
    assert 1.48 <= heights[0] < 1.53 and 1.93 < heights[-1] <= 1.98
    cadences = sorted(g.style.cadence_hz for g in gs)
    assert cadences[0] < 0.75 and cadences[-1] > 2.0
    lifts = sorted(g.style.march_lift_m for g in gs)
    assert lifts[0] < 0.05 and lifts[-1] > 0.23
    yaws = [g.config.yaw_deg for g in gs]
    assert max(yaws) - min(yaws) > 180.0
    assert len({g.style.law for g in gs}) == len(LAWS)


def test_cli_writes_a_set(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(tmp_path), "--count", "1", "--seed", "9", "--duration", "8", "--summary"]) == 0
    assert (tmp_path / "blind_9_00.npz").is_file()
    assert "frames per label" in capsys.readouterr().out
    assert main([str(tmp_path / "x"), "--count", "0"]) == 2
    assert "count must be" in capsys.readouterr().err
    assert not (tmp_path / "x").exists(), "a refused set writes nothing"
