"""Fine-tuning the action model on recorded takes plus simulator data (``cavewalk train``; torch).

The network starts from a registered ONNX model's own weights (the committed model by default):
:func:`torch_from_onnx` reads the graph's convolutions (batch norm folded in by the export; a training
export or a grouped file, :mod:`pipeline.recognition.networks`) back into
:class:`~pipeline.recognition.model.SkeletonSlowFast` (each network of an ensemble file into its
:class:`~pipeline.recognition.model.SlowFastEnsemble`), whose batch norms then stay frozen at the
identity, so the untrained network computes exactly what the file does.
The data: every take's participant frames at the model's frame rate, mirrored (a mirrored left
side step is a right one), with the step evidence of the run-time tracker; plus simulated routines
(stepping and still behaviours) captured through the simulated CAVE cameras, so the model keeps
what it knew. Windows are drawn with each source weighing (its frames) ** 0.5.

Figures for the model card (:func:`train_on_takes`): leave-one-participant-out (each participant's
takes scored by a model fine-tuned without them, next to the base model on the same frames), the
pooled confusion matrix, and the base vs the new model on held-out simulated routines (another seed:
the recognition issue's check that nothing was forgotten). Scores are those of the streaming
recogniser (EMA, hysteresis, gate) replayed on the model's outputs (``evaluation.replay``).
"""

from __future__ import annotations

import logging
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import CavewalkError, InputError, ModelError
from pipeline.recognition import corpus
from pipeline.recognition.dataset import LabelledSequence
from pipeline.recognition.evaluation import network_trace, replay, scored
from pipeline.recognition.features import WITH_EVIDENCE
from pipeline.recognition.metrics import Evaluation, evaluate
from pipeline.recognition.networks import LAYOUT_KEY, TOWERS_KEY
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH, RecognizerConfig, model_info, open_session
from pipeline.skeleton import ACTIONS
from pipeline.takes.config import FinetuneConfig
from pipeline.takes.dataset import TakeData
from pipeline.takes.model_file import sha256_file

if TYPE_CHECKING:  # prepare and train import torch (the train extra): imported where they are used
    from pipeline.recognition.prepare import Item

log = logging.getLogger(__name__)
FPS = 30.0  # the frame rate the corpus is prepared at (pipeline.recognition.prepare.FPS)

Progress = Callable[[float, str], None]
HELDOUT_SEED = 7919  # the model card's seed for simulated test routines (training used 0)


class TrainingUnavailable(CavewalkError):
    """The ``train`` extra (torch, onnx) is not installed."""


def require_training() -> None:
    """Raise :class:`TrainingUnavailable` with the install command when torch or onnx is missing."""
    missing = []
    for name in ("torch", "onnx"):
        try:
            __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise TrainingUnavailable(
            f"training needs the 'train' extra ({', '.join(missing)} not installed): "
            "pip install 'cavewalk[train]'"
        )


# ----------------------------------------------------------------------------- ONNX -> torch
def torch_from_onnx(path: Path) -> tuple[Any, dict[str, Any]]:
    """(SkeletonSlowFast with the file's weights and frozen identity batch norms, or their
    SlowFastEnsemble for a file of several networks; the file's facts). Of a file with a start head
    (``scripts/combine_action.py``) the full-body network is read: a fine-tuned model has no start
    head."""
    import onnx

    from pipeline.recognition.model import SlowFastEnsemble
    from pipeline.recognition.networks import read_networks  # onnx: the train extra

    info = model_info(open_session(path))
    try:  # the first output's networks, of a training export or a grouped file alike
        networks = read_networks(onnx.load(str(path)))
    except ValueError as exc:
        raise ModelError(f"{path.name}: {exc}; it can be run and evaluated but not fine-tuned") from exc
    members = [_network(path, info.window, list(n.convs), n.head) for n in networks]
    model = members[0] if len(members) == 1 else SlowFastEnsemble(members).eval()
    facts = {
        "window": info.window,
        "fps": info.fps,
        "features": info.features,
        "metadata": dict(open_session(path).get_modelmeta().custom_metadata_map),
    }
    return model, facts


def _network(
    path: Path,
    window: int,
    convs: list[tuple[NDArray[Any], NDArray[Any] | None]],
    head: tuple[NDArray[Any], NDArray[Any]],
) -> Any:
    """One SkeletonSlowFast from its exported convolutions (batch norm folded in) and head."""
    import torch
    from torch import nn

    from pipeline.recognition.model import SkeletonSlowFast, SlowFastConfig

    fast = len(convs) == 8
    cs, cin = convs[0][0].shape[:2]
    cfg = SlowFastConfig(
        in_channels=int(cin),
        num_classes=len(ACTIONS),
        window=window,
        alpha=int(convs[2][0].shape[2]) if fast else 4,
        slow_channels=int(cs),
        beta=(convs[1][0].shape[0] / cs) if fast else 1 / 8,
        fast_pathway=fast,
    )
    model = SkeletonSlowFast(cfg)
    order = (
        ["slow1", "fast1", "lat1", "slow2", "fast2", "lat2", "slow3", "fast3"]
        if fast
        else ["slow1", "slow2", "slow3"]
    )  # the export's order: the forward pass's
    with torch.no_grad():
        for name, (w, b) in zip(order, convs, strict=True):
            block = getattr(model, name)
            conv = next(m for m in block if isinstance(m, nn.Conv1d))
            bn = next(m for m in block if isinstance(m, nn.BatchNorm1d))
            if tuple(conv.weight.shape) != w.shape:
                raise ModelError(
                    f"{path.name}: layer {name} is {w.shape}, expected {tuple(conv.weight.shape)}"
                )
            conv.weight.copy_(torch.from_numpy(np.array(w)))
            bn.weight.fill_(1.0)
            bias = np.array(b) if b is not None else np.zeros(w.shape[0], np.float32)
            bn.bias.copy_(torch.from_numpy(bias))
            bn.running_mean.zero_()
            bn.running_var.fill_(1.0 - bn.eps)
        if tuple(model.head.weight.shape) != head[0].shape:
            raise ModelError(
                f"{path.name}: head is {head[0].shape}, expected {tuple(model.head.weight.shape)}"
            )
        model.head.weight.copy_(torch.from_numpy(np.array(head[0])))
        model.head.bias.copy_(torch.from_numpy(np.array(head[1])))
    model.eval()
    return model


# ------------------------------------------------------------------------------------- data
def take_items(takes: Sequence[TakeData], fps: float = FPS) -> list[Item]:
    """Each take at the model's frame rate and mirrored, with its step evidence (source ``takes``)."""
    from pipeline.recognition.prepare import Item, evidence_of

    out = []
    for td in takes:
        seq = corpus.resample(td.seq, fps)
        seq = LabelledSequence(seq.joints_m, seq.fps, seq.labels, seq.tags, None, "takes", td.uid)
        for s, original in ((seq, True), (corpus.mirrored(seq), False)):
            s32 = replace(s, joints_m=s.joints_m.astype(np.float32))
            out.append(Item(f"takes:{td.uid}", s32, evidence_of(s), original))
    return out


def sim_items(
    config: FinetuneConfig,
    cache_dir: Path,
    seed: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[Item]:
    """Simulated routines (stepping and still behaviours in turn), captured and with evidence."""
    from pipeline.recognition.prepare import SourceSpec, prepare_source

    if config.sim_routines == 0:
        return []
    spec = SourceSpec.parse(f"sim=sim:stepping+still@{config.sim_routines}")
    return prepare_source(
        spec,
        cache_dir,
        config.sim_routines,
        config.sim_duration_s,
        config.seed if seed is None else seed,
        progress=progress,
    )


# ---------------------------------------------------------------------------------- training
def finetune(
    base: Path,
    items: Sequence[Item],
    config: FinetuneConfig,
    progress: Progress | None = None,
    share: tuple[float, float] = (0.0, 1.0),
) -> tuple[Any, dict[str, Any]]:
    """Fine-tune the network of ``base`` on ``items``; (model in eval mode, metrics).

    ``progress(fraction, message)`` after every epoch, the fraction within ``share`` of the whole job.
    """
    import torch
    from torch import nn

    from pipeline.recognition.prepare import to_dataset
    from pipeline.recognition.train import batch_inputs, sampling_weights, window_ends

    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    rng = np.random.default_rng(config.seed)
    model, facts = torch_from_onnx(base)
    data = to_dataset(items)
    features = facts["features"]
    if features in WITH_EVIDENCE and data.evidence is None:
        raise ModelError(f"features {features} need step evidence")
    window = int(facts["window"])
    ends_all = window_ends(data)
    p_ends = sampling_weights(data, 0.5)
    known = data.labels[data.labels >= 0]
    freq = np.bincount(known, minlength=len(ACTIONS)) / max(len(known), 1)
    inv = 1.0 / np.sqrt(np.maximum(freq, 1e-3))
    loss_fn = nn.CrossEntropyLoss(
        weight=torch.tensor(inv / inv.mean(), dtype=torch.float32), label_smoothing=config.label_smoothing
    )
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    steps = config.windows_per_epoch // config.batch_size
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=config.epochs * steps)
    history = []
    t0 = time.monotonic()
    for epoch in range(config.epochs):
        model.train()
        for m in model.modules():  # the batch norms stay the file's (folded) identity
            if isinstance(m, nn.BatchNorm1d):
                m.eval()
        ends = rng.choice(ends_all, size=steps * config.batch_size, replace=True, p=p_ends)
        total = 0.0
        for b in range(steps):
            e = ends[b * config.batch_size : (b + 1) * config.batch_size]
            x = torch.from_numpy(batch_inputs(data, e, window, features))
            y = torch.from_numpy(data.labels[e])
            opt.zero_grad()
            loss = loss_fn(model(x), y)
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.item())
        history.append({"epoch": epoch + 1, "loss": total / steps})
        if progress is not None:
            lo, hi = share
            progress(
                lo + (hi - lo) * (epoch + 1) / config.epochs,
                f"epoch {epoch + 1}/{config.epochs}: loss {total / steps:.4f} "
                f"({time.monotonic() - t0:.0f} s)",
            )
    model.eval()
    return model, {
        "history": history,
        "train_s": time.monotonic() - t0,
        "frames": len(data.labels),
        "windows": config.epochs * steps * config.batch_size,
        "facts": facts,
    }


def export(model: Any, out: Path, facts: dict[str, Any], extra: dict[str, str]) -> None:
    from pipeline.recognition.train import export_onnx

    meta = {
        k: v
        for k, v in facts["metadata"].items()
        if k not in ("window", "fps", "classes", "features", LAYOUT_KEY, TOWERS_KEY)
        and not k.startswith("start_")
    }  # the base's start head is not carried over, nor its grouped layout (an export is not grouped)
    export_onnx(
        model,
        out,
        int(facts["window"]),
        float(facts["fps"]),
        extra={**meta, **extra},
        features=facts["features"],
    )


# -------------------------------------------------------------------------------- evaluation
def score(model_path: Path, seqs: Sequence[LabelledSequence], exclude_s: float = 0.3) -> Evaluation:
    """The streaming recogniser with ``model_path`` on labelled sequences (replayed on batched outputs)."""
    session = open_session(model_path)
    fps = model_info(session).fps
    out = []
    for s in seqs:
        r = corpus.resample(s, fps)
        trace = network_trace(session, r.joints_m, r.fps)
        out.append(scored(r, replay(trace, RecognizerConfig(model_path=model_path))))
    return evaluate(out, exclude_s)


def summary(ev: Evaluation) -> dict[str, Any]:
    return {
        "accuracy": ev.accuracy,
        "macro_f1": ev.macro_f1,
        "frames": ev.frames,
        "false_movement": ev.overall.false_movement,
        "false_starts": ev.overall.false_starts,
        "movement_detected": ev.overall.movement_detected,
        "confusion": ev.confusion.tolist(),
    }


def heldout_sources(cache_dir: Path) -> dict[str, list[LabelledSequence]]:
    """The recognition issue's held-out sources (``cavewalk data sources``: every folder of use
    ``eval``: the third and second motion models' held-out sets, the still library's, real motion
    capture), as they are on disk; empty when the sources were never made on this machine."""
    from pipeline.mocap.sources import load_sources

    try:
        manifest = load_sources(cache_dir)
    except InputError:
        return {}
    out = {}
    for name, m in sorted(manifest.items()):
        folder = Path(m["dir"])
        if m.get("use") == "eval" and folder.is_dir():
            out[name] = corpus.from_folder(folder, source=name)
    return out


@dataclass(frozen=True, slots=True)
class TrainingResult:
    out: Path
    card: dict[str, Any]
    card_md: str


def train_on_takes(
    takes: Sequence[TakeData],
    out: Path,
    config: FinetuneConfig,
    cache_dir: Path,
    base: Path = DEFAULT_MODEL_PATH,
    progress: Progress | None = None,
    sources_cache: Path | None = None,
) -> TrainingResult:
    """Fine-tune ``base`` on the takes plus simulator data, write ``out`` and its card; the card's
    figures: leave-one-participant-out, confusion matrix, held-out simulated routines, and the
    recognition issue's held-out sources when ``cavewalk data sources`` made them under
    ``sources_cache`` (the settings' cache folder)."""
    require_training()
    say: Progress = progress or (lambda _f, _m: None)
    t0 = time.monotonic()
    participants = sorted({t.participant for t in takes})
    say(0.0, f"{len(takes)} takes of {len(participants)} participants; preparing the data")
    by_take = {t.uid: take_items([t]) for t in takes}
    sim = sim_items(config, cache_dir, progress=lambda m: say(0.02, m))
    heldout = [
        it.seq
        for it in sim_items(
            replace(config, sim_routines=config.heldout_routines), cache_dir, seed=HELDOUT_SEED
        )
        if it.original
    ]
    prep_s = time.monotonic() - t0
    folds = participants if config.loso and len(participants) >= 2 else []
    n_runs = len(folds) + 1
    fold_rows: list[dict[str, Any]] = []
    pooled = np.zeros((4, 4), np.int64)
    pooled_base = np.zeros((4, 4), np.int64)
    with tempfile.TemporaryDirectory(prefix="cavewalk-loso-") as tmp:
        for k, who in enumerate(folds):
            train_items = [it for t in takes if t.participant != who for it in by_take[t.uid]] + sim
            model, _m = finetune(
                base, train_items, config, say, (0.05 + 0.9 * k / n_runs, 0.05 + 0.9 * (k + 1) / n_runs)
            )
            fold_path = Path(tmp) / f"fold-{k}.onnx"
            export(model, fold_path, _m["facts"], {})
            test = [t.seq for t in takes if t.participant == who]
            tuned, before = score(fold_path, test), score(base, test)
            pooled += tuned.confusion
            pooled_base += before.confusion
            fold_rows.append(
                {
                    "participant": who,
                    "takes": len(test),
                    "base": summary(before),
                    "fine_tuned": summary(tuned),
                }
            )
            say(
                0.05 + 0.9 * (k + 1) / n_runs,
                f"fold {who}: accuracy {_f(before.accuracy)} -> {_f(tuned.accuracy)}",
            )
    all_items = [it for t in takes for it in by_take[t.uid]] + sim
    model, metrics = finetune(base, all_items, config, say, (0.05 + 0.9 * len(folds) / n_runs, 0.95))
    trained = time.strftime("%Y-%m-%d %H:%M:%S")
    export(
        model,
        out,
        metrics["facts"],
        {"trained": trained, "base_sha256": sha256_file(base), "sources": "takes,sim", "fine_tuned": "1"},
    )
    figures: dict[str, Any] = {}
    if fold_rows:
        acc = np.trace(pooled) / max(pooled.sum(), 1)
        acc_b = np.trace(pooled_base) / max(pooled_base.sum(), 1)
        figures |= {
            "loso_accuracy": float(acc),
            "loso_base_accuracy": float(acc_b),
            "loso_confusion": pooled.tolist(),
            "loso_base_confusion": pooled_base.tolist(),
        }
    on_takes = score(out, [t.seq for t in takes])
    figures["takes_seen_in_training"] = summary(on_takes)
    if heldout:
        figures["heldout_sim"] = {
            "routines": len(heldout),
            "seed": HELDOUT_SEED,
            "base": summary(score(base, heldout)),
            "fine_tuned": summary(score(out, heldout)),
        }
    sources = heldout_sources(sources_cache) if sources_cache is not None else {}
    if sources:
        say(0.97, f"scoring base and fine-tuned on {len(sources)} held-out sources")
    figures["heldout_sources"] = {}
    for name, seqs in sources.items():
        before, after = score(base, seqs), score(out, seqs)
        figures["heldout_sources"][name] = {
            "clips": len(seqs),
            "base": summary(before),
            "fine_tuned": summary(after),
        }
    total_s = time.monotonic() - t0
    card = {
        "kind": "fine-tuned",
        "base": {"file": str(base), "sha256": sha256_file(base)},
        "trained": trained,
        "data": {
            "takes": [
                {
                    "uid": t.uid,
                    "participant": t.participant,
                    "frames": len(t.seq),
                    "labels": corpus.label_counts([t.seq]),
                }
                for t in takes
            ],
            "participants": participants,
            "sim_routines": config.sim_routines,
            "sim_duration_s": config.sim_duration_s,
            "training_frames": metrics["frames"],
        },
        "settings": asdict(config),
        "history": metrics["history"],
        "figures": figures,
        "folds": fold_rows,
        "times_s": {
            "prepare": round(prep_s, 2),
            "final_fine_tune": round(metrics["train_s"], 2),
            "total": round(total_s, 2),
        },
    }
    say(1.0, f"wrote {out} in {total_s:.0f} s")
    return TrainingResult(out, card, card_markdown(card))


def _confusion_md(conf: list[list[int]]) -> list[str]:
    lines = ["| truth \\ predicted | " + " | ".join(ACTIONS) + " |", "|---" * (len(ACTIONS) + 1) + "|"]
    for name, row in zip(ACTIONS, conf, strict=True):
        lines.append(f"| {name} | " + " | ".join(str(v) for v in row) + " |")
    return lines


def _f(x: Any) -> str:
    return f"{x:.3f}" if isinstance(x, float) else "—"


def card_markdown(card: dict[str, Any]) -> str:
    """The model card of a fine-tuned model, as Markdown."""
    d, f, s = card["data"], card["figures"], card["settings"]
    lines = [
        f"# Model card: fine-tuned action model ({card['trained']})",
        "",
        f"Fine-tuned from `{Path(card['base']['file']).name}` (sha256 `{card['base']['sha256'][:16]}`) by "
        "`cavewalk train` on recorded takes plus simulator data (batch norms frozen).",
        "",
        "## Data",
        "",
        "| take | participant | frames | still | forward | left | right | ignore |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for t in d["takes"]:
        c = t["labels"]
        lines.append(
            f"| {t['uid']} | {t['participant']} | {t['frames']} | {c['still']} | {c['forward']} | "
            f"{c['left']} | {c['right']} | {c['ignore']} |"
        )
    lines += [
        "",
        f"Plus {d['sim_routines']} simulated routines x {d['sim_duration_s']:g} s (stepping and still "
        f"behaviours, seed {s['seed']}), all mirrored: {d['training_frames']} training frames.",
        "",
        f"Settings: {s['epochs']} epochs x {s['windows_per_epoch']} windows (batch {s['batch_size']}), AdamW "
        f"lr {s['lr']:g} (cosine), label smoothing {s['label_smoothing']:g}, {s['threads']} torch thread(s).",
        "",
        "## Leave-one-participant-out",
        "",
    ]
    if card["folds"]:
        lines += [
            "| participant | takes | base accuracy | fine-tuned accuracy | base false movement | "
            "fine-tuned false movement |",
            "|---|---|---|---|---|---|",
        ]
        for row in card["folds"]:
            b, t = row["base"], row["fine_tuned"]
            lines.append(
                f"| {row['participant']} | {row['takes']} | {_f(b['accuracy'])} | {_f(t['accuracy'])} "
                f"| {_f(b['false_movement'])} | {_f(t['false_movement'])} |"
            )
        lines += [
            "",
            f"Pooled: accuracy {_f(f['loso_accuracy'])} (base {_f(f['loso_base_accuracy'])}).",
            "",
            "Confusion matrix (pooled held-out participants, fine-tuned):",
            "",
        ]
        lines += _confusion_md(f["loso_confusion"])
    else:
        lines.append("Not measured: it needs takes of at least two participants (or was switched off).")
    seen = f["takes_seen_in_training"]
    lines += [
        "",
        "## On the training takes (seen in training: not a held-out figure)",
        "",
        f"Accuracy {_f(seen['accuracy'])}, macro-F1 {_f(seen['macro_f1'])}, {seen['frames']} frames.",
        "",
    ]
    lines += _confusion_md(seen["confusion"])
    if "heldout_sim" in f:
        h = f["heldout_sim"]
        lines += [
            "",
            f"## Held-out simulated routines ({h['routines']}, seed {h['seed']})",
            "",
            "| model | accuracy | macro-F1 | false movement |",
            "|---|---|---|---|",
            f"| base | {_f(h['base']['accuracy'])} | {_f(h['base']['macro_f1'])} | "
            f"{_f(h['base']['false_movement'])} |",
            f"| fine-tuned | {_f(h['fine_tuned']['accuracy'])} | {_f(h['fine_tuned']['macro_f1'])} | "
            f"{_f(h['fine_tuned']['false_movement'])} |",
        ]
    lines += ["", "## The recognition issue's held-out sources (as `cavewalk evaluate` reads them)", ""]
    if f.get("heldout_sources"):
        lines += [
            "| source | clips | base accuracy | fine-tuned accuracy | base false movement | "
            "fine-tuned false movement | base false starts | fine-tuned false starts | base detected | "
            "fine-tuned detected |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for name, h in f["heldout_sources"].items():
            b, t = h["base"], h["fine_tuned"]
            lines.append(
                f"| {name} | {h['clips']} | {_f(b['accuracy'])} | {_f(t['accuracy'])} "
                f"| {_f(b['false_movement'])} | {_f(t['false_movement'])} "
                f"| {_f(b['false_starts'])} | {_f(t['false_starts'])} "
                f"| {_f(b['movement_detected'])} | {_f(t['movement_detected'])} |"
            )
    else:
        lines.append("Not measured: no held-out sources here (`cavewalk data sources` makes them).")
    ts = card["times_s"]
    lines += [
        "",
        f"Time: {ts['total']:.1f} s in all ({ts['prepare']:.1f} s preparing the data, "
        f"{ts['final_fine_tune']:.1f} s the final fine-tune).",
        "",
    ]
    return "\n".join(lines)
