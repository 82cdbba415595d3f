"""A third motion generator, written blind to the project's other two.

It writes SPEC skeleton NPZ files of people stepping in place in a CAVE (marching, side steps) and
doing other things while standing (gestures, looking around, turning in pivot steps, weight shifts,
a bow, a squat, a stretch), with per-frame labels, behaviour tags and ground-truth foot contacts.
Its held-out set (seed 4242, ``blind-heldout``) is never trained on; since 2026-12-05 the action
model trains on other seeds of it (``scripts/train_action.py --source blind``,
:func:`pipeline.recognition.corpus.independent_model`). See ``activities`` (what people do),
``script`` (the ground truth and the label rules), ``kinematics`` (how the body moves) and
``generate`` (sets, noise, files);
``python -m pipeline.sim.blind OUT_DIR`` writes a set.
"""

from pipeline.sim.blind.body import Body, Style, sample_body, sample_style
from pipeline.sim.blind.generate import (
    DEFAULT_SEED,
    Generated,
    NoiseConfig,
    SequenceConfig,
    generate_sequence,
    generate_set,
    write_set,
)

__all__ = [
    "DEFAULT_SEED",
    "Body",
    "Generated",
    "NoiseConfig",
    "SequenceConfig",
    "Style",
    "generate_sequence",
    "generate_set",
    "sample_body",
    "sample_style",
    "write_set",
]
