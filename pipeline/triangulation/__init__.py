"""triangulation stage: tracked 2D views -> 3D skeletons with persistent user ids, and the navigator.

- ``dlt``: pure math: weighted DLT on undistorted points, leave-one-out outlier-view rejection,
  Gauss-Newton refinement, ``reprojection_error`` (vectorised over joints and people).
- ``association``: which 2D person in each view is the same physical person (epipolar distances,
  average-linkage clustering, memory of (camera, track_id) -> user_id).
- ``tracks3d``: persistent user ids through short occlusions, One-Euro smoothing, bone-length priors.
- ``navigator``: ``NavigatorSelector`` (manual by user id, or auto: nearest the CAVE centre).
- ``reconstructor``: ``Reconstructor(cameras, ReconstructionConfig).update(views, t) -> list[Person3D]``.
- ``config``: the frozen configs (the settings' ``[triangulation]``, ``[association]``,
  ``[tracks3d]`` and ``[navigator]`` sections).
"""
