"""The action model's networks as arrays: read from an ONNX file, written as one grouped graph.

A trained file (``scripts/train_action.py``) is the export of a
:class:`pipeline.recognition.model.SlowFastEnsemble`: each network's eight convolutions (batch norm
folded in) and its head, one network after another, about 40 graph nodes each. onnxruntime then
runs several hundred small nodes per frame, and their overhead is much of the model call.
:func:`fused_model` writes the same networks as **one stack whose every layer holds all networks**
of every output (the full-body judge's and the start head's): the first layers as one convolution
with the networks' filters side by side, the later ones as grouped convolutions (one group per
network), then split per output, each output's heads one block-diagonal matrix followed by the mean
of the logits. Same arithmetic, 47 nodes for two outputs of eight networks each (62 with a stack per
output, as files written before 2026-12-07 are); its outputs equal the separate networks' to float
rounding (``scripts/combine_action.py`` checks them before it writes).

:func:`read_networks` reads either form back (fine-tuning and ``scripts/combine_action.py`` use it).
Needs ``onnx`` (the ``train`` extra); the runtime only runs the files.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

LAYERS = ("slow1", "fast1", "lat1", "slow2", "fast2", "lat2", "slow3", "fast3")  # the export's order
SLOW_LAYERS = ("slow1", "slow2", "slow3")  # a network without its fast pathway (the ablation)
LAYOUT_KEY = "layout"  # metadata: "grouped" for a fused file
GROUPED = "grouped"
# metadata of a file whose outputs share one stack: "output:first:count,..." (networks in the stack)
TOWERS_KEY = "towers"


@dataclass(frozen=True, slots=True)
class Network:
    """One skeleton SlowFast network's weights: ``convs`` in :data:`LAYERS` order (or
    :data:`SLOW_LAYERS`), each ``(weight (out, in, k) float32, bias (out,) float32)``;
    ``head`` ``(weight (classes, features), bias (classes,))``."""

    convs: tuple[tuple[NDArray[np.float32], NDArray[np.float32]], ...]
    head: tuple[NDArray[np.float32], NDArray[np.float32]]

    def __post_init__(self) -> None:
        if len(self.convs) not in (len(LAYERS), len(SLOW_LAYERS)):
            raise ValueError(
                f"a network has {len(LAYERS)} or {len(SLOW_LAYERS)} convolutions, got {len(self.convs)}"
            )
        for w, b in self.convs:
            if w.ndim != 3 or b.shape != (w.shape[0],):
                raise ValueError(
                    f"a convolution needs weight (out, in, k) and bias (out,), got {w.shape}, {b.shape}"
                )
        if self.head[0].ndim != 2 or self.head[1].shape != (self.head[0].shape[0],):
            raise ValueError(
                f"the head needs weight (classes, features) and bias (classes,), got {self.head[0].shape}"
            )

    @property
    def fast(self) -> bool:
        return len(self.convs) == len(LAYERS)

    def conv(self, name: str) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        return self.convs[(LAYERS if self.fast else SLOW_LAYERS).index(name)]

    @property
    def alpha(self) -> int:
        """The slow pathway's frame stride (the lateral convolutions' kernel)."""
        return int(self.conv("lat1")[0].shape[2]) if self.fast else 4


def metadata(proto: Any) -> dict[str, str]:
    """An ONNX model's metadata, key -> value."""
    return {p.key: p.value for p in proto.metadata_props}


def read_networks(proto: Any, output: str | None = None) -> list[Network]:
    """The networks behind one output (the first by default) of an action model: a training export
    (one network after another) or a :func:`fused_model` file. A start head's input mask (the joints a
    ``v3`` network does not see) is not part of the networks; ValueError if the graph is neither
    form."""
    import onnx.utils
    from onnx import helper, numpy_helper

    names = [o.name for o in proto.graph.output]
    out = names[0] if output is None else output
    if out not in names:
        raise ValueError(f"the model has no output {out!r} (it has {', '.join(names)})")
    sub = proto
    if len(names) > 1:
        sub = onnx.utils.Extractor(proto).extract_model([proto.graph.input[0].name], [out])
    init = {t.name: numpy_helper.to_array(t) for t in sub.graph.initializer}
    convs: list[tuple[NDArray[np.float32], NDArray[np.float32], int]] = []
    heads: list[tuple[NDArray[np.float32], NDArray[np.float32]]] = []
    for node in sub.graph.node:  # the forward pass's order
        if node.op_type == "Conv":
            w = init.get(node.input[1])
            if w is None:
                raise ValueError("a convolution's weights are not constants")
            b = init.get(node.input[2]) if len(node.input) > 2 else None
            group = next((helper.get_attribute_value(a) for a in node.attribute if a.name == "group"), 1)
            bias = np.zeros(w.shape[0], np.float32) if b is None else b
            convs.append((w.astype(np.float32), bias.astype(np.float32), int(group)))
        elif node.op_type == "Gemm":
            w = init.get(node.input[1])
            b = init.get(node.input[2]) if len(node.input) > 2 else None
            if w is None or b is None:
                raise ValueError("the classifier head's weights are not constants")
            trans_b = next((helper.get_attribute_value(a) for a in node.attribute if a.name == "transB"), 0)
            heads.append(((w if trans_b else w.T).astype(np.float32), b.astype(np.float32)))
    meta = metadata(proto)
    if meta.get(LAYOUT_KEY) == GROUPED:
        return _unfuse(convs, heads, *_tower(meta.get(TOWERS_KEY), out))
    per = len(convs) // max(len(heads), 1)
    if not heads or per not in (len(LAYERS), len(SLOW_LAYERS)) or per * len(heads) != len(convs):
        raise ValueError(
            "not the skeleton SlowFast network cavewalk trains "
            f"({len(convs)} convolutions, {len(heads)} heads)"
        )
    return [
        Network(tuple((w, b) for w, b, _ in convs[k * per : (k + 1) * per]), heads[k])
        for k in range(len(heads))
    ]


def _tower(towers: str | None, output: str) -> tuple[int, int | None]:
    """(first network, count) of ``output`` in a shared stack's ``towers`` metadata; (0, None), the
    whole stack, for a stack of its own."""
    if towers is None:
        return 0, None
    for entry in towers.split(","):
        name, _, span = entry.partition(":")
        if name == output:
            try:
                first, count = (int(v) for v in span.split(":"))
            except ValueError:
                break
            return first, count
    raise ValueError(f"the model's towers metadata {towers!r} does not name output {output!r}")


def _unfuse(
    convs: list[tuple[NDArray[np.float32], NDArray[np.float32], int]],
    heads: list[tuple[NDArray[np.float32], NDArray[np.float32]]],
    first: int = 0,
    count: int | None = None,
) -> list[Network]:
    """The networks of one output of a grouped stack (the layout :func:`_towers` writes): ``count``
    networks from the stack's network ``first`` on (by default every network from ``first`` on)."""
    if len(convs) != len(LAYERS) or len(heads) != 1:
        raise ValueError(f"a grouped model has {len(LAYERS)} convolutions and one head per output")
    total = convs[LAYERS.index("lat1")][2]
    g = total - first if count is None else count
    if first < 0 or g < 1 or first + g > total:
        raise ValueError(f"networks {first} to {first + g - 1} are not in a stack of {total}")
    layers = dict(zip(LAYERS, convs, strict=True))
    cs, cf = layers["slow1"][0].shape[0] // total, layers["fast1"][0].shape[0] // total
    hw, hb = heads[0]  # (g * classes, 2 g cs + 2 g cf), block-diagonal
    k = hb.shape[0] // g
    nets = []
    for m in range(g):
        parts = []
        for name in LAYERS:
            w, b, _ = layers[name]
            n = w.shape[0] // total
            parts.append((w[(first + m) * n : (first + m + 1) * n], b[(first + m) * n : (first + m + 1) * n]))
        rows = hw[m * k : (m + 1) * k]
        cols = np.r_[
            m * cs : (m + 1) * cs,
            (g + m) * cs : (g + m + 1) * cs,
            2 * g * cs + m * cf : 2 * g * cs + (m + 1) * cf,
            2 * g * cs + (g + m) * cf : 2 * g * cs + (g + m + 1) * cf,
        ]
        nets.append(Network(tuple(parts), (rows[:, cols], hb[m * k : (m + 1) * k])))
    return nets


_TO_END = np.array([np.iinfo(np.int64).max], np.int64)  # a Slice's end: to the end of the axis


def _constant(inits: list[Any], name: str, value: Any) -> str:
    """Add ``value`` to ``inits`` as the initializer ``name``; its name."""
    from onnx import numpy_helper

    inits.append(numpy_helper.from_array(np.asarray(value), name))
    return name


def _towers(
    heads: list[tuple[list[Network], NDArray[np.float32] | None]], x: str, prefix: str
) -> tuple[list[Any], list[Any], list[tuple[str, str]]]:
    """(nodes, initializers, each output's (slow, fast) last layer) of the networks of every output
    as one stack: each layer one convolution whose groups are the networks, every output's in turn,
    split per output at the end. ``heads`` = [(networks, input scale or None)]."""
    from onnx import helper

    nets = [n for group, _ in heads for n in group]
    if not nets or not all(n.fast for n in nets):
        raise ValueError("only networks with both pathways can be fused")
    if not _one_architecture(nets):
        raise ValueError("the networks differ in shape; only networks of one architecture can be fused")
    first = nets[0]
    g, a = len(nets), first.alpha
    cs, cf = first.conv("slow1")[0].shape[0], first.conv("fast1")[0].shape[0]
    scales = [scale for group, scale in heads for _ in group]
    nodes: list[Any] = []
    inits: list[Any] = []

    def const(name: str, value: Any) -> str:
        return _constant(inits, f"{prefix}/{name}", value)

    def conv(name: str, src: str, stride: int = 1, causal: bool = True, group: int = 1) -> str:
        ws = [n.conv(name)[0] for n in nets]
        if name in ("slow1", "fast1"):  # the masked joints: zero filters
            ws = [w if s is None else w * s[None, :, None] for w, s in zip(ws, scales, strict=True)]
        w = np.concatenate(ws).astype(np.float32)
        b = np.concatenate([n.conv(name)[1] for n in nets]).astype(np.float32)
        k = int(w.shape[2])
        nodes.append(
            helper.make_node(
                "Conv",
                [src, const(f"{name}/w", w), const(f"{name}/b", b)],
                [f"{prefix}/{name}/conv"],
                name=f"{prefix}/{name}",
                kernel_shape=[k],
                strides=[stride],
                pads=[k - 1 if causal else 0, 0],
                group=group,
            )
        )
        nodes.append(helper.make_node("Relu", [f"{prefix}/{name}/conv"], [f"{prefix}/{name}/out"]))
        return f"{prefix}/{name}/out"

    def interleave(name: str, slow: str, lat: str) -> str:
        """[slow of every network, lateral of every network] -> each network's [slow, lateral]: two
        reshapes and one concatenation (no copy by index)."""
        p = f"{prefix}/{name}"
        nodes.append(
            helper.make_node("Reshape", [slow, const(f"{name}/slow_shape", [0, g, cs, -1])], [f"{p}/s"])
        )
        nodes.append(
            helper.make_node("Reshape", [lat, const(f"{name}/lat_shape", [0, g, 2 * cf, -1])], [f"{p}/l"])
        )
        nodes.append(helper.make_node("Concat", [f"{p}/s", f"{p}/l"], [f"{p}/cat"], axis=2))
        nodes.append(
            helper.make_node("Reshape", [f"{p}/cat", const(f"{name}/shape", [0, g * (cs + 2 * cf), -1])], [p])
        )
        return p

    nodes.append(
        helper.make_node(
            "Slice",
            [
                x,
                const("every_alpha/start", [a - 1]),
                const("every_alpha/end", _TO_END),
                const("time_axis", [2]),
                const("every_alpha/step", [a]),
            ],
            [f"{prefix}/slow_in"],
        )
    )
    slow = conv("slow1", f"{prefix}/slow_in")
    fast = conv("fast1", x)
    slow = conv("slow2", interleave("in2", slow, conv("lat1", fast, a, False, g)), group=g)
    fast = conv("fast2", fast, group=g)
    slow = conv("slow3", interleave("in3", slow, conv("lat2", fast, a, False, g)), group=g)
    fast = conv("fast3", fast, group=g)
    if len(heads) == 1:
        return nodes, inits, [(slow, fast)]
    sizes = [len(group) for group, _ in heads]
    outs = []
    for path, src, width in (("slow", slow, cs), ("fast", fast, cf)):
        names = [f"{prefix}/{path}{i}" for i in range(len(heads))]
        split = const(f"{path}_split", np.array([n * width for n in sizes], np.int64))
        nodes.append(helper.make_node("Split", [src, split], names, axis=1))
        outs.append(names)
    return nodes, inits, list(zip(outs[0], outs[1], strict=True))


def _pooled_head(nets: list[Network], slow: str, fast: str, prefix: str) -> tuple[list[Any], list[Any], str]:
    """(nodes, initializers, logits name) of one output: its networks' pooling and heads, on their
    stack's last slow and fast layers."""
    from onnx import helper

    g, a = len(nets), nets[0].alpha
    cs, cf = nets[0].conv("slow1")[0].shape[0], nets[0].conv("fast1")[0].shape[0]
    inits: list[Any] = []

    def const(name: str, value: Any) -> str:
        return _constant(inits, f"{prefix}/{name}", value)

    p = prefix
    nodes = [
        helper.make_node("ReduceMean", [slow], [f"{p}/slow_mean"], axes=[2], keepdims=0),
        helper.make_node("Gather", [slow, const("last", np.array(-1, np.int64))], [f"{p}/slow_last"], axis=2),
        helper.make_node("ReduceMean", [fast], [f"{p}/fast_mean"], axes=[2], keepdims=0),
        helper.make_node(
            "Slice",
            [fast, const("tail/start", [-a]), const("tail/end", _TO_END), const("tail_axis", [2])],
            [f"{p}/fast_tail"],
        ),
        helper.make_node("ReduceMean", [f"{p}/fast_tail"], [f"{p}/fast_last"], axes=[2], keepdims=0),
        helper.make_node(
            "Concat",
            [f"{p}/slow_mean", f"{p}/slow_last", f"{p}/fast_mean", f"{p}/fast_last"],
            [f"{p}/pooled"],
            axis=1,
        ),
    ]
    k = nets[0].head[0].shape[0]
    # block-diagonal: network m's logits from its own pooled features ([slow mean, slow last, fast
    # mean, fast tail] of every network in turn, the columns of its head in that order)
    hw = np.zeros((2 * g * (cs + cf), g * k), np.float32)
    for m, n in enumerate(nets):
        w, out = n.head[0], slice(m * k, (m + 1) * k)
        f0 = 2 * g * cs
        hw[m * cs : (m + 1) * cs, out] = w[:, :cs].T
        hw[(g + m) * cs : (g + m + 1) * cs, out] = w[:, cs : 2 * cs].T
        hw[f0 + m * cf : f0 + (m + 1) * cf, out] = w[:, 2 * cs : 2 * cs + cf].T
        hw[f0 + (g + m) * cf : f0 + (g + m + 1) * cf, out] = w[:, 2 * cs + cf :].T
    hb = np.concatenate([n.head[1] for n in nets]).astype(np.float32)
    nodes += [
        helper.make_node(
            "Gemm",
            [f"{p}/pooled", const("head/w", hw), const("head/b", hb)],
            [f"{p}/logits_each"],
            name=f"{p}/head",
        ),
        helper.make_node(
            "Reshape",
            [f"{p}/logits_each", const("per_network", np.array([-1, g, k], np.int64))],
            [f"{p}/logits_split"],
        ),
        helper.make_node("ReduceMean", [f"{p}/logits_split"], [f"{p}/logits"], axes=[1], keepdims=0),
    ]
    return nodes, inits, f"{p}/logits"


def _one_architecture(nets: list[Network]) -> bool:
    """Every network has the first one's pathways and layer shapes."""
    first = nets[0]
    shape = [tuple(w.shape) for w, _ in first.convs]
    return all(
        n.fast == first.fast
        and [tuple(w.shape) for w, _ in n.convs] == shape
        and n.head[0].shape == first.head[0].shape
        for n in nets
    )


def fused_model(
    template: Any,
    heads: list[tuple[str, list[Network], NDArray[np.float32] | None]],
    metadata: dict[str, str],
    share: bool = True,
) -> Any:
    """A model whose outputs are ``heads`` = [(output name, its networks, input scale or None)], each
    the softmax of its networks' mean logits, written as grouped stacks; input and opset as in
    ``template`` (an exported action model). Metadata ``metadata`` plus ``layout=grouped``.

    With ``share`` and networks of one architecture in every output, all of them share one stack
    (each layer one convolution for every output's networks; the metadata's ``towers`` names each
    output's networks in it): the same arithmetic as a stack per output, with half the convolutions
    onnxruntime runs per call for two outputs."""
    import onnx
    from onnx import helper

    x = template.graph.input[0]
    nodes: list[Any] = []
    inits: list[Any] = []
    outputs = []
    shared = share and len(heads) > 1 and _one_architecture([n for _, nets, _ in heads for n in nets])
    stacks = [heads] if shared else [[h] for h in heads]
    towers: list[str] = []
    for stack in stacks:
        prefix = "towers" if shared else stack[0][0]
        n, i, last = _towers([(nets, scale) for _, nets, scale in stack], x.name, prefix)
        nodes += n
        inits += i
        first = 0
        for (name, nets, _), (slow, fast) in zip(stack, last, strict=True):
            n, i, logits = _pooled_head(nets, slow, fast, name)
            nodes += [*n, helper.make_node("Softmax", [logits], [name], axis=1)]
            inits += i
            towers.append(f"{name}:{first}:{len(nets)}")
            first += len(nets)
            out = onnx.ValueInfoProto()
            out.CopyFrom(template.graph.output[0])
            out.name = name
            outputs.append(out)
    graph = helper.make_graph(nodes, "action_grouped", [x], outputs, inits)
    model = helper.make_model(graph, opset_imports=template.opset_import, ir_version=template.ir_version)
    extra = {LAYOUT_KEY: GROUPED} | ({TOWERS_KEY: ",".join(towers)} if shared else {})
    for key, value in {**metadata, **extra}.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(model)
    return model
