"""Self-check of a folder of blind6 files: python -m blind6.check OUT_DIR  (exit 1 on failure)."""

import re
import sys
from pathlib import Path

import numpy as np

from pipeline.sim.blind6.capture import capture
from pipeline.sim.blind6.kinematics import LANK, LEL, LHIP, LKNEE, LSH, LWR, RANK, REL, RHIP, RKNEE, RSH, RWR
from pipeline.sim.blind6.script import AIR_OK, LABELS, STEP_TAGS, TAGS, generate

BONES = {
    "thigh": ((LHIP, LKNEE), (RHIP, RKNEE)),
    "shank": ((LKNEE, LANK), (RKNEE, RANK)),
    "upper arm": ((LSH, LEL), (RSH, REL)),
    "forearm": ((LEL, LWR), (REL, RWR)),
    "hip width": ((LHIP, RHIP),),
    "shoulder width": ((LSH, RSH),),
}
KEYS = {
    "joints": np.float32,
    "fps": np.float64,
    "labels": np.dtype("<U7"),
    "tags": np.dtype("<U20"),
    "contacts": np.bool_,
    "source": None,
}
SLIDE_TAGS = ()  # no deliberate slides are modelled


def _runs(mask):
    """(start, stop) of True runs."""
    m = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0], strict=False))


def check_file(path, totals):
    errs = []
    m = re.fullmatch(r"blind6_(\d+)_(\d+)\.npz", path.name)
    if not m:
        return [f"unexpected file name {path.name}"]
    seed, idx = int(m.group(1)), int(m.group(2))
    z = np.load(path)
    if set(z.files) != set(KEYS):
        return [f"keys {sorted(z.files)}"]
    d = {k: z[k] for k in z.files}
    T = len(d["labels"])
    for k, dt in KEYS.items():
        if dt is not None and d[k].dtype != dt:
            errs.append(f"{k} dtype {d[k].dtype}")
    if d["joints"].shape != (T, 17, 3) or d["contacts"].shape != (T, 2) or d["tags"].shape != (T,):
        errs.append("shapes")
    if (
        d["fps"].shape != ()
        or float(d["fps"]) != 30.0
        or d["source"].shape != ()
        or str(d["source"]) != "blind6"
    ):
        errs.append("fps / source")
    if not set(np.unique(d["labels"])) <= set(LABELS):
        errs.append(f"labels vocabulary {set(np.unique(d['labels'])) - set(LABELS)}")
    if not set(np.unique(d["tags"])) <= set(TAGS):
        errs.append(f"tags vocabulary {set(np.unique(d['tags'])) - set(TAGS)}")
    if errs:
        return errs
    clean, meta = generate(seed, idx, T)
    regen = capture(clean["joints"].astype(np.float64), seed, idx)
    if not np.array_equal(regen, d["joints"], equal_nan=True):
        errs.append("joints differ from the regeneration")
    for k in ("labels", "tags", "contacts"):
        if not np.array_equal(clean[k], d[k]):
            errs.append(f"{k} differ from the regeneration")
    nan = np.isnan(d["joints"])
    if not (nan.all(-1) == nan.any(-1)).all():
        errs.append("partly-NaN joints")
    share = nan.all(-1).mean()
    if not 0.015 <= share <= 0.025:
        errs.append(f"drop-out share {share:.4f}")
    # ---- clean regeneration
    J = clean["joints"].astype(np.float64)
    con, lab, tags = clean["contacts"], clean["labels"], clean["tags"]
    body = meta["body"]
    for name, pairs in BONES.items():
        for a, b in pairs:
            L = np.linalg.norm(J[:, a] - J[:, b], axis=-1)
            if np.ptp(L) >= 1e-6:
                errs.append(f"{name} length range {np.ptp(L):.2e} m")
    for i, aj in ((0, LANK), (1, RANK)):
        for s, e in _runs(con[:, i]):
            dev = np.linalg.norm(J[s:e, aj, :2] - J[s, aj, :2], axis=-1).max()
            if dev >= 0.01 and not np.isin(tags[s:e], SLIDE_TAGS).all():
                errs.append(f"foot {i} slides {dev * 100:.1f} cm in contact run {s}-{e}")
                break
    low = J[:, [LANK, RANK], 2].min()
    if low < body.ankle_h - 0.001:
        errs.append(f"ankle {1000 * (body.ankle_h - low):.1f} mm below standing height")
    ds = con.all(1)
    present = set()
    bouts = [(s, e) for s, e in _runs(lab != "still")]
    for s, e in bouts:  # e exclusive
        if len(set(lab[s:e])) != 1:
            errs.append(f"mixed labels in bout {s}-{e}")
        present.add(str(lab[s]))
        if ds[s] or (s > 0 and not ds[s - 1]):
            errs.append(f"bout {s} does not start at a lift-off")
        if not ds[e - 1] or ds[e - 2]:
            errs.append(f"bout ending {e - 1} is not a touch-down")
        runs = [r for r in _runs(ds[s:e])]
        if runs and max(b - a for a, b in runs) > 30:
            errs.append(f"double support > 1 s in bout {s}-{e}")
        if not np.isin(tags[s:e], STEP_TAGS).all():
            errs.append(f"non-stepping tag inside bout {s}-{e}")
        totals["bouts"][str(lab[s])] = totals["bouts"].get(str(lab[s]), 0) + 1
    still = lab == "still"
    air = still & ~ds
    if not np.isin(tags[air], AIR_OK).all():
        bad = sorted(set(tags[air]) - set(AIR_OK))
        errs.append(f"foot in the air in still frames tagged {bad}")
    if np.isin(tags[still], STEP_TAGS).any():
        errs.append("stepping tag on a still frame")
    if T >= 300 and present != {"forward", "left", "right"}:
        errs.append(f"commands present: {sorted(present)}")
    rad = np.linalg.norm(J[:, :, :2], axis=-1).max()
    if rad > 0.75:
        errs.append(f"a joint is {rad:.3f} m from the centre")
    for name in LABELS:
        totals["frames"][name] = totals["frames"].get(name, 0) + int((lab == name).sum())
    for t in np.unique(tags):
        totals["tags"][str(t)] = totals["tags"].get(str(t), 0) + int((tags == t).sum())
    return errs


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("error: usage: python -m pipeline.sim.blind6.check OUT_DIR", file=sys.stderr)
        return 2
    files = sorted(Path(argv[0]).glob("*.npz"))
    if not files:
        print(f"error: no .npz files in {argv[0]}", file=sys.stderr)
        return 2
    totals = {"frames": {}, "bouts": {}, "tags": {}}
    bad = 0
    for p in files:
        errs = check_file(p, totals)
        print(f"{p.name}: {'ok' if not errs else 'FAIL'}")
        for e in errs[:20]:
            print(f"    {e}")
        bad += bool(errs)
    print("frames per label:", totals["frames"])
    print("bouts per label:", totals["bouts"])
    print("frames per tag:", {('""' if k == "" else k): v for k, v in sorted(totals["tags"].items())})
    print(f"{len(files) - bad}/{len(files)} files pass")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
