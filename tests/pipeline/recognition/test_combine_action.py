"""`scripts/combine_action.py`: trained action models become one file with a start head, written as
grouped stacks (`pipeline.recognition.networks`); the recogniser, the replay and the bout gate read it
(the model card's "two judges")."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import onnx
import onnx.utils
import pytest

from pipeline.recognition.evaluation import network_trace, replay
from pipeline.recognition.features import FEATURES_V3, evidence_vector, model_input, window_features
from pipeline.recognition.recognizer import (
    DEFAULT_MODEL_PATH,
    ActionRecognizer,
    RecognizerConfig,
    classify_windows,
    classify_windows_heads,
    model_info,
    open_session,
    recognize_sequence,
)
from pipeline.recognition.steps import StepTracker
from pipeline.skeleton import ACTIONS
from tests.inprocess import run_main

from .kinematic import Scene, Swing, march, noisy, render

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts" / "combine_action.py"
sys.path.insert(0, str(SCRIPT.parent))
import combine_action  # noqa: E402

FPS = 30.0


def _single(tmp: Path, name: str, features: str) -> Path:
    """The committed model's full-body network alone (its first output), labelled ``features``."""
    src = tmp / "committed.onnx"
    out = tmp / name
    onnx.utils.extract_model(str(DEFAULT_MODEL_PATH), str(src), ["x"], ["probs"])
    model = onnx.load(str(src))
    for p in onnx.load(str(DEFAULT_MODEL_PATH)).metadata_props:
        if not p.key.startswith("start_"):
            entry = model.metadata_props.add()
            entry.key, entry.value = p.key, features if p.key == "features" else p.value
    onnx.save(model, str(out))
    return out


def _combine(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=120
    )


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    tmp = tmp_path_factory.mktemp("combine")
    full, legs = _single(tmp, "full.onnx", "v2"), _single(tmp, "legs.onnx", FEATURES_V3)
    out = tmp / "both.onnx"
    done = _combine("--full", full, "--start", legs, "--out", out)
    assert done.returncode == 0, done.stderr
    return full, legs, out


def _windows() -> tuple[np.ndarray, np.ndarray]:
    joints, _ = render(Scene(4.0, march(0.5, 5, 0.6, 0.35)))
    j = noisy(joints, 0.012, 0.02, seed=3)
    tracker = StepTracker()
    ev = np.stack([evidence_vector(tracker.update(f, i / FPS)) for i, f in enumerate(j)])
    idx = np.maximum(np.arange(32, len(j))[:, None] - np.arange(31, -1, -1)[None, :], 0)
    return j[idx], ev[idx]


def test_the_combined_file_gives_both_networks_in_one_call(models: tuple[Path, Path, Path]) -> None:
    full, legs, both = models
    session = open_session(both)
    info = model_info(session)
    assert info.start_head and info.features == "v2"
    meta = {p.key: p.value for p in onnx.load(str(both)).metadata_props}
    assert meta["start_features"] == FEATURES_V3 and meta["features"] == "v2"
    windows, evidence = _windows()
    probs, start = classify_windows_heads(session, windows, FPS, evidence)
    assert start is not None
    # the first output is the full-body network, the second the start network fed its own input
    # (the arms and the face masked inside the graph, as model_input does for v3)
    np.testing.assert_allclose(probs, classify_windows(open_session(full), windows, FPS, evidence), atol=1e-6)
    np.testing.assert_allclose(start, classify_windows(open_session(legs), windows, FPS, evidence), atol=1e-6)
    assert np.abs(start - probs).max() > 0.01, "the masked joints change what the start head sees"
    assert classify_windows_heads(open_session(full), windows, FPS, evidence)[1] is None


def test_the_recogniser_streams_what_the_replay_of_both_heads_gives(models: tuple[Path, Path, Path]) -> None:
    _, _, both = models
    swings = (*march(1.0, 8, 0.55, 0.35), Swing(0, 6.0, 6.4, lateral=-0.3, peak=0.05))
    joints, _ = render(Scene(8.0, swings, yaw_deg=40.0))
    j = noisy(joints, 0.012, 0.02, seed=1)
    config = RecognizerConfig(model_path=both)
    rec = ActionRecognizer.from_config(config)
    streamed = np.array([ACTIONS.index(e.label) for e in recognize_sequence(rec, j, FPS)])
    trace = network_trace(rec.session, j, FPS)
    assert trace.start is not None and trace.start.shape == trace.raw.shape
    assert (streamed == replay(trace, config)).all()
    assert (streamed != 0).any(), "the march is a bout"


def _combine_in_process(*args: str | Path) -> subprocess.CompletedProcess[str]:
    """The script's command line run in this process (its ``main``)."""
    return run_main("combine_action", *map(str, args))


def test_bad_input_gets_one_error_and_writes_nothing(models: tuple[Path, Path, Path], tmp_path: Path) -> None:
    full, legs, _ = models
    out = tmp_path / "x.onnx"
    done = _combine("--full", tmp_path / "none.onnx", "--start", legs, "--out", out)  # the script itself
    assert done.returncode == 2 and done.stderr == f"error: no such model: {tmp_path / 'none.onnx'}\n", (
        done.stderr
    )
    # the other refusals: the same command line, in this process
    for args, message in (
        (("--full", tmp_path / "none.onnx", "--start", legs), "no such model"),
        (("--full", legs, "--start", full), "full model must take features v2, legs.onnx takes 'v3'"),
        (("--full", full, legs, "--start", legs), "full model must take features v2, legs.onnx"),
    ):
        done = _combine_in_process(*args, "--out", out)
        assert done.returncode == 2 and done.stderr.startswith("error: "), done.stderr
        assert message in done.stderr, done.stderr
        assert not out.exists()
    (tmp_path / "text.onnx").write_text("not a model")
    done = _combine_in_process("--full", tmp_path / "text.onnx", "--start", legs, "--out", out)
    assert done.returncode == 2 and done.stderr == "error: text.onnx is not an ONNX model (DecodeError)\n"
    assert not out.exists()
    folder_is_file = tmp_path / "text.onnx" / "x.onnx"
    done = _combine_in_process("--full", full, "--start", legs, "--out", folder_is_file)
    assert done.returncode == 2 and done.stderr.startswith("error: ") and done.stderr.count("\n") == 1
    other = onnx.load(str(legs))
    for p in other.metadata_props:
        if p.key == "fps":
            p.value = "60"
    onnx.save(other, str(tmp_path / "fast.onnx"))
    done = _combine_in_process("--full", full, "--start", tmp_path / "fast.onnx", "--out", out)
    assert done.returncode == 2 and "differ in fps" in done.stderr and not out.exists()
    done = _combine_in_process("--full", full, "--start", legs, tmp_path / "fast.onnx", "--out", out)
    assert done.returncode == 2 and "differ in fps" in done.stderr and not out.exists()


def _random_networks(count: int, seed: int) -> list[object]:
    """``count`` skeleton SlowFast networks with random weights and batch-norm statistics of their own."""
    import torch

    from pipeline.recognition.model import SkeletonSlowFast, SlowFastConfig

    torch.manual_seed(seed)
    nets = [SkeletonSlowFast(SlowFastConfig(in_channels=135, window=32)) for _ in range(count)]
    with torch.no_grad():
        for net in nets:
            for bn in (m for m in net.modules() if isinstance(m, torch.nn.BatchNorm1d)):
                bn.running_mean.uniform_(-0.5, 0.5)
                bn.running_var.uniform_(0.5, 2.0)
                bn.bias.uniform_(-0.3, 0.3)
            net.eval()
    return nets


def test_several_files_per_output_are_one_grouped_ensemble(tmp_path: Path) -> None:
    """Files of 2 and 1 networks as the full-body output, 1 and 2 as the start head: each output is the
    softmax of the mean logits of all its networks (computed here in torch from the networks
    themselves), the start head's with the joints a v3 network does not see zeroed, and the file is
    written as one grouped stack shared by both outputs, which reads back into the same networks."""
    torch = pytest.importorskip("torch")
    from pipeline.recognition.features import CHANNELS_PER_JOINT, FEATURE_CHANNELS, V3_JOINTS
    from pipeline.recognition.model import SlowFastEnsemble
    from pipeline.recognition.networks import LAYOUT_KEY, read_networks
    from pipeline.recognition.train import export_onnx

    nets = _random_networks(6, seed=5)
    paths = []
    for k, (group, features) in enumerate(
        (((0, 1), "v2"), ((2,), "v2"), ((3,), FEATURES_V3), ((4, 5), FEATURES_V3))
    ):
        path = tmp_path / f"part{k}.onnx"
        model = SlowFastEnsemble([nets[i] for i in group]) if len(group) > 1 else nets[group[0]]
        seeds = ",".join(str(i) for i in group)
        export_onnx(
            model, path, 32, 30.0, extra={"seed": seeds, "members": str(len(group))}, features=features
        )
        paths.append(path)
    out = tmp_path / "joined.onnx"
    done = _combine("--full", paths[0], paths[1], "--start", paths[2], paths[3], "--out", out)
    assert done.returncode == 0, done.stderr
    proto = onnx.load(str(out))
    meta = {p.key: p.value for p in proto.metadata_props}
    assert meta["members"] == "3" and meta["seed"] == "0,1,2" and meta["start_seed"] == "3,4,5"
    assert meta["start_members"] == "3" and meta[LAYOUT_KEY] == "grouped"
    assert len(proto.graph.node) < 70, "about 30 nodes per output instead of about 40 per network"

    rng = np.random.default_rng(2)
    x = rng.normal(size=(9, FEATURE_CHANNELS["v2"], 32)).astype(np.float32)
    mask = np.ones(FEATURE_CHANNELS["v2"], np.float32)  # a v3 network sees the step evidence and its joints
    mask[: 17 * CHANNELS_PER_JOINT] = 0.0
    for j in V3_JOINTS:
        mask[j * CHANNELS_PER_JOINT : (j + 1) * CHANNELS_PER_JOINT] = 1.0
    with torch.no_grad():
        t = torch.from_numpy(x)
        tm = torch.from_numpy(x * mask[None, :, None])
        want_full = torch.softmax(torch.stack([nets[i](t) for i in (0, 1, 2)]).mean(0), dim=1).numpy()
        want_start = torch.softmax(torch.stack([nets[i](tm) for i in (3, 4, 5)]).mean(0), dim=1).numpy()
    session = open_session(out)
    probs, start = session.run(None, {"x": x})
    np.testing.assert_allclose(probs, want_full, atol=2e-6)
    np.testing.assert_allclose(start, want_start, atol=2e-6)
    assert np.abs(want_full - want_start).max() > 1e-3, "the two outputs differ (the check can fail)"
    back = read_networks(proto)
    assert len(back) == 3
    sd = nets[2].state_dict()
    w, _ = back[2].conv("slow2")
    scale = (sd["slow2.2.weight"] / torch.sqrt(sd["slow2.2.running_var"] + 1e-5)).numpy()
    np.testing.assert_allclose(w, sd["slow2.1.weight"].numpy() * scale[:, None, None], atol=1e-5)
    np.testing.assert_allclose(back[2].head[0], sd["head.weight"].numpy(), atol=1e-6)
    np.testing.assert_allclose(back[2].head[1], sd["head.bias"].numpy(), atol=1e-6)
    assert meta["towers"] == "probs:0:3,start_probs:3:3"
    start_back = read_networks(proto, "start_probs")  # the stack's networks 3 to 5
    assert len(start_back) == 3
    sd = nets[4].state_dict()
    scale = (sd["slow3.2.weight"] / torch.sqrt(sd["slow3.2.running_var"] + 1e-5)).numpy()
    w, _ = start_back[1].conv("slow3")
    np.testing.assert_allclose(w, sd["slow3.1.weight"].numpy() * scale[:, None, None], atol=1e-5)
    np.testing.assert_allclose(start_back[1].head[0], sd["head.weight"].numpy(), atol=1e-6)
    again = tmp_path / "again.onnx"
    done = _combine("--full", out, "--start", out, "--out", again)
    assert done.returncode == 0, done.stderr
    assert again.read_bytes() == out.read_bytes(), "a grouped file joins into itself byte for byte"


def test_the_committed_file_is_grouped_and_reads_back_into_its_networks() -> None:
    """The committed model is written grouped (a few dozen nodes per output, not forty per network)
    and its metadata counts the networks that reading it back finds."""
    from pipeline.recognition.networks import LAYOUT_KEY, read_networks

    proto = onnx.load(str(DEFAULT_MODEL_PATH))
    meta = {p.key: p.value for p in proto.metadata_props}
    assert meta[LAYOUT_KEY] == "grouped"
    assert len(proto.graph.node) < 80
    full, start = read_networks(proto, "probs"), read_networks(proto, "start_probs")
    assert len(full) == int(meta["members"]) == len(meta["seed"].split(","))
    assert len(start) == int(meta["start_members"]) == len(meta["start_seed"].split(","))


def test_both_outputs_of_the_committed_file_share_one_stack_and_give_what_two_stacks_give() -> None:
    """The full-body judge and the start head are one stack of sixteen networks (one convolution per
    layer for both, then split): the same networks read back, and the same probabilities as each
    output written as a stack of its own, with half the convolutions per call."""
    from pipeline.recognition.networks import TOWERS_KEY, fused_model, read_networks

    proto = onnx.load(str(DEFAULT_MODEL_PATH))
    meta = {p.key: p.value for p in proto.metadata_props}
    assert meta[TOWERS_KEY] == "probs:0:8,start_probs:8:8"
    full, start = read_networks(proto, "probs"), read_networks(proto, "start_probs")
    heads = [("probs", full, None), ("start_probs", start, None)]  # the start networks read masked
    kept = {k: v for k, v in meta.items() if k not in ("layout", TOWERS_KEY)}
    shared, apart = fused_model(proto, heads, kept), fused_model(proto, heads, kept, share=False)
    convs = [sum(n.op_type == "Conv" for n in m.graph.node) for m in (proto, shared, apart)]
    assert convs == [8, 8, 16], convs
    assert TOWERS_KEY not in {p.key for p in apart.metadata_props}
    for name, nets in (("probs", full), ("start_probs", start)):
        again = read_networks(shared, name)
        for a, b in zip(again, nets, strict=True):
            for (wa, ba), (wb, bb) in zip(a.convs, b.convs, strict=True):
                np.testing.assert_array_equal(wa, wb)
                np.testing.assert_array_equal(ba, bb)
            np.testing.assert_array_equal(a.head[0], b.head[0])
    windows, evidence = _windows()
    x = np.concatenate(
        [
            model_input(window_features(windows, FPS), evidence, "v2"),
            np.random.default_rng(4).normal(0.0, 3.0, (40, 135, 32)).astype(np.float32),
        ]
    )
    session = combine_action._session  # one thread, the model in memory
    committed, one, two = (
        [np.asarray(o) for o in session(m).run(None, {"x": x})] for m in (proto, shared, apart)
    )
    for got in (*committed, *one):
        assert np.isfinite(got).all()
    for a, b, c in zip(committed, one, two, strict=True):
        np.testing.assert_array_equal(a, b)  # this file is what fused_model writes
        np.testing.assert_allclose(b, c, rtol=0, atol=1e-6)  # the same arithmetic in other groupings
    assert np.abs(committed[0] - committed[1]).max() > 0.01, "the two outputs differ"


def test_a_towers_entry_that_does_not_name_the_output_is_an_error() -> None:
    from pipeline.recognition.networks import TOWERS_KEY, read_networks

    proto = onnx.load(str(DEFAULT_MODEL_PATH))
    for value, message in (
        ("probs:0:8", "does not name output 'start_probs'"),
        ("probs:0:8,start_probs:8:9", "networks 8 to 16 are not in a stack of 16"),
        ("probs:0:8,start_probs:x", "does not name output 'start_probs'"),
    ):
        entry = next(p for p in proto.metadata_props if p.key == TOWERS_KEY)
        entry.value = value
        with pytest.raises(ValueError, match=message):
            read_networks(proto, "start_probs")


def test_networks_chosen_by_seed_join_back_into_the_same_file(tmp_path: Path) -> None:
    """``FILE:SEEDS`` takes only those networks of a file's output: the committed file's networks split
    in two by seed and joined again are the committed file byte for byte, and one network alone is
    that network (its seed, its weights)."""
    from pipeline.recognition.networks import read_networks

    path = DEFAULT_MODEL_PATH
    meta = {p.key: p.value for p in onnx.load(str(path)).metadata_props}
    seeds, start_seeds = meta["seed"].split(","), meta["start_seed"].split(",")
    half, start_half = len(seeds) // 2, len(start_seeds) // 2
    out = tmp_path / "again.onnx"
    first, second = ",".join(seeds[:half]), ",".join(seeds[half:])
    start_first, start_second = ",".join(start_seeds[:start_half]), ",".join(start_seeds[start_half:])
    done = _combine_in_process(
        "--full", f"{path}:{first}", f"{path}:{second}",
        "--start", f"{path}:{start_first}", f"{path}:{start_second}",
        "--out", out,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert out.read_bytes() == path.read_bytes(), "split by seed and joined: the same file"

    one = tmp_path / "one.onnx"
    done = _combine_in_process(
        "--full", f"{path}:{seeds[-1]}", "--start", f"{path}:{start_seeds[0]}", "--out", one
    )
    assert done.returncode == 0, done.stderr
    proto = onnx.load(str(one))
    got = {p.key: p.value for p in proto.metadata_props}
    assert (got["seed"], got["members"], got["start_seed"], got["start_members"]) == (
        seeds[-1],
        "1",
        start_seeds[0],
        "1",
    )
    committed = onnx.load(str(path))
    for output, index in (("probs", -1), ("start_probs", 0)):
        (net,) = read_networks(proto, output)
        want = read_networks(committed, output)[index]
        for (wa, ba), (wb, bb) in zip(net.convs, want.convs, strict=True):
            np.testing.assert_array_equal(wa, wb)
            np.testing.assert_array_equal(ba, bb)
        np.testing.assert_array_equal(net.head[0], want.head[0])


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        (":99", "has no network of seed 99"),
        (":7-4", "seeds are like 4-7 or 4,6, got '7-4'"),
        (":4,4", "a seed is named twice in '4,4'"),
        (":-4", "seeds are like 4-7 or 4,6, got '-4'"),
        (":x", "no such model"),
    ],
)
def test_a_seed_that_is_not_in_its_file_is_one_error(spec: str, message: str, tmp_path: Path) -> None:
    out = tmp_path / "x.onnx"
    done = _combine_in_process(
        "--full", f"{DEFAULT_MODEL_PATH}{spec}", "--start", DEFAULT_MODEL_PATH, "--out", out
    )
    assert done.returncode == 2 and done.stderr.startswith("error: ") and done.stderr.count("\n") == 1, (
        done.stderr
    )
    assert message in done.stderr, done.stderr
    assert not out.exists()
