"""blind2: synthetic CAVE stepping data from a fourth motion model; its held-out set is never trained on.

An independent generator of labelled COCO-17 3D skeleton sequences, written from first principles
without the product's code, tests, docs or data, and independently of its motion models
(``pipeline.sim``, ``pipeline.sim.blind``). One person stands in a CAVE and marches in place,
side-steps, pauses, makes gestures and turns on the spot; every frame is labelled ``still``,
``forward``, ``left`` or ``right``, tagged with what the person does, and has ground-truth foot
contacts. The default set (seed 2026, 12 files of 60 s at 30 fps) is the ``blind2-heldout``
source (evaluation only); since 2026-12-05 the action model trains on other seeds of it
(``scripts/train_action.py --source blind2``).

Modules: ``body`` (the person), ``feet`` (foot events and ankle paths), ``stepping`` (marching and
side-step bouts), ``behaviours`` (still behaviours and turns), ``script`` (the plan and the label
rule), ``truth`` (the vocabularies and records), ``channels`` (posture channels), ``motion`` (the
whole body), ``generate`` (noise, sets, files), ``profiles`` and ``geometry`` (the math).
``python -m pipeline.sim.blind2 OUT_DIR`` writes a set.
"""

from pipeline.sim.blind2.body import Body, sample_body
from pipeline.sim.blind2.generate import (
    DEFAULT_COUNT,
    DEFAULT_SEED,
    SOURCE,
    Generated,
    SetConfig,
    generate_sequence,
    generate_set,
    save_set,
    write_set,
)
from pipeline.sim.blind2.motion import Motion
from pipeline.sim.blind2.script import StepCounts
from pipeline.sim.blind2.truth import LABELS, TAGS, Behaviour, Bout, Turn

__all__ = [
    "DEFAULT_COUNT",
    "DEFAULT_SEED",
    "LABELS",
    "SOURCE",
    "TAGS",
    "Behaviour",
    "Body",
    "Bout",
    "Generated",
    "Motion",
    "SetConfig",
    "StepCounts",
    "Turn",
    "generate_sequence",
    "generate_set",
    "sample_body",
    "save_set",
    "write_set",
]
