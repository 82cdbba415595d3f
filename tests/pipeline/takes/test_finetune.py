"""Fine-tuning starts from the file's own network: the weights read back from the ONNX graph compute
what the file computes, and export again to an equivalent file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import ModelError
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH, open_session
from pipeline.takes.finetune import export, torch_from_onnx


def test_the_committed_model_read_into_torch_computes_what_the_file_does(tmp_path: Path) -> None:
    torch = pytest.importorskip("torch")
    model, facts = torch_from_onnx(DEFAULT_MODEL_PATH)
    session = open_session(DEFAULT_MODEL_PATH)
    name = session.get_inputs()[0].name
    x = np.random.default_rng(0).normal(size=(6, model.cfg.in_channels, facts["window"])).astype(np.float32)
    with torch.no_grad():
        ours = torch.softmax(model(torch.from_numpy(x)), dim=1).numpy()
    theirs = session.run(None, {name: x})[0]
    assert np.abs(ours - theirs).max() < 1e-4, "the network read back must be the file's network"
    export(model, tmp_path / "again.onnx", facts, {"note": "round trip"})
    again = open_session(tmp_path / "again.onnx")
    assert np.abs(again.run(None, {name: x})[0] - theirs).max() < 1e-4
    assert again.get_modelmeta().custom_metadata_map["note"] == "round trip"
    # the committed file's start head (its second output) is not the network fine-tuning reads: the
    # fine-tuned file has the full-body network alone, and no metadata that says otherwise
    assert len(session.get_outputs()) == 2, "the committed model carries a start head"
    assert len(again.get_outputs()) == 1
    assert not any(k.startswith("start_") for k in again.get_modelmeta().custom_metadata_map)


def test_a_model_that_is_not_the_slowfast_network_cannot_be_fine_tuned(tmp_path: Path) -> None:
    from tests.app.models.onnx_files import three_class_model

    with pytest.raises(ModelError, match="not the skeleton SlowFast network"):
        torch_from_onnx(three_class_model(tmp_path / "m.onnx", classes=4))


def test_an_ensemble_file_reads_back_into_its_networks(tmp_path: Path) -> None:
    """A file of several networks (train_action.py --members N) is fine-tuned as the ensemble it is:
    each network read back from its part of the graph, their mean computing what the file does."""
    torch = pytest.importorskip("torch")
    from pipeline.recognition.features import FEATURE_CHANNELS
    from pipeline.recognition.model import SkeletonSlowFast, SlowFastConfig, SlowFastEnsemble
    from pipeline.recognition.train import export_onnx

    torch.manual_seed(3)
    cfg = SlowFastConfig(in_channels=FEATURE_CHANNELS["v2"], window=32)
    members = [SkeletonSlowFast(cfg) for _ in range(3)]
    for m in members:
        with torch.no_grad():  # batch norms with statistics of their own, as after training
            for bn in (x for x in m.modules() if isinstance(x, torch.nn.BatchNorm1d)):
                bn.running_mean.uniform_(-0.5, 0.5)
                bn.running_var.uniform_(0.5, 2.0)
        m.eval()
    path = tmp_path / "ensemble.onnx"
    export_onnx(SlowFastEnsemble(members).eval(), path, 32, 30.0, extra={"members": "3"}, features="v2")
    model, _ = torch_from_onnx(path)
    assert isinstance(model, SlowFastEnsemble) and len(model.members) == 3
    session = open_session(path)
    x = np.random.default_rng(1).normal(size=(5, model.cfg.in_channels, 32)).astype(np.float32)
    with torch.no_grad():
        ours = torch.softmax(model(torch.from_numpy(x)), dim=1).numpy()
        single = torch.softmax(members[0](torch.from_numpy(x)), dim=1).numpy()
    theirs = session.run(None, {session.get_inputs()[0].name: x})[0]
    assert np.abs(ours - theirs).max() < 1e-4, "the networks read back must be the file's"
    assert np.abs(single - theirs).max() > 1e-3, "one member alone is not the ensemble (the check can fail)"
