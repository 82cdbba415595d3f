"""Self-check: python -m blind7.check OUT_DIR  (exit 0 ok, 1 failure, 2 no files)."""

import re
import sys
from pathlib import Path

import numpy as np

from pipeline.sim.blind7 import JOINT_NAMES, LABELS, TAGS, make_record

KEYS = {"joints", "fps", "labels", "tags", "contacts", "source"}
J = {n: i for i, n in enumerate(JOINT_NAMES)}
BONES = {
    "thigh": ("hip", "knee"),
    "shank": ("knee", "ankle"),
    "upper_arm": ("shoulder", "elbow"),
    "forearm": ("elbow", "wrist"),
}


def runs(mask):
    """(start, end_exclusive) of True runs."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=False))


def check_file(path):
    errs = []
    m = re.fullmatch(r"blind7_(\d+)_(\d+)\.npz", path.name)
    if not m:
        return [f"bad file name {path.name}"]
    seed, idx = int(m.group(1)), int(m.group(2))
    with np.load(path, allow_pickle=False) as z:
        d = {k: z[k] for k in z.files}
    if set(d) != KEYS:
        return [f"keys {sorted(d)} != {sorted(KEYS)}"]
    jt = d["joints"]
    T = jt.shape[0] if jt.ndim == 3 else -1
    spec = {
        "joints": (np.float32, (T, 17, 3)),
        "fps": (np.float64, ()),
        "labels": (np.dtype("<U7"), (T,)),
        "tags": (np.dtype("<U20"), (T,)),
        "contacts": (np.bool_, (T, 2)),
    }
    for k, (dt, sh) in spec.items():
        if d[k].dtype != dt or d[k].shape != sh:
            errs.append(f"{k}: dtype/shape {d[k].dtype}{d[k].shape}, want {np.dtype(dt)}{sh}")
    if d["source"].shape != () or d["source"].dtype.kind != "U" or str(d["source"]) != "blind7":
        errs.append("source must be 0-d str 'blind7'")
    if errs:
        return errs
    if float(d["fps"]) != 30.0:
        errs.append("fps != 30")
    if not set(np.unique(d["labels"])) <= set(LABELS):
        errs.append(f"labels vocabulary {np.unique(d['labels'])}")
    if not set(np.unique(d["tags"])) <= set(TAGS):
        errs.append(f"tags vocabulary {np.unique(d['tags'])}")
    rec = make_record(seed, idx, T, clean=True)
    for k in KEYS:
        a, b = d[k], np.asarray(rec[k])
        same = np.array_equal(a, b, equal_nan=True) if a.dtype.kind == "f" else np.array_equal(a, b)
        if not same or a.dtype != b.dtype:
            errs.append(f"{k} differs from its regeneration")
    drop = np.isnan(jt).any(-1).mean()
    if not 0.015 <= drop <= 0.025:
        errs.append(f"drop-out share {drop:.4f} outside 1.5-2.5 %")
    if np.isnan(jt).any(-1).sum() * 3 != np.isnan(jt).sum():
        errs.append("NaN must cover whole joints")
    C = rec["joints_clean"]
    P = rec["person"]
    # bone lengths
    for name, (a, b) in BONES.items():
        for s in ("left", "right"):
            L = np.linalg.norm(C[:, J[f"{s}_{a}"]] - C[:, J[f"{s}_{b}"]], axis=1)
            if L.max() - L.min() > 1e-5:
                errs.append(f"{s} {name} length varies by {L.max() - L.min():.2e} m")
    for name, (a, b) in {
        "hip_width": ("left_hip", "right_hip"),
        "shoulder_width": ("left_shoulder", "right_shoulder"),
    }.items():
        L = np.linalg.norm(C[:, J[a]] - C[:, J[b]], axis=1)
        if L.max() - L.min() > 1e-5:
            errs.append(f"{name} varies by {L.max() - L.min():.2e} m")
    con = d["contacts"]
    tiptoe = d["tags"] == "tiptoe"
    for i, s in enumerate(("left", "right")):
        A = C[:, J[f"{s}_ankle"]]
        for a, b in runs(con[:, i]):
            seg = A[a:b]
            hor = np.linalg.norm(seg[:, :2] - seg[0, :2], axis=1).max()
            if hor >= 0.01:
                errs.append(f"{s} ankle slides {hor:.3f} m in contact run {a}-{b}")
            flat = ~tiptoe[a:b]
            if flat.any():
                ref = seg[flat][0]
                mv = np.linalg.norm(seg[flat] - ref, axis=1).max()
                if mv >= 0.01:
                    errs.append(f"{s} planted ankle moves {mv:.3f} m in contact run {a}-{b}")
        if A[:, 2].min() < P["ha"] - 0.001:
            errs.append(f"{s} ankle below standing height by {P['ha'] - A[:, 2].min():.4f} m")
    lab = d["labels"]
    moving = lab != "still"
    for a, b in runs(moving):
        seg_labels = set(lab[a:b])
        if len(seg_labels) != 1:
            # adjacent bouts of different direction must still start/end properly
            pass
        lift = a > 0 and any(con[a - 1, i] and not con[a, i] for i in (0, 1))
        td = any((not con[b - 2, i]) and con[b - 1, i] for i in (0, 1)) if b >= 2 else False
        if not lift:
            errs.append(f"bout at {a} does not start at a lift-off")
        if not td:
            errs.append(f"bout ending at {b - 1} does not end at a touch-down")
    if T >= 300:
        missing = {"forward", "left", "right"} - set(np.unique(lab))
        if missing:
            errs.append(f"moving labels missing: {sorted(missing)}")
    r = np.linalg.norm(C[:, :, :2], axis=-1).max()
    if r > 0.75:
        errs.append(f"a joint is {r:.3f} m from the room centre (> 0.75)")
    return errs


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("error: usage: python -m pipeline.sim.blind7.check OUT_DIR", file=sys.stderr)
        return 2
    folder = Path(argv[0])
    files = sorted(folder.glob("blind7_*.npz")) if folder.is_dir() else []
    if not files:
        print(f"error: no blind7_*.npz files in {folder}", file=sys.stderr)
        return 2
    bad = 0
    for f in files:
        errs = check_file(f)
        if errs:
            bad += 1
            print(
                f"FAIL {f.name}: "
                + "; ".join(errs[:8])
                + (f" (+{len(errs) - 8} more)" if len(errs) > 8 else "")
            )
        else:
            print(f"ok   {f.name}")
    print(f"{len(files) - bad}/{len(files)} files pass")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
