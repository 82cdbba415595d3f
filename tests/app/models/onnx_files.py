"""Real ONNX files for the registry's tests: the committed model changed in one way each."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH


def with_metadata(out: Path, **changes: str | None) -> Path:
    """The committed model with metadata keys changed (None: removed)."""
    proto = onnx.load(str(DEFAULT_MODEL_PATH))
    meta = {p.key: p.value for p in proto.metadata_props}
    for k, v in changes.items():
        if v is None:
            meta.pop(k, None)
        else:
            meta[k] = v
    del proto.metadata_props[:]
    for k, v in meta.items():
        e = proto.metadata_props.add()
        e.key, e.value = k, v
    onnx.save(proto, str(out))
    return out


def three_class_model(out: Path, channels: int = 135, window: int = 32, classes: int = 3) -> Path:
    """A small valid ONNX model with the four classes in its metadata but three outputs (``classes``:
    another count; 4 gives a model that runs but is no SlowFast network)."""
    w = numpy_helper.from_array(
        np.random.default_rng(0).normal(size=(channels, classes)).astype(np.float32), "w"
    )
    axes = numpy_helper.from_array(np.array([2], dtype=np.int64), "axes")
    nodes = [
        helper.make_node("ReduceMean", ["x", "axes"], ["m"], keepdims=0),
        helper.make_node("MatMul", ["m", "w"], ["z"]),
        helper.make_node("Softmax", ["z"], ["probs"], axis=1),
    ]
    graph = helper.make_graph(
        nodes, "three",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["batch", channels, window])],
        [helper.make_tensor_value_info("probs", TensorProto.FLOAT, ["batch", classes])],
        [w, axes],
    )  # fmt: skip
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)])
    model.ir_version = 9
    for k, v in {"window": str(window), "fps": "30", "classes": "still,forward,left,right",
                 "features": "v2"}.items():  # fmt: skip
        e = model.metadata_props.add()
        e.key, e.value = k, v
    onnx.save(model, str(out))
    return out
