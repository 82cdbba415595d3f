"""The CAVE simulator: everything after the cameras' pose detector, without hardware.

- :mod:`pipeline.sim.body` / :mod:`pipeline.sim.script` / :mod:`pipeline.sim.motion`:
  animated users (17 COCO joints in the CAVE frame) with ground-truth action, yaw, speed.
- :mod:`pipeline.sim.scene`: the default virtual cameras (one above each wall).
- :mod:`pipeline.sim.views`: virtual cameras producing the pose detector's ``ViewDetections``
  with realistic faults.
- :mod:`pipeline.sim.world`: ``SimWorld``, a navigator plus bystanders stepping in time.
- :mod:`pipeline.sim.walls`: the walls' ArUco patterns as each camera sees them (calibration).
"""
