"""Join two trained action models into one file with a start head.

    .venv/bin/python scripts/combine_action.py FULL.onnx START.onnx --out pipeline/recognition/action.onnx

FULL (features ``v2``: the whole body and the step evidence) stays the model's first output,
``probs``; START (``v2`` or ``v3``: the legs, hips and shoulders and the step evidence) becomes the
second, ``start_probs``, fed the same input with the joints it does not see zeroed inside the graph
(what :func:`pipeline.recognition.features.model_input` does for ``v3``). One onnxruntime call then
gives both; the bout gate reads the start head only while no bout is on
(:class:`pipeline.recognition.bout.GateConfig`, ``start_network``). Needs the ``train`` extra (onnx).
Both files come from ``scripts/train_action.py`` with the same ``--window``; the metadata of START is
kept under ``start_`` keys.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pipeline.recognition.features import (  # noqa: E402
    CHANNELS_PER_JOINT,
    FEATURE_CHANNELS,
    FEATURES_V2,
    FEATURES_V3,
    NUM_CHANNELS,
    V3_JOINTS,
)

_SHARED = ("window", "fps", "classes")


def _meta(model: object) -> dict[str, str]:
    return {p.key: p.value for p in model.metadata_props}  # type: ignore[attr-defined]


def start_mask(features: str) -> np.ndarray:
    """(1, channels, 1) input scale of the start head: 0 for the joints a ``v3`` model does not see."""
    mask = np.ones((1, FEATURE_CHANNELS[FEATURES_V2], 1), np.float32)
    if features == FEATURES_V3:
        mask[0, :NUM_CHANNELS] = 0.0
        for j in V3_JOINTS:
            mask[0, j * CHANNELS_PER_JOINT : (j + 1) * CHANNELS_PER_JOINT] = 1.0
    return mask


def _load(path: Path) -> Any:
    import onnx

    try:
        return onnx.load(str(path))
    except Exception as exc:  # protobuf's DecodeError and the like: not an ONNX file
        raise ValueError(f"{path.name} is not an ONNX model ({type(exc).__name__})") from None


def combine(full_path: Path, start_path: Path, out: Path) -> None:
    """Write FULL + START as one model with outputs ``probs`` and ``start_probs``; ValueError if the
    two do not fit together or one is no ONNX model."""
    import onnx
    from onnx import compose, helper, numpy_helper

    full, start = _load(full_path), _load(start_path)
    mf, ms = _meta(full), _meta(start)
    for key in _SHARED:
        if mf.get(key) != ms.get(key):
            raise ValueError(f"the two models differ in {key}: {mf.get(key)!r} and {ms.get(key)!r}")
    if mf.get("features") != FEATURES_V2:
        raise ValueError(f"the full model must take features {FEATURES_V2}, got {mf.get('features')!r}")
    if ms.get("features") not in (FEATURES_V2, FEATURES_V3):
        raise ValueError(f"the start model must take features v2 or v3, got {ms.get('features')!r}")
    if len(full.graph.output) != 1 or len(start.graph.output) != 1:
        raise ValueError("each model must have one output (a combined model cannot be combined again)")
    inner = compose.add_prefix(start, prefix="start/")
    x = full.graph.input[0].name
    mask = numpy_helper.from_array(start_mask(ms["features"]), name="start/mask")
    nodes = [
        *full.graph.node,
        helper.make_node("Mul", [x, "start/mask"], [inner.graph.input[0].name], name="start/mask_joints"),
        *inner.graph.node,
        helper.make_node("Identity", [inner.graph.output[0].name], ["start_probs"], name="start/out"),
    ]
    head = onnx.ValueInfoProto()
    head.CopyFrom(full.graph.output[0])
    head.name = "start_probs"
    graph = helper.make_graph(
        nodes,
        "action_with_start_head",
        [full.graph.input[0]],
        [full.graph.output[0], head],
        [*full.graph.initializer, mask, *inner.graph.initializer],
    )
    model = helper.make_model(graph, opset_imports=full.opset_import, ir_version=full.ir_version)
    meta = dict(mf)
    meta.update({f"start_{k}": v for k, v in ms.items() if k not in _SHARED})
    for key, value in meta.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(model)
    out.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(model, str(out))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("full", type=Path, help="the full-body model (features v2)")
    ap.add_argument("start", type=Path, help="the start head's model (features v2 or v3)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    for p in (args.full, args.start):
        if not p.is_file():
            print(f"error: no such model: {p}", file=sys.stderr)
            return 2
    try:
        combine(args.full, args.start, args.out)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out} ({args.out.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
