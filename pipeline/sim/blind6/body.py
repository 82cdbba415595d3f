"""Body proportions and personal motion style."""

from dataclasses import dataclass

import numpy as np


@dataclass
class Body:
    height: float
    ankle_h: float  # ankle joint height above the floor, foot flat
    thigh: float
    shank: float
    hip_w: float  # distance between the hip joints
    sh_w: float  # distance between the shoulder joints
    trunk: float  # pelvis centre (hip level) -> neck base
    sh_drop: float  # shoulder joints below the neck base
    neck: float  # neck base -> head centre
    upper: float
    fore: float
    stance: float  # lateral distance between the ankles when standing
    toe_out: float  # knee pole splay (rad)
    face: np.ndarray  # (5, 3) nose, eyes, ears in the head frame

    @property
    def leg(self):
        return self.thigh + self.shank

    @property
    def pel_z0(self):
        lat = 0.5 * (self.stance - self.hip_w)
        return self.ankle_h + np.sqrt((0.99 * self.leg) ** 2 - lat**2)


@dataclass
class Style:
    cadence: float  # preferred steps / s
    lift: float  # preferred ankle apex when marching (m)
    kfwd: float  # forward (knee-up) or backward (heel-kick) swing component
    arm: float  # arm swing amplitude (rad), 0 = no swing
    elbow: float
    sway: float  # lateral pelvis sway (m)
    roll: float
    bob: float
    asym: float  # left/right lift ratio
    sf: float  # swing fraction of a leg cycle
    gamma: float  # swing apex timing
    jitter: float  # relative timing jitter of the rhythm
    pause_p: float  # chance of a pause after a touch-down (in pausing bouts)
    side_w: float  # preferred side-step width (m)
    side_lift: float
    fidget: float
    sa_rest: float
    el_rest: float


def sample_body(rng):
    H = rng.uniform(1.40, 2.05)
    ah = H * rng.uniform(0.040, 0.050)
    legf = rng.uniform(0.455, 0.515)
    ts = rng.uniform(0.48, 0.53)
    thigh, shank = H * legf * ts, H * legf * (1 - ts)
    hip_w = H * rng.uniform(0.085, 0.12)
    neck_base = H * rng.uniform(0.83, 0.845)
    trunk = neck_base - (ah + 0.99 * (thigh + shank))
    f = np.array(
        [
            [0.0, 0.055, -0.012],
            [-0.017, 0.047, 0.008],
            [0.017, 0.047, 0.008],
            [-0.040, 0.0, 0.0],
            [0.040, 0.0, 0.0],
        ]
    )
    f *= H * rng.uniform(0.93, 1.07, 3)
    return Body(
        height=H,
        ankle_h=ah,
        thigh=thigh,
        shank=shank,
        hip_w=hip_w,
        sh_w=H * rng.uniform(0.195, 0.245),
        trunk=trunk,
        sh_drop=H * rng.uniform(0.015, 0.03),
        neck=H * rng.uniform(0.085, 0.10),
        upper=H * 0.186 * rng.uniform(0.93, 1.07),
        fore=H * 0.146 * rng.uniform(0.93, 1.07),
        stance=hip_w * rng.uniform(0.9, 1.6),
        toe_out=rng.uniform(0.0, 0.3),
        face=f,
    )


def sample_style(rng):
    return Style(
        cadence=rng.uniform(0.6, 2.3),
        lift=float(np.exp(rng.uniform(np.log(0.04), np.log(0.26)))),
        kfwd=rng.uniform(-0.3, 0.6),
        arm=0.0 if rng.random() < 0.25 else rng.uniform(0.1, 0.6),
        elbow=rng.uniform(0.1, 0.6),
        sway=rng.uniform(0.005, 0.04),
        roll=rng.uniform(0.0, 0.06),
        bob=rng.uniform(0.0, 0.015),
        asym=rng.uniform(0.8, 1.25),
        sf=rng.uniform(0.33, 0.45),
        gamma=rng.uniform(0.8, 1.25),
        jitter=rng.uniform(0.02, 0.12),
        pause_p=0.0 if rng.random() < 0.4 else rng.uniform(0.1, 0.4),
        side_w=rng.uniform(0.12, 0.38),
        side_lift=rng.uniform(0.02, 0.10),
        fidget=rng.uniform(0.3, 1.0),
        sa_rest=rng.uniform(0.05, 0.15),
        el_rest=rng.uniform(0.1, 0.35),
    )
