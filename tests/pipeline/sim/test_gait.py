"""The second motion model (pipeline.sim.gait): physical sanity, labels, asked-for parameters."""

from __future__ import annotations

import json
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from pipeline.sim.gait import GaitConfig, GaitTake, make_body, simulate_routine
from pipeline.sim.gait.anthropometry import BodyConfig
from pipeline.sim.gait.curves import WALK_KNEE, WALK_THIGH, fit
from pipeline.sim.gait.kinematics import Ch
from pipeline.sim.gait.stepping import GaitParams, MarchParams, SideParams, gait, march, side_steps
from pipeline.sim.gait.support import solve
from pipeline.sim.gait.track import DEG, Track, neutral, sample_style
from pipeline.skeleton import LABELS, J, load_npz

ROOT = Path(__file__).resolve().parents[3]
FPS = 30.0
MOVES = ("forward", "left", "right")


@cache
def routine(seed: int) -> GaitTake:
    return simulate_routine(GaitConfig(duration_s=40.0, fps=FPS), seed)


def _single(behave, yaw: float = 0.3, height: float = 1.75, seed: int = 0):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    body = make_body(height)
    style = sample_style(rng)
    track = Track(FPS, neutral(style, yaw))
    track.hold(0.5)
    behave(track, body, rng)
    track.hold(0.5)
    prog = track.build()
    return body, prog, solve(body, prog, FPS)


def _march(cadence: float, lift: float = 0.15, steps: int = 10, arm: float = 20 * DEG) -> MarchParams:
    return MarchParams(cadence, lift, steps, 0, 0.65, 15 * DEG, arm, 0.0, 0.0, 0.0, 0.02, 2 * DEG,
                       -10 * DEG, -3 * DEG)


@pytest.mark.parametrize("seed", [1, 2])
def test_planted_feet_do_not_slide_and_soles_meet_the_floor(seed: int) -> None:
    take = routine(seed)
    prog, sol = take.programme, take.solved
    support = prog.contact & ~prog.slide
    for s in (0, 1):
        sole = np.stack([sol.heel[:, s], sol.ball[:, s]], 1)  # (T, 2 points, 3)
        lowest = sole[..., 2].min(axis=1)
        assert np.abs(lowest[prog.contact[:, s]]).max() < 1e-6, "a foot in contact is off the floor"
        assert lowest[~prog.contact[:, s]].min() > -1e-6, "a foot in the air is below the floor"
        on_floor = sole[..., 2] < 1e-6
        both = support[1:, s] & support[:-1, s]
        still_down = on_floor[1:] & on_floor[:-1] & both[:, None]
        moved = np.linalg.norm(sole[1:, :, :2] - sole[:-1, :, :2], axis=-1)
        assert moved[still_down].max() < 1e-6, "a planted point of a sole moved along the floor"
        pinned = support[:, s]
        gap = np.minimum(np.linalg.norm(sol.heel[:, s] - sol.pin[:, s], axis=1),
                         np.linalg.norm(sol.ball[:, s] - sol.pin[:, s], axis=1))
        assert gap[pinned].max() < 1e-6, "a supporting foot left its pin"
    assert np.nanmin(take.sequence.joints_m[..., 2]) > 0.0, "a joint went below the floor"


@pytest.mark.parametrize("seed", [1, 2])
def test_bone_lengths_are_constant(seed: int) -> None:
    j = routine(seed).sequence.joints_m
    for a, b in [("l_hip", "l_knee"), ("r_knee", "r_ankle"), ("l_shoulder", "l_elbow"),
                 ("r_elbow", "r_wrist"), ("l_hip", "r_hip"), ("l_shoulder", "r_shoulder"),
                 ("l_ear", "r_ear"), ("nose", "l_eye")]:
        length = np.linalg.norm(j[:, J[a]] - j[:, J[b]], axis=1)
        assert length.std() < 1e-6, f"{a}-{b} changes length by {length.std():.2e} m"


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_labels_follow_the_convention(seed: int) -> None:
    take = routine(seed)
    seq, prog = take.sequence, take.programme
    labels = np.array(seq.labels)
    assert set(labels) <= set(LABELS)
    assert seq.contacts is not None and np.array_equal(seq.contacts, prog.contact)
    assert seq.source == "gait"
    moving = (~prog.contact | prog.slide).any(axis=1)
    is_move = np.isin(labels, MOVES)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], is_move.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        assert moving[a], f"bout at frame {a} does not start with a foot leaving the floor"
        assert a == 0 or not moving[a - 1], f"a foot was already moving before the bout at {a}"
        if b < len(labels):
            assert moving[b - 2] and not moving[b - 1], f"bout {a}-{b} does not end at a touch-down"
        assert len(set(labels[a:b])) == 1, "one bout, one label"
    # Every frame with a foot off the floor is a bout, or a still behaviour with its tag.
    tags = np.array(seq.tags)
    odd = moving & ~is_move & ~np.isin(tags, ["turn", "kneel", "jump", ""])
    assert not odd.any(), f"feet move in still frames tagged {set(tags[odd])}"


def test_a_routine_mixes_behaviours_and_stays_in_the_room() -> None:
    take = simulate_routine(GaitConfig(duration_s=60.0, fps=FPS), 5)
    counts = {lb: take.sequence.labels.count(lb) for lb in set(take.sequence.labels)}
    assert counts.get("still", 0) > 0 and counts.get("forward", 0) > 0, counts
    assert len({t for t in take.sequence.tags if t}) >= 5
    radius = np.linalg.norm(take.solved.pelvis[:, :2], axis=1)
    assert radius.max() < 2.0, f"the person left the room: {radius.max():.2f} m from the centre"


@pytest.mark.parametrize("cadence", [0.6, 1.5, 2.5])
def test_marching_cadence_and_knee_lift_are_as_asked(cadence: float) -> None:
    lift = 0.12
    _body, prog, sol = _single(lambda t, b, r: march(t, b, _march(cadence, lift), r))
    lifts = [np.flatnonzero(~prog.contact[1:, s] & prog.contact[:-1, s]) + 1 for s in (0, 1)]
    starts = np.sort(np.concatenate(lifts))
    measured = (len(starts) - 1) / ((starts[-1] - starts[0]) / FPS)
    assert measured == pytest.approx(cadence, rel=0.1), f"asked {cadence} steps/s, made {measured:.2f}"
    knee = sol.joints[:, J["l_knee"], 2]
    assert knee.max() - knee[0] == pytest.approx(lift, rel=0.2)


def test_marching_in_place_does_not_travel() -> None:
    _body, prog, sol = _single(lambda t, b, r: march(t, b, _march(1.8, 0.2, steps=20), r))
    drift = np.linalg.norm(sol.pelvis[-1, :2] - sol.pelvis[0, :2])
    assert drift < 0.01, f"20 marching steps moved the body {drift * 100:.1f} cm"
    assert set(prog.labels) == {"still", "forward"} and set(prog.tags) == {"", "march"}


def test_walking_travels_forward_along_the_heading() -> None:
    yaw = 0.7
    _body, prog, sol = _single(lambda t, b, r: gait(t, b, GaitParams(1.9, 1.0, 2, False, 1.0, 0)), yaw=yaw)
    travel = sol.pelvis[-1, :2] - sol.pelvis[0, :2]
    heading = np.array([-np.sin(yaw), np.cos(yaw)])
    assert travel @ heading > 2.0, f"walked only {travel @ heading:.2f} m"
    assert abs(travel @ np.array([heading[1], -heading[0]])) < 0.1, "walked sideways"
    speed = np.linalg.norm(travel) / (prog.labels.count("forward") / FPS)
    assert 0.6 < speed < 1.8, f"walking speed {speed:.2f} m/s"


def test_running_has_flight_and_is_faster_than_walking() -> None:
    _, prog, sol = _single(lambda t, b, r: gait(t, b, GaitParams(2.9, 0.9, 3, True, 1.0, 1)))
    assert (~prog.contact).all(axis=1).any(), "no flight phase"
    speed = np.linalg.norm(sol.pelvis[-1, :2] - sol.pelvis[0, :2]) / (prog.labels.count("forward") / FPS)
    assert speed > 1.5, f"running at {speed:.2f} m/s"


@pytest.mark.parametrize("direction", [0, 1])
@pytest.mark.parametrize("kind", ["side-step-out-back", "step-together", "step-touch", "shuffle"])
def test_side_steps_go_to_the_persons_own_side(kind: str, direction: int) -> None:
    yaw, width = -1.1, 0.3
    params = SideParams(direction, kind, width, 2, 0.4, 0.3, 0.05, 0.02, 0.3, 0.0, -20 * DEG)
    _body, prog, sol = _single(lambda t, b, r: side_steps(t, b, params, r), yaw=yaw, seed=3)
    right = np.array([np.cos(yaw), np.sin(yaw)])
    sign = 1.0 if direction == 1 else -1.0
    ankle = sol.joints[:, J["r_ankle" if direction == 1 else "l_ankle"], :2]
    reach = ((ankle - ankle[0]) @ right * sign).max()
    asked = width * (2 if kind == "step-together" else 1)  # two cycles, each moving both feet
    assert reach == pytest.approx(asked, abs=0.03), f"{kind}: foot went {reach:.3f} m out, asked {asked}"
    assert {"left", "right"} & set(prog.labels) == {("left", "right")[direction]}
    travel = (sol.pelvis[-1, :2] - sol.pelvis[0, :2]) @ right * sign
    if kind == "step-together":
        assert travel == pytest.approx(2 * width, abs=0.03)
    elif kind != "shuffle":
        assert abs(travel) < 0.01
    if kind == "shuffle":
        assert prog.slide.any() or (~prog.contact).any()


def test_seeded_and_bodies_vary() -> None:
    a = simulate_routine(GaitConfig(duration_s=8.0), 11).sequence
    b = simulate_routine(GaitConfig(duration_s=8.0), 11).sequence
    c = simulate_routine(GaitConfig(duration_s=8.0), 12).sequence
    assert np.array_equal(a.joints_m, b.joints_m) and a.labels == b.labels
    assert not np.array_equal(a.joints_m, c.joints_m)
    heights = [simulate_routine(GaitConfig(duration_s=1.0, body=BodyConfig(1.4, 2.05)), s).body.height_m
               for s in range(12)]
    assert min(heights) >= 1.4 and max(heights) <= 2.05 and np.ptp(heights) > 0.3


def test_noise_and_dropout() -> None:
    clean = simulate_routine(GaitConfig(duration_s=5.0), 4).sequence
    noisy = simulate_routine(GaitConfig(duration_s=5.0, noise_m=0.012, dropout=0.02), 4).sequence
    missing = np.isnan(noisy.joints_m[..., 0]).mean()
    assert 0.01 < missing < 0.03
    diff = (noisy.joints_m - clean.joints_m)[~np.isnan(noisy.joints_m)]
    assert diff.std() == pytest.approx(0.012, rel=0.1)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fps": 0.0}, "fps must be"),
        ({"duration_s": -1.0}, "duration_s must be positive"),
        ({"mix": (("moonwalk", 1.0),)}, "unknown behaviours"),
        ({"mix": (("march", 0.0),)}, "at least one > 0"),
        ({"cadence": (2.0, 1.0)}, "cadence must be a range"),
        ({"dropout": 1.0}, "dropout in"),
    ],
)
def test_bad_config_is_rejected(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        GaitConfig(**kwargs)


def test_the_fitted_curves_keep_the_published_key_points() -> None:
    for points in (WALK_THIGH, WALK_KNEE):
        curve = fit(points)
        pct = np.array([p for p, _ in points]) / 100
        err = np.rad2deg(curve(pct)) - np.array([d for _, d in points])
        assert np.abs(err).max() < 4.0, f"fit misses a key point by {np.abs(err).max():.1f} deg"


def test_walking_angles_come_from_the_curves() -> None:
    """The knee reaches the published swing peak (about 60 deg) while walking at full amplitude."""
    _, prog, _ = _single(lambda t, b, r: gait(t, b, GaitParams(1.9, 1.0, 2, False, 1.0, 0)))
    knee = np.rad2deg(prog.angles[:, Ch.KNEE_L])
    assert 50 < knee.max() < 70


def test_make_gait_set_writes_spec_files(tmp_path: Path) -> None:
    out = tmp_path / "set"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_gait_set.py"), "--out", str(out), "--seed", "7",
         "--count", "2", "--duration-s", "6"],
        capture_output=True, text=True, cwd=ROOT, check=False,
    )
    assert proc.returncode == 0, proc.stderr
    index = json.loads((out / "index.json").read_text())
    assert [f["file"] for f in index["files"]] == ["gait_7_000.npz", "gait_7_001.npz"]
    for entry in index["files"]:
        seq = load_npz(out / entry["file"])
        assert len(seq) == 180 and seq.fps == 30.0 and seq.source == "gait"
        assert seq.labels is not None and seq.tags is not None and seq.contacts is not None
        assert {k: seq.labels.count(k) for k in set(seq.labels)} == entry["labels"]
    bad = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_gait_set.py"), "--out", str(out), "--count", "0"],
        capture_output=True, text=True, cwd=ROOT, check=False,
    )
    assert bad.returncode == 2 and "--count must be at least 1" in bad.stderr
