"""Forward kinematics of the joint hierarchy, pelvis reach clamp and leg IK pass."""

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

from pipeline.sim.blind5.body import apply, rot, two_bone_ik

REACH = 0.998  # planted legs never straighter than this fraction of thigh + shank


def _rad(x):
    return np.deg2rad(x)


def _euler(yaw, pitch, roll):
    """Body-frame rotation: yaw about up, pitch forward (+ = lean forward), roll (+ = top to the right)."""
    return rot(2, yaw) @ rot(0, -pitch) @ rot(1, roll)


def compose(tl):
    """Evaluate all layers of a Timeline and return world joints (T,17,3) in COCO order
    plus the ankle tracks (T,2,3)."""
    b, ch, n = tl.body, tl.ch, tl.T
    ank, fyaw = tl.ankle_tracks()
    heading = tl.heading_track()
    r = np.stack([np.cos(heading), np.sin(heading)], 1)
    f = np.stack([-np.sin(heading), np.cos(heading)], 1)
    P = np.zeros((n, 3))
    P[:, :2] = ank[:, :, :2].mean(1) + tl.shift_track() + ch["pel_x"][:, None] * r + ch["pel_y"][:, None] * f
    P[:, 2] = b.pelvis_h + ch["pel_z"]
    Rp = _euler(heading + _rad(ch["pel_yaw"]), _rad(ch["pel_pitch"]), _rad(ch["pel_roll"]))
    hips = np.stack(
        [P + apply(Rp, np.array([-b.hip_hw, 0.0, 0.0])), P + apply(Rp, np.array([b.hip_hw, 0.0, 0.0]))], 1
    )

    # reach clamp: lower the pelvis where a leg could not reach its (locked) ankle
    lmax = REACH * (b.thigh + b.shank)
    dh = np.linalg.norm(hips[:, :, :2] - ank[:, :, :2], axis=2)
    allowed = np.sqrt(np.maximum(lmax**2 - dh**2, 0.0))
    need = np.maximum(hips[:, :, 2] - ank[:, :, 2] - allowed, 0.0).max(1)
    smooth = gaussian_filter1d(maximum_filter1d(need, 9), 2.0)
    need = np.maximum(need, smooth)
    P[:, 2] -= need
    hips[:, :, 2] -= need[:, None]

    # two-bone IK: knees bend towards the foot's forward direction (slight toe-out)
    knees = []
    for k, side in ((0, -1.0), (1, 1.0)):
        y = fyaw[:, k] - side * 0.12
        pole = np.stack([-np.sin(y), np.cos(y), np.full(n, 0.15)], 1)
        knees.append(two_bone_ik(hips[:, k], ank[:, k], b.thigh, b.shank, pole))

    # spine chain (two segments share the spine rotation), head, arms
    Rs = _euler(_rad(ch["sp_yaw"]) / 2, _rad(ch["sp_pitch"]) / 2, _rad(ch["sp_roll"]) / 2)
    R1 = Rp @ Rs
    mid = P + apply(R1, np.array([0.0, 0.0, b.spine1]))
    R2 = R1 @ Rs
    neck = mid + apply(R2, np.array([0.0, 0.0, b.spine2]))
    Rh = R2 @ _euler(_rad(ch["hd_yaw"]), _rad(ch["hd_pitch"]), _rad(ch["hd_roll"]))
    pivot = neck + apply(R2, np.array([0.0, 0.0, b.neck]))
    face = [pivot + apply(Rh, b.face[i]) for i in range(5)]

    arms = []
    for pre, side in (("la", -1.0), ("ra", 1.0)):
        sh = neck + apply(R2, np.array([side * b.sh_hw, -0.01 * b.height, -b.sh_drop]))
        Ru = (
            R2
            @ rot(1, -side * _rad(ch[pre + "_abd"]))
            @ rot(0, _rad(ch[pre + "_flex"]))
            @ rot(2, side * _rad(ch[pre + "_twist"]))
        )
        el = sh + apply(Ru, np.array([0.0, 0.0, -b.upper_arm]))
        wr = el + apply(Ru @ rot(0, _rad(ch[pre + "_elb"])), np.array([0.0, 0.0, -b.forearm]))
        arms.append((sh, el, wr))
    (ls, le, lw), (rs, re, rw) = arms
    joints = np.stack(
        [*face, ls, rs, le, re, lw, rw, hips[:, 0], hips[:, 1], knees[0], knees[1], ank[:, 0], ank[:, 1]], 1
    )
    return joints, ank
