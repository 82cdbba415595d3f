"""blind3: a joint-angle stepping-in-place generator (a fifth motion model).

Its held-out set (seed 31337, ``blind3-heldout``) is never trained on; since the sixth motion model
(``pipeline.sim.blind4``) took its place as the one never trained on, the action model trains on
other seeds of it (``scripts/train_action.py --source blind3``).

An independent kinematic generator of labelled COCO-17 3D skeleton sequences, written from scratch
with numpy and scipy only, without the product's code, tests, docs or data, and independently of
its motion models (``pipeline.sim``, ``pipeline.sim.blind``, ``pipeline.sim.blind2``). One person
stands in a small room and steps in place to move through a VR world: marching (``forward``),
side steps, step-touches and shuffles (``left``/``right``), pauses, turns on the spot in pivot
steps, weight shifts, gestures, looking around, stretches and bows (``still``). The skeleton is a
hierarchy driven by joint angles: every event writes joint-angle key frames (PCHIP in between,
analytic lift bumps for the swing legs), the pelvis root is placed each frame by the planted feet,
and every keypoint comes from forward kinematics, so all bones keep their lengths. Every frame has
a label, a tag saying what the person does and ground-truth foot contacts; the files carry capture
noise (1.2 cm) and 2 % of joints dropped in short runs. Sequence i depends on (seed, i) only. The
default set (seed 31337, 12 files of 60 s at 30 fps) is the reference held-out set.

Modules: ``kin`` (rotations and the closed-form leg chain), ``body`` (body sampling), ``model``
(key-frame tracks, the pose solver, the per-frame root/contact simulation, upper-body forward
kinematics), ``events`` (the planners of bouts, turns and gestures), ``api`` (the observation
model, records and files) and ``check`` (the checker: ``check_folder`` tests every file of a set
against the generator). ``python -m pipeline.sim.blind3 OUT_DIR`` writes a set;
``python -m pipeline.sim.blind3.check OUT_DIR`` checks one.
"""

from pipeline.sim.blind3.api import (
    DEFAULT_COUNT,
    DEFAULT_DURATION_S,
    DEFAULT_SEED,
    FILE_KEYS,
    FPS,
    JOINTS,
    SOURCE,
    file_name,
    generate_clean,
    make_record,
    observe,
    record,
    write_set,
)
from pipeline.sim.blind3.body import Body, sample_body
from pipeline.sim.blind3.events import Generator

__all__ = [
    "DEFAULT_COUNT",
    "DEFAULT_DURATION_S",
    "DEFAULT_SEED",
    "FILE_KEYS",
    "FPS",
    "JOINTS",
    "SOURCE",
    "Body",
    "Generator",
    "file_name",
    "generate_clean",
    "make_record",
    "observe",
    "record",
    "sample_body",
    "write_set",
]
