"""python -m pipeline.sim.blind5.check OUT_DIR : self-check of every blind5_*.npz in OUT_DIR."""

import itertools
import re
import sys
from collections import Counter
from pathlib import Path

import numpy as np

from pipeline.sim.blind5 import make_record
from pipeline.sim.blind5.script import generate

KEYS = {"joints", "fps", "labels", "tags", "contacts", "source"}
LABELS = {"still", "forward", "left", "right"}
TAGS = {
    "",
    "march",
    "side-step-out-back",
    "step-together",
    "step-touch",
    "shuffle",
    "pause",
    "turn",
    "weight-shift",
    "sway",
    "gesture",
    "look-around",
    "stretch",
    "bow",
    "crouch",
    "tiptoe",
    "idle",
}
BOUT_TAGS = {
    "forward": {"march", "pause"},
    "left": {"side-step-out-back", "step-together", "step-touch", "shuffle", "pause"},
}
BOUT_TAGS["right"] = BOUT_TAGS["left"]
BONES = [
    (5, 7),
    (7, 9),
    (6, 8),
    (8, 10),
    (11, 13),
    (13, 15),
    (12, 14),
    (14, 16),
    (5, 6),
    (11, 12),
    (0, 1),
    (0, 2),
    (1, 3),
    (2, 4),
    (3, 4),
    (1, 2),
]
FPS = 30.0


def runs(mask):
    """(start, end_exclusive) of True runs."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=False))


def check_file(path):
    errs = []
    m = re.fullmatch(r"blind5_(\d+)_(\d+)\.npz", path.name)
    if not m:
        return [f"bad file name {path.name}"], None
    seed, idx = int(m.group(1)), int(m.group(2))
    z = np.load(path)
    if set(z.files) != KEYS:
        return [f"keys {sorted(z.files)}"], None
    J, lab, tag, con = z["joints"], z["labels"], z["tags"], z["contacts"]
    T = J.shape[0]
    if J.dtype != np.float32 or J.shape != (T, 17, 3):
        errs.append(f"joints {J.dtype} {J.shape}")
    if z["fps"].dtype != np.float64 or z["fps"].shape != () or float(z["fps"]) != FPS:
        errs.append("fps")
    if lab.dtype != np.dtype("<U7") or lab.shape != (T,):
        errs.append(f"labels {lab.dtype} {lab.shape}")
    if tag.dtype != np.dtype("<U20") or tag.shape != (T,):
        errs.append(f"tags {tag.dtype} {tag.shape}")
    if con.dtype != bool or con.shape != (T, 2):
        errs.append(f"contacts {con.dtype} {con.shape}")
    if z["source"].shape != () or z["source"].dtype.kind != "U" or str(z["source"]) != "blind5":
        errs.append("source")
    if set(lab) - LABELS or set(tag) - TAGS:
        errs.append(f"vocab {set(lab) - LABELS} {set(tag) - TAGS}")
    if errs:
        return errs, None

    # determinism: regenerating reproduces the file exactly
    rec = make_record(seed, idx, T)
    same = (
        np.array_equal(rec["labels"], lab)
        and np.array_equal(rec["tags"], tag)
        and np.array_equal(rec["contacts"], con)
        and np.array_equal(rec["joints"], J, equal_nan=True)
    )
    if not same:
        errs.append("file differs from its regeneration")
    g = generate(seed, idx, T)
    C, ah = g["joints"], g["ankle_h"]

    for a, b in BONES:
        L = np.linalg.norm(C[:, a] - C[:, b], axis=1)
        if np.ptp(L) > 1e-6:
            errs.append(f"bone {a}-{b} range {np.ptp(L):.2e}")
    ank = C[:, 15:17]
    if ank[:, :, 2].min() < ah - 1e-9:
        errs.append(f"ankle below standing height by {ah - ank[:, :, 2].min():.4f}")
    lift_ok = np.isin(tag, ["tiptoe", "weight-shift"])
    for k in range(2):
        for s, e in runs(con[:, k]):
            xy = ank[s:e, k, :2]
            if np.linalg.norm(xy - xy[0], axis=1).max() >= 0.01:
                errs.append(f"foot {k} skates in contact run {s}-{e}")
            zz = ank[s:e, k, 2]
            bad = (np.abs(zz - ah) > 1e-6) & ~lift_ok[s:e]
            if bad.any():
                errs.append(f"foot {k} planted ankle off the floor height in {s}-{e}")
    both = con.all(1)
    still = lab == "still"
    air = ~both & still & ~np.isin(tag, ["turn", "weight-shift"])
    if air.any():
        errs.append(f"{air.sum()} still frames with a foot in the air (not turn/weight-shift)")
    bouts = runs(~still)
    for s, e in bouts:
        if len(set(lab[s:e])) != 1:
            errs.append(f"mixed labels in bout {s}-{e}")
        if both[s] or (s > 0 and not both[s - 1]):
            errs.append(f"bout {s}-{e} does not start at a lift-off")
        if not both[e - 1] or both[e - 2]:
            errs.append(f"bout {s}-{e} does not end at a touch-down")
        for a, b in runs(both[s : e - 1]):
            if b - a > FPS:
                errs.append(f"double-support gap {b - a} frames in bout {s}-{e}")
        if set(tag[s:e]) - BOUT_TAGS[lab[s]]:
            errs.append(f"bout {s}-{e} tags {set(tag[s:e])}")
    for (_s0, e0), (s1, _e1) in itertools.pairwise(bouts):
        if s1 - e0 < 1.5 * FPS:
            errs.append(f"still gap {s1 - e0} frames between bouts")
    if not {"forward", "left", "right"} <= set(lab):
        errs.append("not all three commands present")
    nan = np.isnan(J)
    if not np.array_equal(nan.any(2), nan.all(2)):
        errs.append("partial-joint NaN")
    share = nan.any(2).mean()
    if not 0.015 <= share <= 0.025:
        errs.append(f"drop-out share {share:.4f}")
    pos = C[:, [11, 12, 15, 16], :2]
    if np.linalg.norm(pos, axis=2).max() > 0.75:
        errs.append(f"left the 0.75 m area ({np.linalg.norm(pos, axis=2).max():.3f})")
    return errs, (lab, tag)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("error: usage: python -m pipeline.sim.blind5.check OUT_DIR", file=sys.stderr)
        return 2
    files = sorted(Path(argv[0]).glob("blind5_*.npz"))
    if not files:
        print(f"error: no blind5_*.npz in {argv[0]}", file=sys.stderr)
        return 2
    nfail, lc, tc, nb = 0, Counter(), Counter(), Counter()
    for f in files:
        errs, lt = check_file(f)
        print(f"{f.name}: {'OK' if not errs else 'FAIL'}")
        for e in errs[:20]:
            print(f"    {e}")
        nfail += bool(errs)
        if lt:
            lc.update(lt[0].tolist())
            tc.update(lt[1].tolist())
            for s, _e in runs(lt[0] != "still"):
                nb[str(lt[0][s])] += 1
    tot = sum(lc.values())
    print("labels (frames):", ", ".join(f"{k}={v} ({100 * v / tot:.1f}%)" for k, v in sorted(lc.items())))
    print("bouts:", dict(sorted(nb.items())))
    print("tags (frames):", dict(sorted(tc.items())))
    print(f"{len(files) - nfail}/{len(files)} files pass")
    return 1 if nfail else 0


if __name__ == "__main__":
    sys.exit(main())
