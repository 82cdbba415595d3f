"""Capture faults: Gaussian jitter and drop-outs (whole joints, runs of 1-12 frames)."""

import numpy as np

DROP_SHARE = 0.02
NOISE_SD = 0.012


def capture(joints, seed, idx):
    T, J, _ = joints.shape
    out = joints + np.random.default_rng([seed, idx, 3]).normal(0.0, NOISE_SD, joints.shape)
    rd = np.random.default_rng([seed, idx, 4])
    w = np.ones(J)
    w[[9, 10, 15, 16]] = 3.0  # wrists and ankles drop out more often
    w /= w.sum()
    target = round(DROP_SHARE * T * J)
    mask = np.zeros((T, J), bool)
    cnt = 0
    while cnt < target:
        j = int(rd.choice(J, p=w))
        L = int(rd.integers(1, 13))
        s = int(rd.integers(0, T))
        for f in range(s, min(T, s + L)):
            if not mask[f, j]:
                mask[f, j] = True
                cnt += 1
                if cnt == target:
                    break
    out[mask] = np.nan
    return out.astype(np.float32)
