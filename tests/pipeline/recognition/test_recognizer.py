"""Streaming recognition with the committed ONNX model on simulated users, and the command filter."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import InputError, ModelError
from pipeline.recognition.evaluation import network_trace
from pipeline.recognition.recognizer import (
    DEFAULT_MODEL_PATH,
    ActionRecognizer,
    CommandFilter,
    RecognizerConfig,
    open_session,
    recognize_sequence,
)
from pipeline.recognition.train import NoiseConfig, capture
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.skeleton import ACTIONS, J

FPS = 30.0


@pytest.fixture(scope="module")
def recognizer() -> ActionRecognizer:
    return ActionRecognizer.from_config(RecognizerConfig())


def _routine(segments: tuple[Segment, ...], height: float, yaw: float, seed: int, noisy: bool = True):  # type: ignore[no-untyped-def]
    motion = simulate_user(
        MotionScript(segments, start_xy_m=(0.3, -0.2), start_yaw_deg=yaw),
        body_from_height(height),
        FPS,
        seed=seed,
    )
    joints = (
        capture(motion.joints_m, np.random.default_rng(seed), NoiseConfig(), FPS)
        if noisy
        else motion.joints_m
    )
    return motion, joints


# ------------------------------------------------------------------ the committed model


def test_committed_model_is_small_and_describes_itself() -> None:
    assert DEFAULT_MODEL_PATH.is_file(), "pipeline/recognition/action.onnx is committed"
    # sixteen networks of 47,244 parameters (eight per output, MODEL_CARD.md "Latest change"): 3.1 MiB
    assert DEFAULT_MODEL_PATH.stat().st_size < 4 * 1024 * 1024
    rec = ActionRecognizer.from_config(RecognizerConfig())
    assert rec.info.classes == ACTIONS and rec.info.fps == FPS and 30 <= rec.info.window <= 40


@pytest.mark.parametrize(
    ("action", "height", "yaw"),
    [
        ("still", 1.52, 0.0),
        ("turn", 1.9, 60.0),
        ("forward", 1.52, -120.0),
        ("forward", 1.93, 170.0),
        ("left", 1.7, 90.0),
        ("right", 1.6, -30.0),
    ],
)
def test_model_classifies_each_class_on_average(action: str, height: float, yaw: float) -> None:
    motion, joints = _routine((Segment(action, 4.0),), height, yaw, seed=11)
    session = open_session(DEFAULT_MODEL_PATH)
    # the network's output for the window ending at each frame (with the step evidence a v2 model needs)
    probs = network_trace(session, joints, FPS).raw[40:]
    mean = probs.mean(axis=0)
    want = ACTIONS.index(motion.labels[-1])
    assert int(np.argmax(mean)) == want, (
        f"{action}: mean probabilities {dict(zip(ACTIONS, mean.round(3), strict=True))}"
    )
    assert mean[want] > 0.6, f"{action}: mean probability of {ACTIONS[want]} only {mean[want]:.3f}"


def test_streaming_follows_a_routine(recognizer: ActionRecognizer) -> None:
    segs = (
        Segment("still", 3.0),
        Segment("forward", 4.0),
        Segment("left", 3.0),
        Segment("still", 3.0),
        Segment("right", 3.0),
        Segment("still", 2.0),
    )
    motion, joints = _routine(segs, 1.75, 45.0, seed=5)
    est = recognize_sequence(recognizer, joints, FPS)
    labels = np.array([e.label for e in est])
    truth = np.array(motion.labels)
    steady = np.ones(len(truth), bool)
    for i in np.flatnonzero(truth[1:] != truth[:-1]) + 1:
        steady[i : i + 15] = False  # half a second after each change
    acc = float(np.mean(labels[steady] == truth[steady]))
    assert acc > 0.9, f"steady-state accuracy {acc:.3f}"
    changes = int(np.sum(labels[1:] != labels[:-1]))
    assert changes <= 8, f"{changes} command changes for 5 true ones: flicker"
    yaw_err = np.abs((np.array([e.yaw_deg for e in est]) - motion.yaw_deg + 180) % 360 - 180)
    assert np.median(yaw_err[30:]) < 10.0
    speed = np.array([e.speed_mps for e in est])
    assert np.all(speed[labels == "still"] == 0.0)
    fwd = steady & (truth == "forward") & (labels == "forward")
    assert abs(np.median(speed[fwd]) - np.median(motion.speed_mps[fwd])) < 0.15
    for e in est[::50]:
        assert sum(e.probs.values()) == pytest.approx(1.0, abs=1e-4) and set(e.probs) == set(ACTIONS)


def test_the_clock_origin_changes_nothing(recognizer: ActionRecognizer) -> None:
    """A live clock (seconds since 1970) or a recording's (from 0): the same motion gives the same
    commands and gate verdicts, frame for frame. The tracker, filter and gate count time from the
    stream's first frame in whole model frames (no sum of 1/30 s steps drifting across a
    threshold that is a whole number of frames, such as the 0.1 s a swing must last)."""
    segs = (Segment("still", 2.0), Segment("forward", 4.0), Segment("still", 1.5), Segment("right", 3.0))
    _, joints = _routine(segs, 1.7, -20.0, seed=9)
    runs = []
    for origin in (0.0, 1_733_300_000.0):
        recognizer.reset()
        est = [recognizer.update(f, origin + i / FPS) for i, f in enumerate(joints)]
        runs.append(est)
    a, b = runs
    assert [e.label for e in a] == [e.label for e in b]
    assert [e.gate.reason for e in a if e.gate] == [e.gate.reason for e in b if e.gate]
    assert [e.steps.t for e in b if e.steps] == pytest.approx([i / FPS for i in range(len(joints))], abs=1e-9)


def test_sixty_fps_input_is_resampled(recognizer: ActionRecognizer) -> None:
    segs = (Segment("still", 2.5), Segment("forward", 3.5))
    m60 = simulate_user(MotionScript(segs, start_yaw_deg=10.0), body_from_height(1.8), 60.0, seed=2)
    est = recognize_sequence(recognizer, m60.joints_m, 60.0)
    assert len(est) == len(m60)
    labels = [e.label for e in est]
    assert labels[100:150].count("still") == 50, "still during the first 2.5 s"
    assert labels[-60:].count("forward") == 60, "forward in the last second"


def test_rejected_input_changes_nothing() -> None:
    _, joints = _routine((Segment("forward", 2.0),), 1.75, 0.0, seed=9, noisy=False)
    a = ActionRecognizer.from_config(RecognizerConfig())
    b = ActionRecognizer.from_config(RecognizerConfig())
    for i in range(40):
        a.update(joints[i], i / FPS)
        b.update(joints[i], i / FPS)
    with pytest.raises(InputError, match=r"\(17, 3\)"):
        a.update(np.zeros((16, 3)), 40 / FPS)
    with pytest.raises(InputError, match="increase"):
        a.update(joints[40], 39 / FPS)
    with pytest.raises(InputError, match="finite"):
        a.update(joints[40], float("nan"))
    assert a.update(joints[40], 40 / FPS) == b.update(joints[40], 40 / FPS)


def test_unknown_joints_and_gaps_are_tolerated(recognizer: ActionRecognizer) -> None:
    _, joints = _routine((Segment("forward", 4.0),), 1.65, 0.0, seed=4, noisy=False)
    j = joints.copy()
    j[:, [0, 1, 2, 3, 4]] = np.nan  # no face at all
    j[50:55] = np.nan  # nobody for a moment
    est = recognize_sequence(recognizer, j, FPS)
    assert [e.label for e in est[-30:]].count("forward") >= 27
    recognizer.reset()
    e0 = recognizer.update(joints[0], 0.0)
    e1 = recognizer.update(joints[1], 5.0)  # after a long gap the recogniser starts afresh
    assert e0.label == e1.label == "still"


def test_bad_model_files(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="not found"):
        ActionRecognizer.from_config(RecognizerConfig(model_path=tmp_path / "none.onnx"))
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"not a model")
    with pytest.raises(ModelError, match="cannot load"):
        ActionRecognizer.from_config(RecognizerConfig(model_path=junk))


def test_run_time_needs_no_torch() -> None:
    code = (
        "import sys, numpy as np\n"
        "from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig\n"
        "r = ActionRecognizer.from_config(RecognizerConfig())\n"
        "r.update(np.zeros((17, 3)), 0.0)\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=False,
        cwd=Path(__file__).resolve().parents[3],
    )
    assert proc.returncode == 0, proc.stderr


# ------------------------------------------------------------------ EMA + hysteresis


def test_filter_does_not_flicker_on_noisy_probabilities() -> None:
    rng = np.random.default_rng(0)
    f = CommandFilter(ema_alpha=0.5, min_dwell_s=0.1, switch_prob=0.5)
    labels = []
    for i in range(600):
        # forward wins on average, but still wins single frames a third of the time
        p = np.array([0.35, 0.55, 0.05, 0.05]) + rng.normal(0, 0.2, 4)
        p = np.clip(p, 0.01, None)
        labels.append(f.update(p / p.sum(), i / FPS))
    changes = int(np.sum(np.diff(labels) != 0))
    assert changes <= 2, f"{changes} command changes on a steady noisy input"
    assert labels[-1] == ACTIONS.index("forward")


def test_filter_ignores_a_short_spike_and_follows_a_real_change() -> None:
    still, fwd = np.eye(4)[0], np.eye(4)[1]
    f = CommandFilter(ema_alpha=0.5, min_dwell_s=0.1, switch_prob=0.5)
    seq = [still] * 10 + [fwd] * 2 + [still] * 10 + [fwd] * 10
    out = [f.update(p, i / FPS) for i, p in enumerate(seq)]
    assert out[:22] == [0] * 22, "a two-frame spike does not pass the dwell time"
    first = out.index(1)
    assert 22 < first <= 22 + 5, f"a real change passes after the dwell time, at frame {first}"


def test_filter_without_dwell_follows_the_ema_at_once() -> None:
    f = CommandFilter(ema_alpha=1.0, min_dwell_s=0.0, switch_prob=0.0)
    assert f.update(np.eye(4)[2], 0.0) == 2
    assert f.update(np.eye(4)[3], 0.033) == 3


def test_filter_counts_skipped_frames() -> None:
    a = CommandFilter(0.3, 0.0, 0.5)
    b = CommandFilter(0.3, 0.0, 0.5)
    p = np.array([0.1, 0.7, 0.1, 0.1])
    a.update(p, 0.0, ticks=3)
    for i in range(3):
        b.update(p, i / FPS)
    np.testing.assert_allclose(a.probs, b.probs)


@pytest.mark.parametrize(
    ("args", "match"),
    [((0.0, 0.1, 0.5), "ema_alpha"), ((0.5, -1.0, 0.5), "min_dwell_s"), ((0.5, 0.1, 2.0), "switch")],
)
def test_filter_bad_parameters(args: tuple[float, float, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        CommandFilter(*args)


def test_filter_rejects_bad_probabilities() -> None:
    f = CommandFilter(0.5, 0.1, 0.5)
    with pytest.raises(ValueError, match="4 finite"):
        f.update(np.array([0.5, np.nan, 0.2, 0.3]), 0.0)
    assert f.label == 0 and f.probs[0] == 1.0, "a rejected update leaves the filter as it was"


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_no_data_is_still_with_confidence_zero(value: float, caplog: pytest.LogCaptureFixture) -> None:
    rec = ActionRecognizer.from_config(RecognizerConfig())
    with caplog.at_level("WARNING", logger="pipeline.recognition.recognizer"):
        est = recognize_sequence(rec, np.full((100, 17, 3), value), FPS)
    assert all(e.label == "still" and e.confidence == 0.0 and e.no_data for e in est)
    assert all(e.speed_mps == 0.0 and sum(e.probs.values()) == 0.0 for e in est)
    warnings = [r for r in caplog.records if "no known leg joint" in r.getMessage()]
    assert len(warnings) == 1, "one warning for the stretch, not one per frame"


def test_a_navigator_whose_joints_go_unknown_stops_after_max_gap() -> None:
    """The live path: fusion keeps calling update() with the navigator's joints, now all unknown."""
    _, joints = _routine((Segment("forward", 7.0),), 1.75, 0.0, seed=4, noisy=False)
    rec = ActionRecognizer.from_config(RecognizerConfig(max_gap_s=0.5))
    for i in range(90):
        est = rec.update(joints[i], i / FPS)
    assert est.label == "forward"
    out = [rec.update(np.full((17, 3), np.nan), (90 + k) / FPS) for k in range(60)]
    held = [e for k, e in enumerate(out) if (k + 1) / FPS <= 0.5]
    assert all(e.label == "forward" for e in held), "a short dropout holds the command"
    assert all(e.label == "still" and e.confidence == 0.0 and e.no_data for e in out[20:])
    back = [rec.update(joints[150 + k], (150 + k) / FPS) for k in range(40)]
    assert not back[-1].no_data and back[-1].label == "forward", "data back: recognition resumes"


@pytest.mark.parametrize("seed", [3, 5])
def test_an_outlier_just_before_a_stretch_without_data_is_no_step(seed: int) -> None:
    """Standing, an ankle 25 cm off in the frame before four frames without any joint (a triangulation
    outlier as the person is lost for a moment): no command. The stretch is bridged from the median
    of the last three frames with data, not from the outlier (before: the glide from it was a smooth
    rise the step tracker took for a lift-off; ``scripts/eval_acquisition.py --seed 5000``: one
    standing person of 300 moved for 0.77 s). In a march, such a stretch keeps the command."""
    _, clean = _routine(
        (Segment("still", 4.0, gestures=()), Segment("forward", 5.0)), 1.75, 20.0, seed, noisy=False
    )
    j = clean + np.random.default_rng(seed).normal(0.0, 0.008, clean.shape)
    j[40, J["r_ankle"]] += (-0.09, -0.12, -0.2)
    j[41:45] = np.nan
    j[180:186] = np.nan
    labels = [e.label for e in recognize_sequence(ActionRecognizer.from_config(RecognizerConfig()), j, FPS)]
    moving = [i for i, lab in enumerate(labels[:120]) if lab != "still"]
    assert not moving, f"standing: {len(moving)} frames called moving, first at {moving[0] / FPS:.2f} s"
    assert all(lab == "forward" for lab in labels[175:190]), labels[175:190]


def test_arms_without_legs_is_no_data() -> None:
    _, joints = _routine((Segment("still", 2.0),), 1.75, 0.0, seed=4, noisy=False)
    j = joints.copy()
    j[:, 11:] = np.nan
    est = recognize_sequence(ActionRecognizer.from_config(RecognizerConfig()), j, FPS)
    assert all(e.no_data for e in est)


# ------------------------------------------------------------------ what the model says it expects


def _tiny_model(path: Path, channels: int, features: str | None) -> Path:
    """A real ONNX graph (mean over time, a fixed linear map, softmax) with the recogniser's metadata."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    w = numpy_helper.from_array(np.linspace(-1, 1, channels * 4, dtype=np.float32).reshape(channels, 4), "w")
    axes = numpy_helper.from_array(np.array([2], dtype=np.int64), "axes")
    nodes = [
        helper.make_node("ReduceMean", ["x", "axes"], ["m"], keepdims=0),
        helper.make_node("MatMul", ["m", "w"], ["z"]),
        helper.make_node("Softmax", ["z"], ["probs"], axis=1),
    ]
    graph = helper.make_graph(
        nodes, "tiny", [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["batch", channels, 32])],
        [helper.make_tensor_value_info("probs", TensorProto.FLOAT, ["batch", 4])], initializer=[w, axes],
    )  # fmt: skip
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)])
    model.ir_version = 9
    meta = {"window": "32", "fps": "30", "classes": ",".join(ACTIONS)}
    if features is not None:
        meta["features"] = features
    for k, v in meta.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = k, v
    onnx.save(model, str(path))
    return path


def test_the_recogniser_reads_and_checks_the_models_features(tmp_path: Path) -> None:
    v2 = ActionRecognizer.from_config(
        RecognizerConfig(model_path=_tiny_model(tmp_path / "v2.onnx", 135, "v2"))
    )
    assert v2.info.features == "v2"
    est = recognize_sequence(v2, np.tile(np.linspace(0, 1, 51).reshape(17, 3), (40, 1, 1)), FPS)
    assert len(est) == 40 and est[-1].steps is not None, "a v2 model is fed joints and step evidence"
    old = ActionRecognizer.from_config(
        RecognizerConfig(model_path=_tiny_model(tmp_path / "v1.onnx", 119, None))
    )
    assert old.info.features == "v1", "a model without the key is v1 (joints only)"
    with pytest.raises(ModelError, match="features 'v9'"):
        ActionRecognizer.from_config(
            RecognizerConfig(model_path=_tiny_model(tmp_path / "v9.onnx", 135, "v9"))
        )
    with pytest.raises(ModelError, match=r"\(B, 135, 32\) for features v2"):
        ActionRecognizer.from_config(
            RecognizerConfig(model_path=_tiny_model(tmp_path / "bad.onnx", 119, "v2"))
        )


def test_a_v3_model_does_not_see_the_arms_or_the_face(tmp_path: Path) -> None:
    """features v3: the same input layout as v2 with every joint but shoulders, hips, knees and
    ankles masked, so waving an arm or turning the head cannot change what the network says."""
    from pipeline.recognition.features import V3_JOINTS

    rng = np.random.default_rng(3)
    base = np.tile(np.linspace(0, 1, 51).reshape(17, 3), (40, 1, 1)) + rng.normal(0, 0.01, (40, 17, 3))
    waving = base.copy()
    others = [j for j in range(17) if j not in V3_JOINTS]
    waving[:, others] += rng.normal(0, 0.2, (40, len(others), 3))
    outputs = {}
    for version in ("v2", "v3"):
        rec = ActionRecognizer.from_config(
            RecognizerConfig(model_path=_tiny_model(tmp_path / f"{version}.onnx", 135, version), gate=False)
        )
        assert rec.info.features == version
        last = [recognize_sequence(rec, x, FPS)[-1] for x in (base, waving)]
        outputs[version] = [[e.probs[a] for a in ACTIONS] for e in last]
    assert not np.allclose(*outputs["v2"]), "a v2 model sees the arms (the check can fail)"
    assert np.allclose(*outputs["v3"], atol=1e-6), "a v3 model must not see the arms or the face"
