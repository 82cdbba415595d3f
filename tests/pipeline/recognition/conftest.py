"""Hand-made skeletons with known geometry for the recognition tests."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from pipeline.skeleton import J

# A 1.75 m person standing at the origin facing +Y. COCO left = the person's own left,
# which for someone facing +Y is towards -X.
_POSE = {
    "nose": (0.0, 0.10, 1.62),
    "l_eye": (-0.03, 0.08, 1.65),
    "r_eye": (0.03, 0.08, 1.65),
    "l_ear": (-0.08, 0.0, 1.62),
    "r_ear": (0.08, 0.0, 1.62),
    "l_shoulder": (-0.20, 0.0, 1.43),
    "r_shoulder": (0.20, 0.0, 1.43),
    "l_elbow": (-0.24, 0.0, 1.11),
    "r_elbow": (0.24, 0.0, 1.11),
    "l_wrist": (-0.25, 0.04, 0.85),
    "r_wrist": (0.25, 0.04, 0.85),
    "l_hip": (-0.10, 0.0, 0.93),
    "r_hip": (0.10, 0.0, 0.93),
    "l_knee": (-0.10, 0.02, 0.50),
    "r_knee": (0.10, 0.02, 0.50),
    "l_ankle": (-0.10, 0.0, 0.07),
    "r_ankle": (0.10, 0.0, 0.07),
}


def standing_pose() -> NDArray[np.float64]:
    pose = np.zeros((17, 3))
    for name, xyz in _POSE.items():
        pose[J[name]] = xyz
    return pose


def rot_z(deg: float) -> NDArray[np.float64]:
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


@pytest.fixture()
def pose() -> NDArray[np.float64]:
    return standing_pose()
