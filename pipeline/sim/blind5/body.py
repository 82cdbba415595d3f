"""Body sampling, rotation helpers and two-bone leg IK."""

from dataclasses import dataclass

import numpy as np


@dataclass
class Body:
    height: float
    ankle_h: float  # ankle joint height above the floor when standing flat
    thigh: float
    shank: float
    hip_hw: float  # half distance between hip joints
    spine1: float  # pelvis centre -> mid spine
    spine2: float  # mid spine -> neck base
    neck: float  # neck base -> head pivot
    sh_hw: float  # half shoulder width
    sh_drop: float  # shoulder joint below neck base
    upper_arm: float
    forearm: float
    face: np.ndarray  # (5,3) nose, l eye, r eye, l ear, r ear in head frame (x right, y fwd, z up)

    @property
    def pelvis_h(self):
        """Nominal standing pelvis (hip joint) height: legs almost straight."""
        return self.ankle_h + 0.995 * (self.thigh + self.shank)


def sample_body(rng):
    H = rng.uniform(1.40, 2.05)
    u = rng.uniform(-0.06, 0.06)  # leg / trunk ratio
    leg, trunk = 1.0 + 0.5 * u, 1.0 - 0.5 * u
    hipw = rng.uniform(0.85, 1.15)
    shw = rng.uniform(0.85, 1.15)
    arm = rng.uniform(0.95, 1.05, size=2)
    head = rng.uniform(0.95, 1.05)
    f = (
        np.array(
            [
                [0.0, 0.058, 0.030],
                [-0.019, 0.050, 0.046],
                [0.019, 0.050, 0.046],
                [-0.043, 0.000, 0.036],
                [0.043, 0.000, 0.036],
            ]
        )
        * H
        * head
    )
    return Body(
        height=H,
        ankle_h=0.045 * H,
        thigh=0.245 * H * leg,
        shank=0.244 * H * leg,
        hip_hw=0.056 * H * hipw,
        spine1=0.115 * H * trunk,
        spine2=0.185 * H * trunk,
        neck=0.055 * H,
        sh_hw=0.113 * H * shw,
        sh_drop=0.022 * H,
        upper_arm=0.186 * H * arm[0],
        forearm=0.150 * H * arm[1],
        face=f,
    )


def _stack(c, s, axis):
    T = len(c)
    R = np.zeros((T, 3, 3))
    a, b = [(1, 2), (2, 0), (0, 1)][axis]
    R[:, axis, axis] = 1.0
    R[:, a, a] = c
    R[:, a, b] = -s
    R[:, b, a] = s
    R[:, b, b] = c
    return R


def rot(axis, ang):
    """(T,3,3) rotation about x (0), y (1) or z (2) by ang radians (right-handed)."""
    ang = np.asarray(ang, dtype=float)
    return _stack(np.cos(ang), np.sin(ang), axis)


def apply(R, v):
    """R (T,3,3) times v (3,) or (T,3)."""
    if np.ndim(v) == 1:
        return np.einsum("tij,j->ti", R, v)
    return np.einsum("tij,tj->ti", R, v)


def two_bone_ik(hip, ank, a, b, pole):
    """Knee position for thigh a, shank b, bending towards pole (T,3)."""
    v = ank - hip
    d = np.linalg.norm(v, axis=1)
    u = v / d[:, None]
    dc = np.clip(d, abs(a - b) + 1e-9, a + b - 1e-9)
    x = (a * a - b * b + dc * dc) / (2 * dc)
    r = np.sqrt(np.maximum(a * a - x * x, 0.0))
    p = pole - np.sum(pole * u, axis=1)[:, None] * u
    p /= np.linalg.norm(p, axis=1)[:, None]
    return hip + x[:, None] * u + r[:, None] * p
