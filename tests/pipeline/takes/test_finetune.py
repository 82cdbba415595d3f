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


def test_a_model_that_is_not_the_slowfast_network_cannot_be_fine_tuned(tmp_path: Path) -> None:
    from tests.app.models.onnx_files import three_class_model

    with pytest.raises(ModelError, match="not the skeleton SlowFast network"):
        torch_from_onnx(three_class_model(tmp_path / "m.onnx"))
