"""Body size / proportion / posture sampling."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.sim.blind3.kin import D2R

H_MIN, H_MAX = 1.48, 1.98
STRATA = 12  # heights are stratified over blocks of 12 sequences


@dataclass
class Body:
    """One person: size, proportions and habitual posture (lengths in m, angles in rad)."""

    H: float  # standing height (m)
    ankle_h: float  # ankle joint height above the floor with the foot flat
    L1: float  # thigh (hip-knee)
    L2: float  # shank (knee-ankle)
    hw: float  # half distance between the hip keypoints
    s1: float  # lumbar segment (pelvis root -> mid spine)
    s2: float  # thoracic segment (mid spine -> neck base)
    neck: float  # neck base -> head pivot
    sw: float  # half distance between the shoulder keypoints
    sh_dy: float  # shoulder offset from neck base (forward)
    sh_dz: float  # shoulder offset from neck base (up)
    Lu: float  # upper arm
    Lf: float  # forearm (elbow-wrist)
    head: np.ndarray  # (5,3) nose, l_eye, r_eye, l_ear, r_ear in the head frame
    neck_dy: float
    ball_r: float  # ankle -> ball of foot distance (heel-raise pivot)
    ball_a: float  # elevation angle of the ankle seen from the ball of the foot
    knee0: float  # habitual standing knee flexion (rad)
    half_stance: float  # half ankle-to-ankle distance in the habitual stance
    toe_out: tuple[float, float]  # habitual toe-out (rad) left, right
    lumbar0: float
    thoracic0: float
    tilt0: float
    neck_pitch0: float
    head_roll0: float
    p_controllers: float  # how often this person holds the VR controllers up in front
    handed: int  # 1 right-handed, 0 left-handed


def height_for(seed: int, idx: int, rng: np.random.Generator) -> float:
    """Standing height of sequence idx: stratified over blocks of 12 sequences of one seed."""
    perm = np.random.default_rng([seed, 999]).permutation(STRATA)
    k = perm[idx % STRATA]
    return H_MIN + (H_MAX - H_MIN) * (k + rng.uniform(0.05, 0.95)) / STRATA


def sample_body(rng: np.random.Generator, H: float) -> Body:
    """A person of height H with random proportions and posture."""

    def f(sd: float) -> float:
        return float(np.clip(rng.normal(1.0, sd), 1.0 - 2.5 * sd, 1.0 + 2.5 * sd))

    ankle_h = float(np.clip(0.045 * H * f(0.05), 0.06, 0.10))
    legk = f(0.03)  # long- vs short-legged
    L1 = 0.245 * H * legk * f(0.02)
    L2 = 0.246 * H * legk * f(0.02)
    hw = 0.056 * H * f(0.07)
    neck = 0.062 * H * f(0.06)
    pivot = 0.905 * H
    trunk = pivot - ankle_h - L1 - L2 - neck
    s1 = trunk * 0.40 * f(0.04)
    s2 = trunk - s1
    sw = 0.106 * H * f(0.06)
    hk = H * f(0.04)
    head = (
        np.array(
            [
                [0.0, 0.060, 0.010],
                [-0.018, 0.047, 0.026],
                [0.018, 0.047, 0.026],
                [-0.043, -0.003, 0.016],
                [0.043, -0.003, 0.016],
            ]
        )
        * hk
    )
    sep = rng.uniform(0.17, 0.31) * H / 1.75  # ankle-to-ankle distance when standing
    return Body(
        H=H,
        ankle_h=ankle_h,
        L1=L1,
        L2=L2,
        hw=hw,
        s1=s1,
        s2=s2,
        neck=neck,
        sw=sw,
        sh_dy=-0.012 * H,
        sh_dz=-0.022 * H * f(0.1),
        Lu=0.186 * H * f(0.03),
        Lf=0.146 * H * f(0.03),
        head=head,
        neck_dy=0.01 * H,
        ball_r=0.075 * H * f(0.05),
        ball_a=30 * D2R * f(0.08),
        knee0=rng.uniform(2.5, 10.0) * D2R,
        half_stance=sep / 2.0,
        toe_out=(rng.uniform(0, 12) * D2R, rng.uniform(0, 12) * D2R),
        lumbar0=rng.uniform(-2, 4) * D2R,
        thoracic0=rng.uniform(0, 6) * D2R,
        tilt0=rng.uniform(0, 6) * D2R,
        neck_pitch0=rng.uniform(-6, 6) * D2R,
        head_roll0=rng.uniform(-3, 3) * D2R,
        p_controllers=float(rng.uniform(0.0, 1.0)),
        handed=int(rng.random() < 0.85),
    )
