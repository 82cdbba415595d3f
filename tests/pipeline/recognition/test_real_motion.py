"""The live recogniser on real people's motion capture that ships in the repository
(facebookresearch/AnimatedDrawings', yuki-koyama/bvh11's and a CMU take's BVH clips,
`pipeline/mocap/vendored/`; evaluation only, never trained on): gestures, jumps, jumping jacks,
twists, bending over, a crouch and deep squats never move the person, dance footwork hardly does,
a slow real walk is one command from its first step, and standing after a real walk's kick, with
the feet slid apart, is still."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pipeline.mocap.fetch import PACKAGES, convert_bvh, load_catalogue, vendored_members
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig
from pipeline.skeleton import SkeletonSequence

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def clips() -> dict[str, SkeletonSequence]:
    out = {}
    for package in ("animated-drawings", "bvh11", "monoform-previs-studio"):
        specs = [c for c in load_catalogue() if c.package == package]
        files = vendored_members(PACKAGES[package], [c.path for c in specs])
        out.update({c.id: convert_bvh(files[c.path].decode("latin-1"), c) for c in specs})
    return out


def _commands(seq: SkeletonSequence, config: RecognizerConfig | None = None) -> np.ndarray:
    rec = ActionRecognizer.from_config(config or RecognizerConfig())
    return np.array([rec.update(j, i / seq.fps).label for i, j in enumerate(seq.joints_m)])


@pytest.mark.parametrize("clip", ["ad-wave-hello", "ad-jumping", "ad-cmu-jumping-jacks"])
def test_real_gestures_and_jumps_never_move(clips: dict[str, SkeletonSequence], clip: str) -> None:
    """A wave with the feet planted, a standing long jump of ~2 m into a deep crouch, and four
    jumping jacks (both feet leave and land together): not one frame of movement."""
    got = _commands(clips[clip])
    assert set(got) == {"still"}, f"{clip}: {np.sum(got != 'still')} frames moving"


def test_real_dance_footwork_is_mostly_still(clips: dict[str, SkeletonSequence]) -> None:
    """Hip-hop footwork on the spot: both feet slide and lift in turn, and for up to 2 s neither is in
    contact. A foot that swings while the other is also up counts as a run's step only if the other
    lifted at most ``run_swing_s`` (0.6 s) ago, or the full-body network is sure of movement
    (``run_still_prob``: p(still) at most 0.05): a runner's feet overlap in the air briefly, and the
    network knows a run. Before that rule the dance was called left or right in 23.7 % of its frames
    (0.9 s in one stretch: the first rule alone also fixed it, but lost our simulator's runs whose
    landing the tracker missed); now 6.2 %."""
    seq = clips["ad-dab"]
    got = _commands(seq)
    tags = np.asarray(seq.tags)
    dance = tags == "dance"
    assert dance.sum() > 150
    moving = float(np.mean(got[dance] != "still"))
    assert moving <= 0.10, f"the dance called moving in {moving:.1%} of its frames"


def test_a_real_low_crouch_after_a_dance_never_moves(clips: dict[str, SkeletonSequence]) -> None:
    """The dab's end: the dancer drops into a low crouch (pelvis at 0.55 m) and holds the pose."""
    seq = clips["ad-dab"]
    got = _commands(seq)
    assert set(got[np.asarray(seq.tags) == "crouch"]) == {"still"}


def test_a_real_slow_walk_is_one_command_from_its_first_step(clips: dict[str, SkeletonSequence]) -> None:
    """A slow zombie walk (arms held forward, ~0.7 m/s) from standing: forward within 0.1 s of the
    first lift-off, and forward in at least 90 % of its walking frames (98.2 % now: one drop of
    0.33 s after the first steps; the two turns are not scored)."""
    seq = clips["ad-zombie"]
    got = _commands(seq)
    labels = np.asarray(seq.labels)
    walking = labels == "forward"
    first_step, first_call = np.flatnonzero(walking)[0], np.flatnonzero(got != "still")[0]
    assert 0 <= (first_call - first_step) / seq.fps <= 0.1
    assert np.mean(got[walking] == "forward") >= 0.9
    assert not np.any(np.isin(got[walking], ["left", "right"]))


def test_standing_after_a_real_walk_that_ends_in_a_kick_and_a_wide_stance_is_still(
    clips: dict[str, SkeletonSequence],
) -> None:
    """CMU 131_02 ("Start Walk Stop", a stylised strut): the walk is forward in every scored frame;
    at its end the right leg kicks forward (0.6 m high) and, while it is still up, the left foot
    slides 0.2 m out to the side; the kick lands with the feet 0.54 m apart and the person stands.
    That slide lifted off while the other foot was up in the air, so it starts no bout
    (``GateConfig.start_air_m``): the standing frames are all still. Without the rule they were
    called `left` for 0.8 s (the pause a foot out to the side holds)."""
    seq = clips["cmu-131-02-walk-stop"]
    labels, tags = np.asarray(seq.labels), np.asarray(seq.tags)
    walking = labels == "forward"
    standing_after = (labels == "still") & (np.arange(len(labels)) > np.flatnonzero(walking)[-1])
    assert walking.sum() > 150 and standing_after.sum() > 20 and "walk-styled" in set(tags)
    got = _commands(seq)
    assert (got[walking] == "forward").all()
    assert (got[standing_after] == "still").all(), f"{(got[standing_after] != 'still').sum()} frames moving"
    base = RecognizerConfig()
    without = _commands(seq, replace(base, gate_config=replace(base.gate_config, start_air_m=float("inf"))))
    assert (without[standing_after] != "still").sum() / seq.fps > 0.5


def test_real_exercises_on_the_spot_never_move(clips: dict[str, SkeletonSequence]) -> None:
    """CMU 13_29: jumping jacks, twists of the upper body, bending forward and two deep squats (the
    pelvis down to 0.31 m), all with the feet on the spot: still, but for the hold after the high knee
    raises just before the squats (ignored: the recogniser calls them a march) that runs into the
    first squat's first 0.5 s, and 2 frames before the knee raises."""
    seq = clips["cmu-13-29-exercises"]
    tags = np.asarray(seq.tags)
    got = _commands(seq)
    for tag in ("jumping-jacks", "twist"):
        moving = int((got[tags == tag] != "still").sum())
        assert moving == 0, f"{tag}: {moving} frames moving"
    assert (got[tags == "bend"] != "still").sum() <= 3
    squat = np.flatnonzero(tags == "squat")
    assert len(squat) > 150
    assert (got[squat[int(0.5 * seq.fps):]] == "still").all()
