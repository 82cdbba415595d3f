"""What the triangulation stage hands on: 3D skeletons with persistent user ids."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import NUM_JOINTS


@dataclass(frozen=True, slots=True)
class Person3D:
    """One person's 3D skeleton in the CAVE frame.

    user_id: persistent id of this person (stable over time, across views).
    joints_m: (17, 3) float64 metres, NaN where unknown.
    joint_valid: (17,) bool, True where seen by at least two good views.
    reproj_px: mean reprojection error of the valid joints, pixels.
    views: (camera, track_id) pairs this person was built from.
    """

    user_id: int
    joints_m: NDArray[np.float64]
    joint_valid: NDArray[np.bool_]
    reproj_px: float
    views: tuple[tuple[str, int], ...] = ()

    def __post_init__(self) -> None:
        j = np.asarray(self.joints_m, dtype=np.float64)
        v = np.asarray(self.joint_valid, dtype=bool)
        if j.shape != (NUM_JOINTS, 3):
            raise ValueError(f"joints_m must have shape (17, 3), got {j.shape}")
        if v.shape != (NUM_JOINTS,):
            raise ValueError(f"joint_valid must have shape (17,), got {v.shape}")
        object.__setattr__(self, "joints_m", j)
        object.__setattr__(self, "joint_valid", v)

    @property
    def position_m(self) -> NDArray[np.float64]:
        """(3,) floor position: mean of the valid hips (else of all valid joints), z = 0."""
        hips = self.joints_m[[11, 12]][self.joint_valid[[11, 12]]]
        pts = hips if len(hips) else self.joints_m[self.joint_valid]
        if len(pts) == 0:
            return np.full(3, np.nan)
        p = pts.mean(axis=0)
        return np.array([p[0], p[1], 0.0])
