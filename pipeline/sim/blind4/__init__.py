"""blind4: an inverted-pendulum stepping-in-place generator. Held-out evaluation data only: never train on it.

A sixth motion model, written by a helper from a description of the task only, without reading the
product's code, tests, docs or data, and independently of the other motion models (``pipeline.sim``,
``pipeline.sim.blind``, ``blind2``, ``blind3``); numpy and scipy only. It writes labelled COCO-17 3D
skeletons at 30 fps of one person stepping in place in a small room: marching (``forward``), side
steps out and back, step-togethers and shuffles (``left``/``right``), and, labelled ``still``, turns
on the spot in pivot steps, weight shifts, sways, gestures, looks, stretches, bows, idle poses and
plain standing. It is dynamics-driven: a footstep planner emits swings; the feet follow
minimum-jerk swings with heel-off and toe landing; the centre of mass is the bounded solution of a
linear inverted pendulum over a ZMP reference between the loaded feet, which places the pelvis;
analytic two-link IK places the knees; the arms are damped pendulums driven by the shoulders'
accelerations. Every bone keeps its length. Every frame has a label, a tag saying what the person
does and ground-truth foot contacts; the files carry capture noise (1.2 cm per coordinate) and 2 %
of the joints dropped in runs of 1-12 frames. Sequence i depends on (seed, i) and the duration only.
The default set (seed 60606, 12 files of 60 s) is the reference held-out set; README.md beside this
file describes the model, the file format and the label convention.

Modules: ``body`` (body sampling), ``records`` (plan records), ``plan`` and ``still`` (the
footstep planner and the still behaviours), ``feet`` (foot trajectories), ``com`` (the inverted
pendulum and the pelvis), ``legs`` (two-link IK), ``upper`` (trunk, head, arms and gestures),
``capture`` (noise and drop-outs), ``mathutil`` (profiles, filters, rotations), ``sequence`` (one
sequence, its file and a set) and ``check`` (regenerates every file of a set and checks it).
``python -m pipeline.sim.blind4 OUT_DIR`` writes a set; ``python -m pipeline.sim.blind4.check
OUT_DIR`` checks one.
"""

from pipeline.sim.blind4.body import Body, sample_body
from pipeline.sim.blind4.mathutil import FPS
from pipeline.sim.blind4.sequence import (
    DEFAULT_COUNT,
    DEFAULT_DURATION_S,
    DEFAULT_SEED,
    FILE_KEYS,
    SOURCE,
    CleanSequence,
    file_name,
    generate,
    generate_clean,
    write_set,
)

__all__ = [
    "DEFAULT_COUNT",
    "DEFAULT_DURATION_S",
    "DEFAULT_SEED",
    "FILE_KEYS",
    "FPS",
    "SOURCE",
    "Body",
    "CleanSequence",
    "file_name",
    "generate",
    "generate_clean",
    "sample_body",
    "write_set",
]
