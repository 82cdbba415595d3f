"""Action model files: what one says about itself, and whether cavewalk can run it.

An action model is an ONNX file with one input ``(B, channels, window)`` and one output
``probs`` ``(B, 4)`` (softmax over ``still, forward, left, right``) and the metadata the
recogniser reads (``window``, ``fps``, ``classes``, ``features``; see
``pipeline/recognition/MODEL_CARD.md``). :func:`check_model_file` loads it with onnxruntime,
checks all of that and runs it once on a zero window; a model card (JSON) given with it must
agree with the file. Anything else raises :class:`~pipeline.errors.ModelError` naming the problem.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.errors import ModelError
from pipeline.recognition.recognizer import FEATURE_CHANNELS, model_info, open_session
from pipeline.skeleton import ACTIONS

#: Card keys that must equal the model file's own metadata when a card gives them.
CARD_KEYS = ("window", "fps", "classes", "features", "sha256")
MAX_MODEL_BYTES = 64 * 1024 * 1024


@dataclass(frozen=True, slots=True)
class ModelFileInfo:
    """A checked action model file.

    window: frames per window; fps: the model's frame rate; classes: the four actions in order;
    features: ``v1`` or ``v2`` (the input channels); sha256 of the file; bytes: its size;
    metadata: every metadata key of the ONNX file.
    """

    window: int
    fps: float
    classes: tuple[str, ...]
    features: str
    sha256: str
    bytes: int
    metadata: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "window": self.window,
            "fps": self.fps,
            "classes": list(self.classes),
            "features": self.features,
            "sha256": self.sha256,
            "bytes": self.bytes,
            "metadata": dict(self.metadata),
        }


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with Path(path).open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _card_value_matches(key: str, card_value: Any, info: ModelFileInfo) -> bool:
    if key == "classes":
        given = card_value.split(",") if isinstance(card_value, str) else card_value
        return isinstance(given, list | tuple) and tuple(str(c) for c in given) == info.classes
    if key == "window":
        return (
            not isinstance(card_value, bool)
            and isinstance(card_value, int | str)
            and str(card_value) == str(info.window)
        )
    if key == "fps":
        try:
            return math.isclose(float(card_value), info.fps)
        except (TypeError, ValueError):
            return False
    return str(card_value) == str(getattr(info, key))


def check_model_file(path: Path, card: dict[str, Any] | None = None) -> ModelFileInfo:
    """Check that ``path`` is a four-class action model cavewalk can run (and agrees with ``card``).

    Raises :class:`ModelError` with one message naming the problem; reads nothing else.
    """
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"model file not found: {p}")
    size = p.stat().st_size
    if size > MAX_MODEL_BYTES:
        raise ModelError(f"{p.name}: {size} bytes is too large for an action model (<= {MAX_MODEL_BYTES})")
    with p.open("rb") as f:
        head = f.read(64)
    if not head:
        raise ModelError(f"{p.name}: the file is empty, not an ONNX model")
    try:
        session = open_session(p)
    except ModelError as exc:
        raise ModelError(f"{p.name}: not an ONNX model onnxruntime can load ({exc})") from None
    try:
        # ModelError: metadata missing, not the four actions, wrong input, not one (B, 4) output (and
        # a start head alike)
        info = model_info(session)
    except ModelError as exc:
        raise ModelError(f"{p.name}: {exc}") from None
    channels = FEATURE_CHANNELS[info.features]
    try:
        outs = session.run(None, {info.input_name: np.zeros((2, channels, info.window), np.float32)})
    except Exception as exc:  # onnxruntime's own error types
        raise ModelError(f"{p.name}: the model does not run on a window ({exc})") from None
    for out in (np.asarray(o, dtype=np.float64) for o in outs):
        sums_to_one = out.shape == (2, len(ACTIONS)) and np.allclose(out.sum(1), 1, atol=1e-3)
        if not sums_to_one or not np.isfinite(out).all():
            raise ModelError(
                f"{p.name}: the output must be {len(ACTIONS)} probabilities summing to 1 per window, "
                f"got {out[0]}"
            )
    meta = dict(session.get_modelmeta().custom_metadata_map)
    result = ModelFileInfo(
        window=info.window,
        fps=info.fps,
        classes=tuple(info.classes),
        features=info.features,
        sha256=sha256_file(p),
        bytes=size,
        metadata=meta,
    )
    if card is not None:
        if not isinstance(card, dict):
            raise ModelError("the model card must be a JSON object")
        wrong = [k for k in CARD_KEYS if k in card and not _card_value_matches(k, card[k], result)]
        if wrong:
            detail = ", ".join(f"{k}: card {card[k]!r}, file {getattr(result, k)!r}" for k in wrong)
            raise ModelError(f"{p.name}: the model card does not match the model file ({detail})")
    return result
