"""The CAVE simulator: everything after the cameras' pose detector, without hardware.

- :mod:`pipeline.sim.body`: bodies (1.40-2.05 m, varied proportions), personal motion styles,
  the kinematics that pose them.
- :mod:`pipeline.sim.script`: routines (segments of still / forward / left / right / turn with
  a behaviour each), their JSON/TOML format and :func:`~pipeline.sim.script.random_script`.
- :mod:`pipeline.sim.ranges`: what random routines draw: routine kinds, behaviours, ranges.
- :mod:`pipeline.sim.routines`: one seed -> a person doing a routine of a kind (training API).
- :mod:`pipeline.sim.motion`: ``simulate_user``: animated users (17 COCO joints in the CAVE
  frame) with ground-truth labels, tags, foot contacts, yaw and speed; planned by
  :mod:`pipeline.sim.stepping` (stepping bouts, turns), :mod:`pipeline.sim.behaviours` (the
  still library), :mod:`pipeline.sim.idle` (standing, gestures) on :mod:`pipeline.sim.feet`
  (foot moves) and :mod:`pipeline.sim.plan` (channels).
- :mod:`pipeline.sim.scene`: the default virtual cameras (one above each wall).
- :mod:`pipeline.sim.views`: virtual cameras producing the pose detector's ``ViewDetections``
  with realistic faults.
- :mod:`pipeline.sim.world`: ``SimWorld``, a navigator plus bystanders stepping in time.
- :mod:`pipeline.sim.walls`: the walls' ArUco patterns as each camera sees them (calibration).
"""
