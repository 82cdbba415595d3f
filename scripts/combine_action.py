"""Join trained action models into one file with a start head, written as one grouped stack.

    .venv/bin/python scripts/combine_action.py --full FULL.onnx [FULL2.onnx ...] \
        --start START.onnx [START2.onnx ...] --out pipeline/recognition/action.onnx

The networks of the FULL files (features ``v2``: the whole body and the step evidence) become the
model's first output, ``probs``, the softmax of their mean logits; those of the START files (``v2`` or
``v3``: the legs, hips and shoulders and the step evidence) the second, ``start_probs``, fed the same
input with the joints they do not see zeroed (their first layers' filters for those joints are zero:
what :func:`pipeline.recognition.features.model_input` does for ``v3``). A file with a start head
given to ``--start`` gives its start head's networks, to ``--full`` its first output's: so the
committed file and newly trained ones can be joined. One onnxruntime call gives both outputs; the bout
gate reads the start head only while no bout is on (:class:`pipeline.recognition.bout.GateConfig`,
``start_network``). Both outputs' networks are written as one grouped stack
(:func:`pipeline.recognition.networks.fused_model`: each layer one convolution for all of them, split
per output before the pooling; 47 graph nodes for eight networks per output instead of forty per
network) and checked against the files it came from (at most 1e-5 apart) before it is written.
Needs the ``train`` extra (onnx). The files come from ``scripts/train_action.py`` with the same
``--window``; the first START file's metadata is kept under ``start_`` keys, ``seed`` and
``members`` (and ``start_seed``, ``start_members``) count every file's networks, ``sources`` names
every file's sources. ``FILE:SEEDS`` (``SEEDS`` like ``4-7`` or ``4,6``) takes only the networks of
those seeds (the file's ``seed`` metadata, one seed per network) from that file's output: an ensemble
keeps some of a committed file's networks and replaces the others.

    .venv/bin/python scripts/combine_action.py --full NEW.onnx action.onnx:4-7 \
        --start NEW_START.onnx action.onnx:4-7 --out pipeline/recognition/action.onnx
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
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
from pipeline.recognition.networks import (  # noqa: E402
    LAYOUT_KEY,
    TOWERS_KEY,
    Network,
    fused_model,
    metadata,
    read_networks,
)
from pipeline.skeleton import ACTIONS  # noqa: E402

_SHARED = ("window", "fps", "classes")


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


@dataclass(frozen=True, slots=True)
class Part:
    """One file's share of one output: its networks, the output they come from and the metadata that
    describes them (a start head's without the ``start_`` prefix)."""

    path: Path
    proto: Any
    output: str
    meta: dict[str, str]
    networks: list[Network]


def parse_seeds(text: str) -> tuple[int, ...]:
    """``4-7`` or ``4,6`` (or both: ``0-1,6``) as seeds; ValueError for anything else."""
    seeds: list[int] = []
    for item in text.split(","):
        lo, dash, hi = item.partition("-")
        if not lo.isdigit() or (dash and not hi.isdigit()):
            raise ValueError(f"seeds are like 4-7 or 4,6, got {text!r}")
        first, last = int(lo), int(hi) if dash else int(lo)
        if last < first:
            raise ValueError(f"seeds are like 4-7 or 4,6, got {text!r}")
        seeds += range(first, last + 1)
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"a seed is named twice in {text!r}")
    return tuple(seeds)


def split_spec(text: str) -> tuple[Path, tuple[int, ...] | None]:
    """``FILE`` or ``FILE:SEEDS`` as (path, seeds or None)."""
    head, sep, tail = text.rpartition(":")
    if sep and tail and all(c.isdigit() or c in ",-" for c in tail):
        return Path(head), parse_seeds(tail)
    return Path(text), None


def _subset(part: Part, seeds: tuple[int, ...]) -> Part:
    """The networks of ``seeds`` alone, as a one-output file of their own (the reference that the
    joined model is checked against)."""
    have = part.meta.get("seed", "").split(",")
    if len(have) != len(part.networks):
        raise ValueError(
            f"{part.path.name} names {len(have)} seeds for {len(part.networks)} networks: "
            "its networks cannot be chosen by seed"
        )
    missing = [s for s in seeds if str(s) not in have]
    if missing:
        raise ValueError(
            f"{part.path.name} has no network of seed {missing[0]} (its seeds: {','.join(have)})"
        )
    chosen = [part.networks[have.index(str(s))] for s in seeds]
    meta = dict(part.meta, seed=",".join(map(str, seeds)), members=str(len(seeds)))
    proto = fused_model(part.proto, [("probs", chosen, None)], meta, share=False)
    return Part(part.path, proto, "probs", meta, chosen)


def _part(path: Path, as_start: bool, seeds: tuple[int, ...] | None = None) -> Part:
    part = _whole_part(path, as_start)
    return part if seeds is None else _subset(part, seeds)


def _whole_part(path: Path, as_start: bool) -> Part:
    proto = _load(path)
    meta = metadata(proto)
    outputs = [o.name for o in proto.graph.output]
    if as_start and len(outputs) == 2:  # a file with a start head: its start networks
        meta = {
            k.removeprefix("start_"): v for k, v in meta.items() if k.startswith("start_") or k in _SHARED
        }
        output = outputs[1]
    elif len(outputs) in (1, 2):
        meta = {k: v for k, v in meta.items() if not k.startswith("start_")}
        output = outputs[0]
    else:
        raise ValueError(f"{path.name} has {len(outputs)} outputs; an action model has one or two")
    for key in (LAYOUT_KEY, TOWERS_KEY):  # written again for the joined file
        meta.pop(key, None)
    try:
        networks = read_networks(proto, output)
    except ValueError as exc:
        raise ValueError(f"{path.name}: {exc}") from None
    return Part(path, proto, output, meta, networks)


def _joined(parts: list[Part], role: str, allowed: tuple[str, ...]) -> dict[str, str]:
    """The metadata of one output's files: the first file's, with every file's seeds and networks."""
    first = parts[0].meta
    for part in parts:
        for key in _SHARED:
            if part.meta.get(key) != first.get(key):
                raise ValueError(
                    f"{parts[0].path.name} and {part.path.name} differ in {key}: "
                    f"{first.get(key)!r} and {part.meta.get(key)!r}"
                )
        if part.meta.get("features") not in allowed:
            raise ValueError(
                f"the {role} model must take features {' or '.join(allowed)}, "
                f"{part.path.name} takes {part.meta.get('features')!r}"
            )
        if part.meta.get("features") != first.get("features"):
            raise ValueError(
                f"the {role} models differ in features: "
                f"{first.get('features')!r} and {part.meta.get('features')!r}"
            )
    meta = dict(first)
    meta["members"] = str(sum(len(p.networks) for p in parts))
    if all("seed" in p.meta for p in parts):
        meta["seed"] = ",".join(p.meta["seed"] for p in parts)
    if all("sources" in p.meta for p in parts):
        names = [n for p in parts for n in p.meta["sources"].split(",")]
        meta["sources"] = ",".join(dict.fromkeys(names))
    return meta


def _reference(parts: list[Part], scale: np.ndarray | None, x: np.ndarray) -> np.ndarray:
    """What one output of the joined model must give on inputs x: the softmax of the mean of every
    network's logits, from each file's own probabilities (log p is the logits up to a constant per
    window, which the softmax drops), each file weighted by its networks."""
    total = np.zeros((x.shape[0], len(ACTIONS)), np.float64)
    for part in parts:
        session = _session(part.proto)
        names = [o.name for o in session.get_outputs()]
        # a file with a start head masks its start networks' input itself
        fed = x if (scale is None or len(names) == 2) else x * scale[None, :, None]
        probs = session.run([part.output], {session.get_inputs()[0].name: fed})[0]
        total += len(part.networks) * np.log(np.maximum(probs.astype(np.float64), 1e-30))
    total /= sum(len(p.networks) for p in parts)
    total = np.exp(total - total.max(axis=1, keepdims=True))
    return total / total.sum(axis=1, keepdims=True)


Spec = tuple[Path, tuple[int, ...] | None]


def combine(full_specs: list[Spec], start_specs: list[Spec], out: Path) -> float:
    """Write the FULL files' networks as output ``probs`` and the START files' as ``start_probs``,
    grouped; the largest difference from the files' own outputs. Each file comes with the seeds of
    the networks to take from it, or None for all (:func:`split_spec`). ValueError if they do not
    fit together, one is no ONNX model, a seed is not in its file or the joined model would differ
    from them."""
    import onnx

    full = [_part(p, False, seeds) for p, seeds in full_specs]
    start = [_part(p, True, seeds) for p, seeds in start_specs]
    mf = _joined(full, "full", (FEATURES_V2,))
    ms = _joined(start, "start", (FEATURES_V2, FEATURES_V3))
    for key in _SHARED:
        if mf.get(key) != ms.get(key):
            raise ValueError(f"the two models differ in {key}: {mf.get(key)!r} and {ms.get(key)!r}")
    scale = start_mask(ms["features"]).reshape(-1)
    meta = dict(mf)
    meta.update({f"start_{k}": v for k, v in ms.items() if k not in _SHARED})
    model = fused_model(
        full[0].proto,
        [
            ("probs", [n for p in full for n in p.networks], None),
            ("start_probs", [n for p in start for n in p.networks], scale),
        ],
        meta,
    )
    channels, window = FEATURE_CHANNELS[FEATURES_V2], int(mf["window"])
    rng = np.random.default_rng(0)
    x = rng.standard_normal((64, channels, window)).astype(np.float32)
    joined = _session(model)
    session_out = [np.asarray(o, np.float64) for o in joined.run(None, {joined.get_inputs()[0].name: x})]
    diff = 0.0
    for parts, mask, got in ((full, None, session_out[0]), (start, scale, session_out[1])):
        diff = max(diff, float(np.abs(_reference(parts, mask, x) - got).max()))
    if diff > 1e-5:
        raise ValueError(f"the joined model differs from its files by {diff:.2g} (> 1e-5)")
    out.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(model, str(out))
    return diff


def _session(proto: Any) -> Any:
    """An onnxruntime session (one thread, CPU) of an in-memory model."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.log_severity_level = 3
    return ort.InferenceSession(proto.SerializeToString(), opts, providers=["CPUExecutionProvider"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--full", nargs="+", required=True, help="the full-body models (features v2): FILE or FILE:SEEDS"
    )
    ap.add_argument(
        "--start", nargs="+", required=True, help="the start head's models (v2 or v3): FILE or FILE:SEEDS"
    )
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    try:
        full, start = [split_spec(t) for t in args.full], [split_spec(t) for t in args.start]
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for p, _ in (*full, *start):
        if not p.is_file():
            print(f"error: no such model: {p}", file=sys.stderr)
            return 2
    try:
        diff = combine(full, start, args.out)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(
        f"wrote {args.out} ({args.out.stat().st_size // 1024} KiB; "
        f"largest difference from its files {diff:.1g})"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
