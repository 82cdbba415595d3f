"""A second motion model, written independently of :mod:`pipeline.sim.motion`.

It is driven by published joint-angle curves, not by foot trajectories: a kinematic
skeleton with anthropometric segment proportions (:mod:`.anthropometry`: Drillis & Contini
via Winter 2009, Bell et al. 1990), joint angles over time (:mod:`.curves`: Winter's
normative walking curves, Novacheck's running curves, Perry & Burnfield's pelvis; the
behaviours of :mod:`.stepping` and :mod:`.standing`), forward kinematics to the 17 COCO
joints (:mod:`.kinematics`), and the stance foot pinned to the floor with the body carried
over it (:mod:`.support`), so stepping in place does not travel unless the angles make it.

Use::

    from pipeline.sim.gait import GaitConfig, generate_routine
    seq = generate_routine(GaitConfig(duration_s=60.0, fps=30.0), seed=3)
    # seq.joints_m (T, 17, 3), seq.labels, seq.tags, seq.contacts (T, 2), seq.source == "gait"

``simulate_routine`` returns the same with the body, the angle programme and the solved
foot points (heels, balls, pins) for tests and inspection.
"""

from pipeline.sim.gait.anthropometry import Body, BodyConfig, make_body, sample_body
from pipeline.sim.gait.routine import (
    BEHAVIOURS,
    DEFAULT_MIX,
    IN_PLACE_MIX,
    IN_PLACE_SIDE_KINDS,
    MODEL_VERSION,
    SIDE_KINDS,
    SOURCE,
    GaitConfig,
    GaitTake,
    generate_routine,
    simulate_routine,
)

__all__ = [
    "BEHAVIOURS",
    "DEFAULT_MIX",
    "IN_PLACE_MIX",
    "IN_PLACE_SIDE_KINDS",
    "MODEL_VERSION",
    "SIDE_KINDS",
    "SOURCE",
    "Body",
    "BodyConfig",
    "GaitConfig",
    "GaitTake",
    "generate_routine",
    "make_body",
    "sample_body",
    "simulate_routine",
]
