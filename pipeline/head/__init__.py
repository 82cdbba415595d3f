"""Head pose for the walls (issue 20 item 3): each navigator's head position and forward/up
vectors from the 3D skeleton, with short-horizon prediction to make up for the latency.

- :mod:`pipeline.head.config`: :class:`HeadConfig`, the settings' ``[head]`` section.
- :mod:`pipeline.head.pose`: the pure geometry: a rigid face template fitted to the face
  keypoints (:func:`head_pose_from_joints`), rotation helpers, angle errors.
- :mod:`pipeline.head.tracker`: :class:`HeadTracker`, per-user filtering and velocities, and
  :meth:`HeadEstimate.predict`, the constant-velocity extrapolation.

Import from those modules: this package imports nothing, so that the settings can read
:class:`HeadConfig` without loading the tracker's scipy.
"""
