"""The blind2 generator (pipeline.sim.blind2): its files, its motion before noise, its label rules,
its command line, and a fingerprint of the first file of the held-out set (seed 2026)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from pipeline.sim.blind2 import (
    LABELS,
    TAGS,
    Generated,
    SetConfig,
    StepCounts,
    generate_sequence,
    generate_set,
    sample_body,
    save_set,
)
from pipeline.sim.blind2.__main__ import main
from pipeline.sim.blind2.behaviours import BEHAVIOURS
from pipeline.sim.blind2.channels import Balance, Channels
from pipeline.sim.blind2.feet import FootEvent, render_feet
from pipeline.sim.blind2.generate import FILE_KEYS, NAN_RATE, NOISE_SD_M, SOURCE
from pipeline.sim.blind2.geometry import facing_vec, right_vec, rot_x, rot_y, rot_z, two_link_ik
from pipeline.sim.blind2.motion import compose
from pipeline.sim.blind2.profiles import bump, envelope, min_jerk
from pipeline.sim.blind2.script import Planner
from pipeline.sim.blind2.truth import STEP_TAGS, STILL_BEHAVIOURS, Bout, Turn
from pipeline.skeleton import J, load_npz

FPS = 30.0
SEED = 13  # with two 30 s sequences: all four bout kinds, both sides and four turns
RIGID = (
    ("l_hip", "l_knee"),
    ("r_hip", "r_knee"),
    ("l_knee", "l_ankle"),
    ("r_knee", "r_ankle"),
    ("l_shoulder", "l_elbow"),
    ("r_shoulder", "r_elbow"),
    ("l_elbow", "l_wrist"),
    ("r_elbow", "r_wrist"),
    ("l_hip", "r_hip"),
    ("l_shoulder", "r_shoulder"),
    ("l_eye", "r_eye"),
    ("l_ear", "r_ear"),
    ("nose", "l_eye"),
    ("nose", "l_ear"),
)
ANKLES = ("l_ankle", "r_ankle")

# Sequence 0 of the held-out set (seed 2026, 60 s), recorded from blind2_2026_00.npz as the
# standalone generator wrote it: any change to the motion model or its random draws shows here.
FINGERPRINT_00 = {
    "labels": {"forward": 251, "left": 364, "right": 227, "still": 958},
    "tags": {
        "": 287,
        "cross-arms": 119,
        "look-around": 96,
        "march": 251,
        "point": 69,
        "shuffle": 401,
        "side-step-out-back": 190,
        "turn": 133,
        "weight-shift": 254,
    },
    "contacts": [1507, 1548],
    "nan_joints": 587,
    "mean_xyz": [-0.30484, -0.25264, 1.01646],
    "sd": 0.7159,
}


def runs(values: np.ndarray) -> list[tuple[object, int, int]]:
    """(value, first, length) of each run of equal values."""
    out: list[tuple[object, int, int]] = []
    start = 0
    for i in range(1, len(values) + 1):
        if i == len(values) or values[i] != values[start]:
            out.append((values[start], start, i - start))
            start = i
    return out


def line_yaw(left: np.ndarray, right: np.ndarray) -> float:
    """The facing yaw (rad) implied by a left→right joint pair (the right vector is (cos ψ, sin ψ))."""
    d = right - left
    return math.atan2(d[1], d[0])


def wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


@pytest.fixture(scope="module")
def pair() -> list[Generated]:
    """Two 30 s sequences of one set."""
    return generate_set(SetConfig(count=2, seed=SEED, duration_s=30.0))


@pytest.fixture(scope="module")
def files(pair: list[Generated], tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return save_set(tmp_path_factory.mktemp("blind2"), pair, SEED)


def all_bouts(pair: list[Generated]) -> list[tuple[Generated, Bout]]:
    return [(g, b) for g in pair for b in g.bouts]


# ---- configuration and records -------------------------------------------------------------------


def _body_with(**changes: object):
    return lambda: dataclasses.replace(sample_body(np.random.default_rng(0)), **changes)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: SetConfig(count=0), "count"),
        (lambda: SetConfig(count=1001), "count"),
        (lambda: SetConfig(count=2.5), "count"),  # type: ignore[arg-type]
        (lambda: SetConfig(seed=-1), "seed"),
        (lambda: SetConfig(duration_s=1.0), "duration_s"),
        (lambda: SetConfig(duration_s=float("nan")), "duration_s"),
        (_body_with(height_m=3.0), "height_m"),
        (_body_with(thigh_m=-0.1), "thigh_m"),
        (_body_with(ankle_height_m=0.2), "ankle_height_m"),
        (_body_with(head_m=np.zeros((4, 3))), "head_m"),
        (lambda: Balance(pelvis_drop_rad=-0.1, trunk_lean_rad=0.0), "pelvis_drop_rad"),
        (lambda: Channels({"kflex": np.zeros(5)}, 6), "kflex"),
        (lambda: FootEvent("hop", 0, 5, np.zeros(2), np.zeros(2), 0.0, 0.0), "kind"),  # type: ignore[arg-type]
        (lambda: FootEvent("swing", 5, 5, np.zeros(2), np.zeros(2), 0.0, 0.0), "start < end"),
        (lambda: FootEvent("swing", 0, 5, np.zeros(3), np.zeros(2), 0.0, 0.0), "xy points"),
        (lambda: Bout(0, 10, "jump", "march", 0.0, "left", ()), "label"),
        (lambda: Bout(0, 10, "left", "wave", 0.0, "left", ()), "tag"),
        (lambda: Bout(10, 10, "left", "shuffle", 0.0, "left", ()), "start < end"),
        (lambda: Bout(0, 10, "left", "shuffle", 0.0, "middle", ()), "first_foot"),
        (lambda: Turn(0, 10, 12, 5, 1.0, 3), "first_lift"),
    ],
)
def test_bad_configs_and_records_are_refused(make, match) -> None:
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize(
    "make",
    [
        lambda: SetConfig(),
        lambda: SetConfig(count=1, seed=0, duration_s=5.0),
        lambda: sample_body(np.random.default_rng(1)),
        lambda: Balance(pelvis_drop_rad=0.02, trunk_lean_rad=0.01),
        lambda: Bout(3, 40, "right", "step-together", 1.0, "right", (0.2, 0.3)),
        lambda: Turn(0, 30, 5, 25, -2.0, 3),
    ],
)
def test_good_configs_and_records_are_accepted(make) -> None:
    make()


def test_the_defaults_are_the_held_out_set() -> None:
    cfg = SetConfig()
    assert (cfg.count, cfg.seed, cfg.n_frames) == (12, 2026, 1800)
    assert set(BEHAVIOURS) == set(STILL_BEHAVIOURS), "every still behaviour has a function"
    assert LABELS == ("still", "forward", "left", "right")
    assert set(TAGS) == set(STEP_TAGS) | set(STILL_BEHAVIOURS)


# ---- the math ------------------------------------------------------------------------------------


def test_profiles_ramp_and_bump() -> None:
    t = np.linspace(0.0, 1.0, 101)
    ramp = min_jerk(t)
    assert ramp[0] == 0.0 and ramp[-1] == 1.0 and np.all(np.diff(ramp) >= 0)
    b = bump(t)
    assert b[0] == 0.0 and b[-1] < 1e-12 and b[50] == pytest.approx(1.0)
    w = envelope(30, 10, 5)
    assert w[0] < 0.05 and w[-1] < 0.1 and np.all(w[10:25] == 1.0)


def test_geometry_follows_the_cave_frame() -> None:
    assert np.allclose(facing_vec(0.0), [0.0, 1.0]), "yaw 0 faces +Y"
    assert np.allclose(right_vec(0.0), [1.0, 0.0]), "facing +Y, the right is +X and the left -X"
    assert np.allclose(facing_vec(math.pi / 2), [-1.0, 0.0]), "positive yaw turns counter-clockwise"
    for rot in (rot_x, rot_y, rot_z):
        r = rot(np.array([0.3, -1.2]))
        assert np.allclose(r @ r.transpose(0, 2, 1), np.eye(3)) and np.allclose(np.linalg.det(r), 1.0)
    root = np.zeros((2, 3))
    target = np.array([[0.1, 0.2, -0.7], [0.0, 0.0, -2.0]])
    pole = np.tile([0.0, 1.0, 0.0], (2, 1))
    mid, end, res = two_link_ik(root, target, 0.45, 0.43, pole)
    assert np.allclose(np.linalg.norm(mid - root, axis=1), 0.45)
    assert np.allclose(np.linalg.norm(end - mid, axis=1), 0.43)
    assert np.allclose(end[0], target[0]) and res[0] == pytest.approx(0.0)
    assert res[1] > 1.0, "an out-of-reach target leaves a residual"


# ---- files and noise -----------------------------------------------------------------------------


def test_files_have_the_documented_format(files: list[Path]) -> None:
    assert [p.name for p in files] == [f"blind2_{SEED}_00.npz", f"blind2_{SEED}_01.npz"]
    for path in files:
        with np.load(path, allow_pickle=False) as d:
            assert list(d.files) == list(FILE_KEYS)
            x, lab, tag, con = d["joints"], d["labels"], d["tags"], d["contacts"]
            n = x.shape[0]
            assert x.dtype == np.float32 and x.shape == (900, 17, 3)
            assert d["fps"].dtype == np.float64 and d["fps"].shape == () and float(d["fps"]) == FPS
            assert lab.dtype == np.dtype("<U7") and lab.shape == (n,)
            assert tag.dtype == np.dtype("<U18") and tag.shape == (n,)
            assert con.dtype == np.bool_ and con.shape == (n, 2)
            assert d["source"].shape == () and str(d["source"]) == SOURCE
            assert set(lab.tolist()) <= set(LABELS), "labels come from the four actions"
            assert set(tag.tolist()) <= set(TAGS) | {""}
            nan = np.isnan(x)
            assert np.array_equal(nan.any(-1), nan.all(-1)), "an unknown joint is NaN in all coordinates"
            assert np.all(lab[:60] == "still"), "the first 2 s are still"
        seq = load_npz(path)  # the product's reader takes the files as they are
        assert len(seq) == n and seq.source == SOURCE


def test_capture_noise_is_1_2_cm_with_2_percent_nan(pair: list[Generated]) -> None:
    for g in pair:
        x = g.joints_m.astype(np.float64)
        nan = np.isnan(x).any(-1)
        assert abs(nan.mean() - NAN_RATE) < 0.005, f"NaN share {nan.mean():.4f}"
        resid = (x - g.clean.joints_m)[~nan]
        assert abs(resid.std() - NOISE_SD_M) < 0.001, f"noise sd {resid.std():.4f}"
        assert abs(resid.mean()) < 0.001
        assert np.array_equal(g.contacts, g.clean.contacts)


# ---- the motion before noise ---------------------------------------------------------------------


def test_planted_ankles_stay_at_standing_height(pair: list[Generated]) -> None:
    for g in pair:
        ah = g.body.ankle_height_m
        assert 0.07 <= ah <= 0.09
        for f, name in enumerate(ANKLES):
            z = g.clean.joints_m[:, J[name], 2]
            planted = g.contacts[:, f]
            assert np.abs(z[planted] - ah).max() < 1e-6, f"{name} planted off its standing height"
            assert z.min() > ah - 1e-6, f"{name} below the standing level"


def test_legs_reach_and_bones_keep_their_length(pair: list[Generated]) -> None:
    for g in pair:
        assert np.abs(g.clean.ik_residual_m).max() < 1e-4, "every ankle is within the leg's reach"
        x = g.clean.joints_m
        for a, b in RIGID:
            length = np.linalg.norm(x[:, J[a]] - x[:, J[b]], axis=1)
            assert length.std() < 1e-6 * max(length.mean(), 1.0), f"{a}-{b} changes length"


def test_feet_are_never_both_up_and_only_turns_lift_outside_bouts(pair: list[Generated]) -> None:
    for g in pair:
        con = g.contacts
        assert not (~con[:, 0] & ~con[:, 1]).any(), "no flight phase"
        lifted = ~(con[:, 0] & con[:, 1])
        bad = lifted & (g.labels == "still") & (g.tags != "turn")
        assert not bad.any(), f"a foot lifts in {bad.sum()} still frames that are no turn"


@pytest.mark.parametrize("name", STILL_BEHAVIOURS)
def test_each_still_behaviour_keeps_the_feet_down(name: str) -> None:
    rng = np.random.default_rng(3)
    p = Planner(rng, 450, StepCounts())
    p.stand(1.0)
    BEHAVIOURS[name](p, p.n_frames - p.cur - 18)
    assert [b.tag for b in p.behaviours] == [name], f"{name} fits in 14 s"
    b = p.body
    feet = render_feet(p.feet, p.n_frames, b.ankle_height_m, b.thigh_m, b.shank_m)
    motion = compose(b, feet, p.channels, p.balance, p.rng)
    beh = p.behaviours[0]
    assert np.all(p.tags[beh.start : beh.end + 1] == name) and np.all(p.labels == "still")
    lifted = ~motion.contacts.all(axis=1)
    if name == "turn":
        assert lifted.any() and not (~motion.contacts).all(axis=1).any(), "a turn steps, one foot at a time"
        assert len(p.turns) == 1
    else:
        assert not lifted.any(), f"{name} lifts a foot"
    length = np.linalg.norm(motion.joints_m[:, J["l_hip"]] - motion.joints_m[:, J["l_knee"]], axis=1)
    assert length.std() < 1e-9


# ---- bouts and labels ----------------------------------------------------------------------------


def test_bouts_follow_the_label_rules(pair: list[Generated]) -> None:
    for g in pair:
        lab, tag, con = g.labels, g.tags, g.contacts
        n = len(lab)
        in_bout = np.zeros(n, dtype=bool)
        for b in g.bouts:
            a, e = b.start, b.end
            in_bout[a : e + 1] = True
            assert np.all(lab[a : e + 1] == b.label), "no bout mixes directions"
            assert np.all(tag[a : e + 1] == b.tag)
            assert lab[a - 1] == "still" and (e + 1 >= n or lab[e + 1] == "still"), "bounded by still"
            assert (~con[a + 1]).any() and (~con[e - 1]).any(), "a bout runs from lift-off to touch-down"
        assert np.array_equal(in_bout, lab != "still"), "every stepping frame belongs to a bout"
        for value, start, length in runs(tag):
            if value in STEP_TAGS:
                assert np.all(lab[start : start + length] != "still"), f"{value} labelled still"
            else:
                assert np.all(lab[start : start + length] == "still"), f"'{value}' labelled stepping"
        label_runs = runs(lab)
        for k, (value, start, length) in enumerate(label_runs):
            if value == "still" and 0 < k < len(label_runs) - 1:
                assert length >= 45, f"only {length} still frames between bouts at {start}"


def test_pauses_inside_bouts_are_at_most_1_s(pair: list[Generated]) -> None:
    gaps = []
    for g, b in all_bouts(pair):
        both_down = g.contacts[b.start : b.end + 1].all(axis=1)
        for value, start, length in runs(both_down):
            if value and start > 0 and start + length < len(both_down):
                gaps.append((length - 1) / FPS)
    assert gaps and max(gaps) <= 1.0 + 1e-9, f"longest gap {max(gaps):.2f} s"


def test_side_bouts_start_with_the_sides_foot_moving_to_that_side(pair: list[Generated]) -> None:
    seen = set()
    for g, b in all_bouts(pair):
        if b.label == "forward":
            continue
        con, clean, noisy = g.contacts, g.clean.joints_m, g.joints_m.astype(np.float64)
        a, e = b.start, b.end
        first_lift = [
            int((~con[a : e + 1, f]).argmax()) if (~con[a : e + 1, f]).any() else 10**9 for f in (0, 1)
        ]
        foot = int(np.argmin(first_lift))
        assert foot == (0 if b.label == "left" else 1), f"a {b.label} bout opens with the other foot"
        j = J[ANKLES[foot]]
        touch = a + int(np.argmax(con[a + 1 : e + 1, foot])) + 1
        rgt = right_vec(b.yaw_rad)
        side = float((clean[touch, j, :2] - clean[a, j, :2]) @ rgt)
        noisy_side = float(
            (np.nanmean(noisy[touch : touch + 4, j, :2], 0) - np.nanmean(noisy[max(0, a - 6) : a, j, :2], 0))
            @ rgt
        )
        sign = -1.0 if b.label == "left" else 1.0
        assert sign * side > 0.05 and sign * noisy_side > 0.02, (
            f"{b.label} bout: the first foot moves {side:+.3f} m (noisy {noisy_side:+.3f}) to the right"
        )
        seen.add(b.label)
    assert seen == {"left", "right"}, "the fixture has bouts to both sides"


def test_marching_stays_in_place(pair: list[Generated]) -> None:
    marches = [(g, b) for g, b in all_bouts(pair) if b.label == "forward"]
    assert marches
    for g, b in marches:
        rgt, fwd = right_vec(b.yaw_rad), facing_vec(b.yaw_rad)
        for name in ANKLES:
            net = g.clean.joints_m[b.end, J[name], :2] - g.clean.joints_m[b.start, J[name], :2]
            assert abs(net @ rgt) < 0.1 and abs(net @ fwd) < 0.35, f"march travels {net}"


def test_pelvis_moves_over_the_stance_foot(pair: list[Generated]) -> None:
    for g, b in all_bouts(pair):
        x, con = g.clean.joints_m[b.start : b.end + 1], g.contacts[b.start : b.end + 1]
        pelvis = 0.5 * (x[:, J["l_hip"], :2] + x[:, J["r_hip"], :2])
        feet = x[:, J["l_ankle"], :2], x[:, J["r_ankle"], :2]
        for f in (0, 1):
            single = con[:, f] & ~con[:, 1 - f]
            if single.sum() > 3:
                axis = feet[f][single] - feet[1 - f][single]
                axis /= np.linalg.norm(axis, axis=1, keepdims=True)
                mid = 0.5 * (feet[0][single] + feet[1][single])
                shift = np.mean(np.sum((pelvis[single] - mid) * axis, 1))
                assert shift > 0.01, f"{b.tag}: the pelvis moves {shift:+.3f} m toward the stance foot"


def test_turns_rotate_hips_and_shoulders(pair: list[Generated]) -> None:
    turns = [(g, t) for g in pair for t in g.turns]
    assert turns
    for g, t in turns:
        clean, noisy = g.clean.joints_m, g.joints_m.astype(np.float64)
        a, b = t.start, t.end
        planned = math.degrees(t.yaw_change_rad)
        assert 45.0 <= abs(planned) <= 180.0
        for left, right in (("l_hip", "r_hip"), ("l_shoulder", "r_shoulder")):
            jl, jr = J[left], J[right]
            turned = line_yaw(clean[b, jl], clean[b, jr]) - line_yaw(clean[a, jl], clean[a, jr])
            n0 = line_yaw(np.nanmean(noisy[a : a + 8, jl], 0), np.nanmean(noisy[a : a + 8, jr], 0))
            n1 = line_yaw(np.nanmean(noisy[b - 7 : b + 1, jl], 0), np.nanmean(noisy[b - 7 : b + 1, jr], 0))
            err = wrap_deg(math.degrees(turned) - planned)
            noisy_err = wrap_deg(math.degrees(n1 - n0) - planned)
            assert abs(err) < 12 and abs(noisy_err) < 20, f"{left[2:]} off by {err:.1f}° ({noisy_err:.1f}°)"
        ankles = [J["l_ankle"], J["r_ankle"]]
        lift = clean[t.first_lift : t.last_touch + 1, ankles, 2].max() - g.body.ankle_height_m
        assert 0.005 < lift < 0.06, f"pivot steps lift {lift:.3f} m"


# ---- determinism and the held-out set ------------------------------------------------------------


def test_generation_is_reproducible() -> None:
    one = generate_sequence(5, 0, StepCounts(), 300)
    two = generate_sequence(5, 0, StepCounts(), 300)
    assert np.array_equal(one.joints_m, two.joints_m, equal_nan=True)
    assert np.array_equal(one.labels, two.labels) and np.array_equal(one.tags, two.tags)


def test_sequence_0_of_the_held_out_set_matches_its_fingerprint() -> None:
    g = generate_sequence(2026, 0, StepCounts(), SetConfig().n_frames)
    labels, n_labels = np.unique(g.labels, return_counts=True)
    tags, n_tags = np.unique(g.tags, return_counts=True)
    x = g.joints_m.astype(np.float64)
    got = {
        "labels": dict(zip(labels.tolist(), n_labels.tolist(), strict=True)),
        "tags": dict(zip(tags.tolist(), n_tags.tolist(), strict=True)),
        "contacts": g.contacts.sum(0).tolist(),
        "nan_joints": int(np.isnan(x).any(-1).sum()),
        "mean_xyz": np.round(np.nanmean(x, axis=(0, 1)), 5).tolist(),
        "sd": round(float(np.nanstd(x)), 5),
    }
    assert got == FINGERPRINT_00, "the motion model or its random draws changed"


# ---- command line --------------------------------------------------------------------------------


def test_cli_writes_a_set(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "set"
    assert main([str(out), "--count", "2", "--seed", "4", "--duration", "8", "--summary"]) == 0
    printed = capsys.readouterr().out.splitlines()
    paths = [out / "blind2_4_00.npz", out / "blind2_4_01.npz"]
    assert printed[:2] == [str(p) for p in paths]
    assert all(p.is_file() for p in paths)
    assert printed[2].startswith("frames per label:")
    assert len(load_npz(paths[0])) == 240


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--count", "0"], "count must be"),
        (["--count", "two"], "invalid int value"),
        (["--seed", "-1"], "seed must be"),
        (["--duration", "2"], "duration_s must be"),
        (["--bogus"], "unrecognized arguments"),
    ],
)
def test_cli_refuses_bad_arguments(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], match: str
) -> None:
    out = tmp_path / "set"
    assert main([str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and match in err, err
    assert "Traceback" not in err
    assert not out.exists(), "a refused set writes nothing"


def test_cli_refuses_a_file_as_out_dir_and_a_missing_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    taken = tmp_path / "taken"
    taken.write_text("keep me")
    assert main([str(taken), "--count", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "not a folder" in err
    assert taken.read_text() == "keep me" and sorted(tmp_path.iterdir()) == [taken]
    assert main([]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "out_dir" in err
