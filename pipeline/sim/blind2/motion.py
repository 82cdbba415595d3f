"""The blind2 body over time: pelvis, legs, trunk, head and arms from the feet and the channels.

* Pelvis (hip midpoint), horizontally: the midpoint of the feet plus the weight-shift bias in
  double support, moved toward the stance foot by the sway gain in single support, plus postural
  sway, then Gaussian-smoothed (σ 3.5 frames) so the shift anticipates lift-off. Its height: the
  highest at which every planted leg keeps at least its desired knee flexion (never under 4°) and
  every swing leg can reach, minus a squat's drop; eroded and then smoothed, so it never exceeds
  that limit. It rolls down on the swing side; the trunk leans toward the stance foot.
* Facing: the mean of the two foot yaws (smoothed) plus a small oscillation.
* Legs: two-link IK from hip to ankle, the knee toward the mean of pelvis and foot yaw plus toe-out.
* Trunk and head: rigid links with twist, pitch and roll; head yaw, pitch and roll on top.
* Arms: forward kinematics in the trunk frame from plane of elevation, elevation, humeral
  rotation and elbow flexion; marching swings them against the legs (left arm forward while the
  right knee is up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter1d, minimum_filter1d

from pipeline.sim.blind2.body import Body
from pipeline.sim.blind2.channels import Balance, Channels
from pipeline.sim.blind2.feet import FeetMotion
from pipeline.sim.blind2.geometry import apply, rot_x, rot_y, rot_z, two_link_ik
from pipeline.sim.blind2.profiles import DEG, smooth_noise

F64 = NDArray[np.float64]
N_JOINTS = 17  # COCO-17, in the order of pipeline.skeleton.JOINT_NAMES


@dataclass(frozen=True, slots=True, eq=False)
class Motion:
    """The noise-free motion of one sequence over T frames (metres, radians, CAVE frame).

    joints_m: (T, 17, 3) COCO-17 joints. contacts: (T, 2) bool, (left, right) foot on the floor.
    feet: the ankle paths and foot yaws. pelvis_yaw_rad: (T,) facing. pelvis_m: (T, 3) hip
    midpoint. ik_residual_m: (T, 2) how far each leg falls short of its ankle (0 when reachable).
    """

    joints_m: F64
    contacts: NDArray[np.bool_]
    feet: FeetMotion
    pelvis_yaw_rad: F64
    pelvis_m: F64
    ik_residual_m: F64

    def __post_init__(self) -> None:
        n = self.joints_m.shape[0]
        if self.joints_m.shape != (n, N_JOINTS, 3) or self.contacts.shape != (n, 2):
            raise ValueError(
                f"expected joints_m (T, {N_JOINTS}, 3) and contacts (T, 2), got "
                f"{self.joints_m.shape}, {self.contacts.shape}"
            )
        if (
            self.pelvis_yaw_rad.shape != (n,)
            or self.pelvis_m.shape != (n, 3)
            or self.ik_residual_m.shape != (n, 2)
        ):
            raise ValueError(
                f"expected pelvis_yaw_rad (T,), pelvis_m (T, 3) and ik_residual_m (T, 2) for T = {n}, got "
                f"{self.pelvis_yaw_rad.shape}, {self.pelvis_m.shape}, {self.ik_residual_m.shape}"
            )


def arm_points(
    body: Body, ch: Channels, side: str, swing: F64, shoulder: F64, trunk_rot: F64
) -> tuple[F64, F64]:
    """Elbow and wrist (T, 3) of arm ``side`` (``L`` or ``R``) hanging from ``shoulder`` (T, 3).

    swing: (T,) the counter-swing signal (positive while the right foot is higher); trunk_rot:
    (T, 3, 3) the trunk's rotation.
    """
    sgn = 1 if side == "L" else -1
    al, be = ch["a" + side], ch["b" + side] + sgn * ch["armA"] * swing
    el, ps = ch["e" + side] + 0.3 * ch["armA"] * np.abs(swing), ch["r" + side]
    sa, ca, sb, cb = np.sin(al), np.cos(al), np.sin(be), np.cos(be)
    u = np.stack([-sa * sb, ca * sb, -cb], -1)
    b0 = np.stack([-sa * cb, ca * cb, sb], -1)
    bb = b0 * np.cos(ps)[:, None] + np.cross(u, b0) * np.sin(ps)[:, None]
    fd = np.cos(el)[:, None] * u + np.sin(el)[:, None] * bb
    elb = body.upper_arm_m * u
    wri = elb + body.forearm_m * fd
    if side == "R":
        elb = elb * np.array([-1, 1, 1])
        wri = wri * np.array([-1, 1, 1])
    return shoulder + apply(trunk_rot, elb), shoulder + apply(trunk_rot, wri)


def compose(body: Body, feet: FeetMotion, ch: Channels, balance: Balance, rng: np.random.Generator) -> Motion:
    """The whole body over the feet's frames (``rng`` draws the small pelvis-height jitter)."""
    P, Y, C, E = feet.ankle_m, feet.yaw, feet.contact, feet.lift_env
    T = P.shape[1]
    if ch.n_frames != T:
        raise ValueError(f"channels have {ch.n_frames} frames, the feet {T}")
    swing_ind = gaussian_filter1d((~C).astype(float), 2.0, axis=1)
    # facing
    pyaw = gaussian_filter1d(0.5 * (Y[0] + Y[1]), 2.0) + ch["pyaw"]
    # support target (xy)
    mid = 0.5 * (P[0, :, :2] + P[1, :, :2])
    tgt = mid + ch["ws"][:, None] * (P[1, :, :2] - P[0, :, :2])
    a = ch["sway"][:, None]
    only_l = C[0] & ~C[1]
    only_r = C[1] & ~C[0]
    tgt[only_l] = (P[0, :, :2] + (1 - a) * (mid - P[0, :, :2]))[only_l]
    tgt[only_r] = (P[1, :, :2] + (1 - a) * (mid - P[1, :, :2]))[only_r]
    rp_yaw = rot_z(pyaw)
    off = apply(rp_yaw, np.stack([ch["pdx"], ch["pdy"], np.zeros(T)], -1))[:, :2]
    pxy = gaussian_filter1d(tgt + off, 3.5, axis=0, mode="nearest")
    # pelvis orientation
    proll = ch["proll"] + balance.pelvis_drop_rad * (swing_ind[1] - swing_ind[0])
    rp = rp_yaw @ rot_y(proll)
    hw = body.hip_width_m / 2
    hoff = [apply(rp, np.array([-hw, 0, 0])), apply(rp, np.array([hw, 0, 0]))]
    # pelvis height: the highest z that gives every planted leg >= its desired knee flexion
    l1, l2 = body.thigh_m, body.shank_m
    lmax = (l1 + l2) * 0.9994  # about 4° of knee flexion
    zc = np.full(T, np.inf)
    for f in range(2):
        kf = np.clip(ch["kflex"], 4 * DEG, 150 * DEG)
        d_des = np.minimum(np.sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * np.cos(kf)), lmax)
        d = np.where(C[f], d_des, lmax)
        hxy = pxy + hoff[f][:, :2]
        horiz = np.linalg.norm(hxy - P[f, :, :2], axis=-1)
        d = np.where(horiz > 0.97 * d, lmax, d)
        vert = np.sqrt(np.maximum(d * d - horiz * horiz, 1e-6))
        zc = np.minimum(zc, P[f, :, 2] + vert - hoff[f][:, 2])
    zc = zc - ch["drop"] - np.abs(smooth_noise(rng, T, 20, 0.002))
    rad = 6
    pz = gaussian_filter1d(
        minimum_filter1d(zc, 2 * rad + 1, mode="nearest"), 2.0, mode="nearest", truncate=rad / 2.0
    )
    pc = np.concatenate([pxy, pz[:, None]], -1)
    hips = [pc + hoff[0], pc + hoff[1]]
    # legs
    knees, ank, res = [], [], []
    for f in range(2):
        sgn = 1 if f == 0 else -1
        ky = 0.5 * (pyaw + Y[f]) + sgn * body.toe_out_rad
        pole = np.stack([-np.sin(ky), np.cos(ky), np.zeros(T)], -1)
        k, an, rr = two_link_ik(hips[f], P[f], l1, l2, pole)
        knees.append(k)
        ank.append(an)
        res.append(rr)
    # trunk
    troll = ch["troll"] - balance.trunk_lean_rad * (swing_ind[1] - swing_ind[0])
    rt = rot_z(pyaw + ch["ttwist"]) @ rot_x(-ch["tpitch"]) @ rot_y(troll)
    sc = pc + apply(rt, np.array([0, 0, body.trunk_m]))
    sh = [
        sc + apply(rt, np.array([-body.shoulder_width_m / 2, 0, 0])),
        sc + apply(rt, np.array([body.shoulder_width_m / 2, 0, 0])),
    ]
    # head: nose, eyes, ears
    rh = rt @ rot_z(ch["hyaw"]) @ rot_x(-ch["hpitch"]) @ rot_y(ch["hroll"])
    head = [sc + apply(rh, v) for v in body.head_m]
    # arms: counter-swing from the legs' lift envelopes (left arm forward when the right knee is up)
    s = gaussian_filter1d(E[1] - E[0], 2.0)
    elbow_l, wrist_l = arm_points(body, ch, "L", s, sh[0], rt)
    elbow_r, wrist_r = arm_points(body, ch, "R", s, sh[1], rt)
    J = np.stack(
        [
            *head,
            sh[0],
            sh[1],
            elbow_l,
            elbow_r,
            wrist_l,
            wrist_r,
            hips[0],
            hips[1],
            knees[0],
            knees[1],
            ank[0],
            ank[1],
        ],
        1,
    )
    return Motion(
        joints_m=J,
        contacts=C.T.copy(),
        feet=feet,
        pelvis_yaw_rad=pyaw,
        pelvis_m=pc,
        ik_residual_m=np.stack(res, -1),
    )
