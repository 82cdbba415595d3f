"""Capture model: per-coordinate Gaussian noise and whole-joint drop-out runs."""

import numpy as np

S_NOISE, S_DROP = 4, 5
NOISE_SD = 0.012
DROP_SHARE = 0.02
# extremities (wrists 9,10 and ankles 15,16) drop more often than the torso (5,6,11,12)
DROP_WEIGHT = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.5, 0.5, 1.5, 1.5, 3.0, 3.0, 0.5, 0.5, 1.5, 1.5, 3.0, 3.0])


def capture(clean, seed, idx):
    rn = np.random.default_rng([int(seed), int(idx), S_NOISE])
    rd = np.random.default_rng([int(seed), int(idx), S_DROP])
    T = clean.shape[0]
    out = clean + rn.normal(0.0, NOISE_SD, size=clean.shape)
    mask = np.zeros((T, 17), dtype=bool)
    target = round(DROP_SHARE * T * 17)
    p = DROP_WEIGHT / DROP_WEIGHT.sum()
    while mask.sum() < target:
        j = rd.choice(17, p=p)
        ln = int(rd.integers(1, 13))
        s = int(rd.integers(0, T))
        ln = min(ln, target - int(mask.sum()) + int(mask[s : s + ln, j].sum()))
        mask[s : s + ln, j] = True
    out[mask] = np.nan
    return out.astype(np.float32)
