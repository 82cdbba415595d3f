"""The training data pipeline (no training): capture faults, windows, transition weights."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pipeline.recognition.features import EVIDENCE_CHANNELS, FEATURES_V2
from pipeline.recognition.train import (
    AugmentConfig,
    Dataset,
    NoiseConfig,
    TrainConfig,
    augment_windows,
    augmented_index,
    batch_inputs,
    capture,
    gather_windows,
    still_arms,
    transition_weights,
    window_ends,
)
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.skeleton import J


def test_capture_adds_triangulation_like_error_and_unknown_joints() -> None:
    m = simulate_user(MotionScript((Segment("forward", 10.0),)), body_from_height(1.75), 30.0, seed=1)
    out = capture(m.joints_m, np.random.default_rng(0), NoiseConfig(), 30.0)
    assert out.shape == m.joints_m.shape
    err = np.linalg.norm(out - m.joints_m, axis=-1)
    med = float(np.nanmedian(err))
    assert 0.002 < med < 0.05, f"median 3D error {med * 1000:.1f} mm: a few centimetres at most"
    assert np.isnan(out).any(), "some joints are unknown (seen by fewer than two cameras, gaps)"
    again = capture(m.joints_m, np.random.default_rng(0), NoiseConfig(), 30.0)
    np.testing.assert_array_equal(out, again, err_msg="deterministic for a seed")


def test_capture_without_faults_returns_the_skeleton() -> None:
    m = simulate_user(MotionScript((Segment("still", 2.0),)), body_from_height(1.6), 30.0, seed=2)
    quiet = NoiseConfig(
        pixel_sigma_px=(0.0, 0.0),
        drift_sigma_px=(0.0, 0.0),
        drop_prob=(0.0, 0.0),
        outlier_prob=0.0,
        gap_prob_per_s=0.0,
        group_drop_per_s=0.0,
        face_missing_prob=0.0,
    )
    out = capture(m.joints_m, np.random.default_rng(0), quiet, 30.0)
    np.testing.assert_allclose(out, m.joints_m, atol=1e-6)


def _toy() -> Dataset:
    joints = np.arange(10 * 17 * 3, dtype=np.float32).reshape(10, 17, 3)
    labels = np.array([0, 0, 0, 1, 1, 1, 0, 0, 2, 2])
    return Dataset(joints, labels, np.array([0, 6, 10]), 10.0)


def test_windows_repeat_the_first_frame_of_their_own_sequence() -> None:
    data = _toy()
    w = gather_windows(data, np.array([1, 7]), window=4)
    np.testing.assert_array_equal(w[0], data.joints[[0, 0, 0, 1]])
    np.testing.assert_array_equal(
        w[1], data.joints[[6, 6, 6, 7]], err_msg="never reaches into the sequence before"
    )
    assert window_ends(data, stride=3).tolist() == [0, 3, 6, 9]


def test_transition_weights_mark_the_time_after_a_change_but_not_a_new_sequence() -> None:
    w = transition_weights(_toy(), window_s=0.2, weight=2.0)
    assert w.tolist() == [1, 1, 1, 2, 2, 1, 1, 1, 2, 2]


def _march_windows() -> np.ndarray:
    m = simulate_user(MotionScript((Segment("forward", 3.0),)), body_from_height(1.75), 30.0, seed=3)
    return m.joints_m[None, 30:62].astype(np.float32)  # (1, 32, 17, 3)


def test_augmentation_changes_only_what_it_says() -> None:
    w = _march_windows()
    rng = np.random.default_rng(0)
    same = AugmentConfig(speed=(1, 1), leg_scale=(1, 1), step_scale=(1, 1), drop_prob=0.0, jitter_m=(0, 0))
    out, step = augment_windows(w, rng, same)
    np.testing.assert_allclose(out, w, atol=1e-6, err_msg="no change when every range is the identity")
    legs = AugmentConfig(
        speed=(1, 1), leg_scale=(1.1, 1.1), step_scale=(1, 1), drop_prob=0.0, jitter_m=(0, 0)
    )
    out, _ = augment_windows(w, rng, legs)
    hip, ankle = J["l_hip"], J["l_ankle"]
    ratio = np.linalg.norm(out[0, :, ankle] - out[0, :, hip], axis=-1) / np.linalg.norm(
        w[0, :, ankle] - w[0, :, hip], axis=-1
    )
    np.testing.assert_allclose(ratio, 1.1, rtol=1e-4, err_msg="the legs are 10 % longer")
    feet = [J["l_ankle"], J["r_ankle"]]
    assert abs(float(np.min(out[0, :, feet, 2]) - np.min(w[0, :, feet, 2]))) < 1e-5, "on the same floor"
    trunk = out[0, :, J["nose"]] - out[0, :, J["l_hip"]]
    np.testing.assert_allclose(
        trunk, w[0, :, J["nose"]] - w[0, :, J["l_hip"]], atol=1e-5, err_msg="same trunk"
    )
    high = AugmentConfig(
        speed=(1, 1), leg_scale=(1, 1), step_scale=(1.3, 1.3), drop_prob=0.0, jitter_m=(0, 0)
    )
    out, step = augment_windows(w, rng, high)
    lift = np.ptp(out[0, :, J["l_ankle"], 2]) / np.ptp(w[0, :, J["l_ankle"], 2])
    assert abs(lift - 1.3) < 1e-4 and float(step[0, 0]) == 1.3, "the step is 30 % higher"
    drop = AugmentConfig(drop_prob=1.0, drop_joints=(2, 2))
    out, _ = augment_windows(w, rng, drop)
    lost = np.isnan(out[0]).all(axis=(0, 2))
    assert lost.sum() == 2, f"two joints lost for the whole window, got {lost.sum()}"


def test_a_faster_reading_covers_more_source_frames_and_its_evidence_too() -> None:
    n = 300
    joints = np.repeat(_march_windows()[0, :1], n, axis=0)
    evidence = np.zeros((n, EVIDENCE_CHANNELS), np.float32)
    evidence[:, 5] = 0.6  # the left foot's swing time
    data = Dataset(joints, np.zeros(n, np.int64), np.array([0, n]), 30.0, evidence, ("a",))
    rng = np.random.default_rng(0)
    idx, _speed = augmented_index(data, np.array([200]), 32, rng, AugmentConfig(speed=(1.25, 1.25)))
    assert idx[0, -1] == 200 and idx[0, -1] - idx[0, 0] == round(31 * 1.25), idx[0]
    x = batch_inputs(
        data, np.array([200]), 32, FEATURES_V2, rng, AugmentConfig(speed=(1.25, 1.25), drop_prob=0.0)
    )
    assert x.shape == (1, 17 * 7 + EVIDENCE_CHANNELS, 32)
    np.testing.assert_allclose(
        x[0, 17 * 7 + 5], 0.6 / 1.25, rtol=1e-5, err_msg="a swing read faster is shorter"
    )


def test_an_augment_share_leaves_the_other_windows_as_recorded() -> None:
    n = 300
    w = _march_windows()[0]
    joints = np.concatenate([w] * (n // len(w) + 1))[:n]
    evidence = np.full((n, EVIDENCE_CHANNELS), 0.5, np.float32)
    data = Dataset(joints, np.ones(n, np.int64), np.array([0, n]), 30.0, evidence, ("a",))
    ends = np.arange(40, 290, 2)
    plain = batch_inputs(data, ends, 32, FEATURES_V2)
    big = AugmentConfig(speed=(1.25, 1.25), step_scale=(1.3, 1.3), drop_prob=0.0)
    every = batch_inputs(data, ends, 32, FEATURES_V2, np.random.default_rng(0), big)
    assert not any(np.allclose(a, b) for a, b in zip(every, plain, strict=True)), "share 1: every window"
    half = batch_inputs(data, ends, 32, FEATURES_V2, np.random.default_rng(0), replace(big, share=0.5))
    same = np.array([np.array_equal(a, b) for a, b in zip(half, plain, strict=True)])
    assert 0.3 < same.mean() < 0.7, f"{same.mean():.2f} of the windows as recorded with share 0.5"
    none = batch_inputs(data, ends, 32, FEATURES_V2, np.random.default_rng(0), replace(big, share=0.0))
    np.testing.assert_array_equal(none, plain, err_msg="share 0: no window changes")
    with pytest.raises(ValueError, match="share"):
        AugmentConfig(share=1.5)
    with pytest.raises(ValueError, match="augment_share"):
        TrainConfig(augment_share=-0.1)


_HANDS = [J["l_elbow"], J["l_wrist"], J["r_elbow"], J["r_wrist"]]


def test_still_arms_hang_from_the_shoulders_and_leave_everything_else() -> None:
    w = np.repeat(_march_windows(), 2, axis=0)  # a march swings the arms
    w[1, 4:7, J["r_wrist"]] = np.nan
    swing = np.ptp(w[0, :, J["l_wrist"], 1] - w[0, :, J["l_shoulder"], 1])
    assert swing > 0.05, f"the simulated march swings its arms ({swing * 100:.1f} cm)"
    out = still_arms(w, np.array([True, False]), np.random.default_rng(0))
    np.testing.assert_array_equal(out[1], w[1], err_msg="a window not picked is untouched")
    others = [j for j in range(17) if j not in _HANDS]
    np.testing.assert_array_equal(out[0][:, others], w[0][:, others], err_msg="only elbows and wrists move")
    for hand, shoulder in ((J["l_wrist"], J["l_shoulder"]), (J["r_elbow"], J["r_shoulder"])):
        off = out[0, :, hand] - out[0, :, shoulder]
        assert float(np.max(np.std(off, axis=0))) < 0.012, "the arm keeps its place below the shoulder"
        np.testing.assert_allclose(
            off.mean(axis=0),
            (w[0, :, hand] - w[0, :, shoulder]).mean(axis=0),
            atol=0.005,
            err_msg="at the window's mean offset",
        )
    both = still_arms(w, np.array([True, True]), np.random.default_rng(0))
    assert np.isnan(both[1, 4:7, J["r_wrist"]]).all() and not np.isnan(both[1, 7:, J["r_wrist"]]).any(), (
        "an unknown joint stays unknown, a known one stays known"
    )


def test_training_with_still_arms_changes_the_arm_channels_of_that_share_of_stepping_windows() -> None:
    n = 200
    joints = np.concatenate([_march_windows()[0]] * 7)[:n]
    data = Dataset(joints, np.ones(n, np.int64), np.array([0, n]), 30.0)
    ends = np.full(400, 150)
    plain = batch_inputs(data, ends, 32)
    x = batch_inputs(data, ends, 32, rng=np.random.default_rng(1), arms_still=0.5)
    changed = np.any(np.abs(x - plain) > 1e-4, axis=(1, 2))
    assert 0.4 < changed.mean() < 0.6, f"{changed.mean():.2f} of the windows changed, not about half"
    moved = np.any(np.abs(x - plain) > 1e-4, axis=(0, 2)).reshape(17, 7).any(axis=1)
    assert set(np.flatnonzero(moved)) <= set(_HANDS), "only the arms' channels change"
    np.testing.assert_array_equal(batch_inputs(data, ends, 32, arms_still=0.5), plain, "no rng: no change")
    standing = Dataset(joints, np.zeros(n, np.int64), np.array([0, n]), 30.0)
    np.testing.assert_array_equal(
        batch_inputs(standing, ends, 32, rng=np.random.default_rng(1), arms_still=1.0),
        batch_inputs(standing, ends, 32),
        err_msg="a still window keeps its arms (a wave is still whatever the legs do)",
    )
    with pytest.raises(ValueError, match="arms_still"):
        TrainConfig(arms_still=1.5)


def _train_script(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """``scripts/train_action.py ARGS`` writing into ``tmp_path`` only (model ``m.onnx``, cache)."""
    script = Path(__file__).resolve().parents[3] / "scripts" / "train_action.py"
    return subprocess.run(
        [sys.executable, str(script), *args, "--out", str(tmp_path / "m.onnx"), "--cache", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
    )


def test_the_training_script_refuses_a_share_outside_0_to_1(tmp_path: Path) -> None:
    out = tmp_path / "m.onnx"
    for bad in ("1.5", "-0.1", "half"):
        done = _train_script(tmp_path, "--arms-still", bad)
        last = done.stderr.strip().splitlines()[-1]
        assert done.returncode == 2 and last.endswith(
            f"error: argument --arms-still: invalid share value: '{bad}'"
        )
        assert not out.exists() and list(tmp_path.iterdir()) == [], "nothing written"


@pytest.mark.parametrize(("flag", "value"), [("--windows-per-epoch", "64"), ("--epochs", "0")])
def test_training_settings_that_make_no_step_are_one_error_before_any_data(
    tmp_path: Path, flag: str, value: str
) -> None:
    done = _train_script(tmp_path, flag, value)
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2 and "error: epochs and batch_size must be at least 1" in last, done.stderr
    assert "Traceback" not in done.stderr and list(tmp_path.iterdir()) == [], "nothing prepared or written"


def test_the_third_to_fifth_motion_models_train_from_other_seeds_than_their_held_out_sets(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from pipeline.errors import InputError
    from pipeline.mocap.sources import BLIND_SETS, BlindSet
    from pipeline.recognition import corpus
    from pipeline.recognition.prepare import SourceSpec
    from pipeline.skeleton import ACTIONS

    spec = SourceSpec.parse("b=blind2@3")
    assert (spec.name, spec.generator, spec.count, spec.folder) == ("b", "blind2", 3, None)
    assert SourceSpec.parse("blind").generator == "blind"
    held = {s.model: s.seed for s in BLIND_SETS.values()}
    for model in corpus.INDEPENDENT_MODELS:
        drawn = corpus.training_seed(model, 0)
        assert drawn != held[model] and all(corpus.training_seed(model, k) != held[model] for k in range(8))
        # a draw that hits the held-out set's seed steps off it
        monkeypatch.setitem(BLIND_SETS, "probe", BlindSet(count=1, duration_s=10.0, seed=drawn, model=model))
        assert corpus.training_seed(model, 0) == drawn + 1
    for model in corpus.INDEPENDENT_MODELS:
        a = corpus.independent_model(model, 2, 8.0, seed=0)
        again = corpus.independent_model(model, 2, 8.0, seed=0)
        other = corpus.independent_model(model, 2, 8.0, seed=1)
        assert [s.name for s in a] == [f"{model}-0-0000", f"{model}-0-0001"]
        assert all(s.source == model and s.joints_m.shape == (240, 17, 3) for s in a)
        assert not any(np.isnan(s.joints_m).any() for s in a), "clean: the training capture adds the faults"
        moving = np.concatenate([s.labels for s in a])
        assert set(np.unique(moving)) & {ACTIONS.index(x) for x in ("forward", "left", "right")}
        assert all(np.array_equal(x.joints_m, y.joints_m) for x, y in zip(a, again, strict=True))
        assert not np.allclose(a[0].joints_m, other[0].joints_m), "each member seed draws other people"
    assert corpus.INDEPENDENT_MODELS == ("blind", "blind2", "blind3")
    with pytest.raises(InputError, match="independent motion model"):
        corpus.independent_model("blind4", 1, 10.0, seed=0)  # the sixth stays evaluation only


@pytest.mark.parametrize("bad", ["blind4", "b=blind4@2", "sim@0", "x=sim:nope"])
def test_the_training_script_refuses_a_bad_source_with_one_error_line(tmp_path: Path, bad: str) -> None:
    out = tmp_path / "m.onnx"
    done = _train_script(tmp_path, "--source", bad)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert lines[-1].startswith("train_action.py: error: argument --source: "), lines[-1]
    assert not out.exists() and list(tmp_path.iterdir()) == [], "nothing written"


def test_the_training_script_refuses_a_folder_the_manifest_holds_out(tmp_path: Path) -> None:
    """A folder that ``cavewalk data sources`` wrote for evaluation only (``sources.json``: use eval)
    is refused as a training source, with one error line and nothing written; a training folder of the
    same manifest is not held out."""
    import json

    from pipeline.mocap.sources import evaluation_only

    root = tmp_path / "sources"
    for name in ("blind5-heldout", "still"):
        (root / name).mkdir(parents=True)
    manifest = {
        "blind5-heldout": {"dir": str(root / "blind5-heldout"), "use": "eval"},
        "still": {"dir": str(root / "still"), "use": "train"},
    }
    (root / "sources.json").write_text(json.dumps(manifest))
    assert evaluation_only(root / "blind5-heldout") == "blind5-heldout"
    assert evaluation_only(root / "still") is None and evaluation_only(tmp_path) is None
    work = tmp_path / "work"
    work.mkdir()
    done = _train_script(work, "--source", f"b={root / 'blind5-heldout'}")
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert last.startswith("train_action.py: error: argument --source: ") and "never trained on" in last
    assert list(work.iterdir()) == [], "nothing written"


def test_a_prepared_simulator_source_is_made_again_when_the_simulator_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cache of prepared training data keys our simulator's sources by ``SIM_VERSION``: a
    changed simulator (a new still behaviour in its draws) must not train on the old routines."""
    from pipeline.recognition.prepare import SourceSpec, prepare_source
    from pipeline.sim import routines

    spec = SourceSpec.parse("s=sim:still@1")
    first = prepare_source(spec, tmp_path, sim_duration_s=4.0, seed=0)
    assert len(list(tmp_path.glob("action-source-s-*.pkl"))) == 1
    again = prepare_source(spec, tmp_path, sim_duration_s=4.0, seed=0)
    assert np.array_equal(first[0].seq.joints_m, again[0].seq.joints_m, equal_nan=True)
    assert len(list(tmp_path.glob("action-source-s-*.pkl"))) == 1, "the same simulator reads its cache"
    gait = SourceSpec.parse("gait@1").fingerprint()
    monkeypatch.setattr(routines, "SIM_VERSION", routines.SIM_VERSION + 1)
    prepare_source(spec, tmp_path, sim_duration_s=4.0, seed=0)
    assert len(list(tmp_path.glob("action-source-s-*.pkl"))) == 2, "a new simulator prepares again"
    assert SourceSpec.parse("gait@1").fingerprint() == gait, "other motion models keep their cache"


def test_preparing_data_and_the_training_scripts_arguments_need_no_torch() -> None:
    """torch (the train extra) is imported by training itself, not by preparing or evaluating data:
    a bad argument to the training script is answered at once, and evaluation runs without torch."""
    code = (
        "import sys\n"
        "import pipeline.recognition.prepare, pipeline.recognition.train, pipeline.recognition.evaluation\n"
        "print(sorted(m for m in sys.modules if m == 'torch' or m.startswith('torch.')))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", f"torch imported: {done.stdout[:200]}"
