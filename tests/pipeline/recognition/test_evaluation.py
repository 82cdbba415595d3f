"""The fast replay used for tuning and the ablations gives the streaming recogniser's commands; the
corpus helpers (resampling, mirroring) keep labels where they belong."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pipeline.recognition.corpus import mirrored, resample
from pipeline.recognition.dataset import LabelledSequence
from pipeline.recognition.evaluation import network_trace, replay
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig, recognize_sequence
from pipeline.skeleton import ACTIONS, J

from .kinematic import Scene, Swing, march, noisy, render

FPS = 30.0


@pytest.mark.parametrize("gate", [False, True])
def test_replay_gives_the_streaming_commands(gate: bool) -> None:
    swings = (*march(1.0, 8, 0.55, 0.35), Swing(0, 6.0, 6.4, lateral=-0.3, peak=0.05))
    joints, _ = render(Scene(8.0, swings, yaw_deg=40.0))
    j = noisy(joints, 0.012, 0.02, seed=1)
    config = RecognizerConfig(gate=gate)
    rec = ActionRecognizer.from_config(config)
    est = recognize_sequence(rec, j, FPS)
    streamed = np.array([ACTIONS.index(e.label) for e in est])
    replayed = replay(network_trace(rec.session, j, FPS), config)
    assert (streamed == replayed).all(), np.flatnonzero(streamed != replayed)
    assert all(e.steps is not None for e in est)
    assert all((e.gate is not None) == gate for e in est)
    if gate:
        assert est[-1].gate is not None and est[-1].gate.to_dict()["command"] in ACTIONS


def test_replay_gives_the_streaming_commands_on_another_models_captured_minute() -> None:
    """A minute of the eighth motion model (its own noise and lost joints): the step tracker's
    timestamps in the replay are the streaming recogniser's to the last bit (a swing 3 frames long
    is 0.1 s in both, or in neither), so no threshold on a duration flips between them."""
    from pipeline.sim.blind6 import make_record

    j = make_record(60606, 3, 1800)["joints"].astype(np.float64)
    config = RecognizerConfig()
    rec = ActionRecognizer.from_config(config)
    streamed = np.array([ACTIONS.index(e.label) for e in recognize_sequence(rec, j, FPS)])
    replayed = replay(network_trace(rec.session, j, FPS), config)
    assert (streamed == replayed).all(), np.flatnonzero(streamed != replayed)


def _seq() -> LabelledSequence:
    joints, contacts = render(Scene(2.0, (Swing(0, 0.5, 0.9, lateral=-0.2),)))
    labels = np.zeros(len(joints), dtype=np.int64)
    labels[15:27] = ACTIONS.index("left")
    tags = np.array(["side"] * len(joints))
    return LabelledSequence(joints, FPS, labels, tags, contacts, "unit", "s")


def test_mirroring_swaps_sides_and_side_step_labels() -> None:
    s = _seq()
    m = mirrored(s)
    assert (m.labels[15:27] == ACTIONS.index("right")).all() and (m.labels[:15] == 0).all()
    np.testing.assert_allclose(m.joints_m[:, J["r_ankle"], 0], -s.joints_m[:, J["l_ankle"], 0])
    assert (m.contacts == s.contacts[:, ::-1]).all()  # type: ignore[index]
    np.testing.assert_allclose(mirrored(m).joints_m, s.joints_m)


def test_resampling_keeps_timing_and_labels() -> None:
    s = _seq()
    r = resample(s, 60.0)
    assert r.fps == 60.0 and len(r) == 2 * len(s) - 1
    t_left = np.flatnonzero(r.labels == ACTIONS.index("left"))[[0, -1]] / 60.0
    np.testing.assert_allclose(t_left, [15 / FPS, 26 / FPS], atol=0.02)
    fast = resample(s, FPS, speed=1.25)
    assert len(fast) == int((len(s) - 1) / 1.25) + 1 and fast.name.endswith("@x1.25")
    assert replace(s, name="x").name == "x"
