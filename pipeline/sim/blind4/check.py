"""The blind4 checker: ``python -m pipeline.sim.blind4.check OUT_DIR`` verifies every
``blind4_<seed>_<idx>.npz`` file of a set.

The noise-free skeleton is regenerated from (seed, idx, duration) to test the format, the agreement
of labels, tags, contacts and drop-outs with the generator, bone lengths, foot contacts, the capture
noise level, the placement, the labels against the contacts and the direction of side bouts
(README.md, "Self-check"). ``check_folder`` returns every problem of a folder as a list of
``<file>: <problem>`` lines. The command exits with 0 when every file passes, 1 when one fails and 2
on a usage error (no folder, or no blind4 files in it).
"""

from __future__ import annotations

import itertools
import re
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.capture import MAX_RUN, dropout_mask
from pipeline.sim.blind4.mathutil import FPS
from pipeline.sim.blind4.sequence import FILE_KEYS, SOURCE, STREAM_DROP, generate_clean, rng_for

KEYS = set(FILE_KEYS)
LABELS = {"still", "forward", "left", "right"}
STEP_TAGS = {"march", "side-step-out-back", "step-together", "shuffle", "pause"}
STILL_TAGS = {"", "idle", "weight-shift", "turn", "gesture", "look-around", "stretch", "bow", "sway"}
BONES = [
    (5, 7),
    (7, 9),
    (6, 8),
    (8, 10),
    (11, 13),
    (13, 15),
    (12, 14),
    (14, 16),
    (11, 12),
    (5, 6),
    (0, 1),
    (0, 2),
    (1, 2),
    (3, 4),
    (0, 3),
    (0, 4),
    (1, 3),
    (2, 4),
]
NAME = re.compile(r"blind4_(\d+)_(\d+)\.npz$")


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Maximal runs [a, b) of True in a 1-D mask."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


class Checker:
    """Collects failures for one file."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.errors: list[str] = []

    def expect(self, cond: bool, msg: str) -> None:
        if not cond:
            self.errors.append(msg)


def check_file(path: Path) -> tuple[list[str], Counter[str], dict[str, float]]:
    """Return (errors, label frame counts, stats) for one file."""
    ck = Checker(path.name)
    stats: dict[str, float] = {}
    m = NAME.search(path.name)
    if m is None:
        return [f"unexpected file name {path.name}"], Counter(), stats
    seed, idx = int(m.group(1)), int(m.group(2))
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        return [f"not a readable NPZ file ({exc})"], Counter(), stats
    ck.expect(set(data) == KEYS, f"keys {sorted(data)}")
    if set(data) != KEYS:
        return ck.errors, Counter(), stats
    j, labels, tags, contacts = data["joints"], data["labels"], data["tags"], data["contacts"]
    t = j.shape[0]
    # ---- format
    ck.expect(j.dtype == np.float32 and j.shape == (t, 17, 3), f"joints {j.dtype} {j.shape}")
    ck.expect(
        data["fps"].dtype == np.float64 and data["fps"].shape == () and float(data["fps"]) == 30.0, "fps"
    )
    ck.expect(labels.shape == (t,) and labels.dtype.kind == "U", f"labels {labels.dtype} {labels.shape}")
    ck.expect(tags.shape == (t,) and tags.dtype.kind == "U", f"tags {tags.dtype} {tags.shape}")
    ck.expect(
        contacts.shape == (t, 2) and contacts.dtype == np.bool_, f"contacts {contacts.dtype} {contacts.shape}"
    )
    src = data["source"]
    ck.expect(src.shape == () and src.dtype.kind == "U" and str(src) == SOURCE, f"source {src!r}")
    ck.expect(set(labels.tolist()) <= LABELS, f"label vocabulary {set(labels.tolist()) - LABELS}")
    ck.expect(set(tags.tolist()) <= STEP_TAGS | STILL_TAGS, f"tag vocabulary {set(tags.tolist())}")
    shapes_ok = (
        j.shape == (t, 17, 3)
        and labels.shape == tags.shape == (t,)
        and labels.dtype.kind == tags.dtype.kind == "U"
        and contacts.shape == (t, 2)
        and contacts.dtype == np.bool_
    )
    ck.expect(t > 0, "no frames")
    if not shapes_ok or t == 0:  # the checks below need the documented shapes
        return ck.errors, Counter(), stats
    # ---- regenerate the noise-free skeleton
    clean = generate_clean(seed, idx, t / FPS)
    cj = clean.joints
    ck.expect(cj.shape == j.shape, "regenerated shape differs")
    ck.expect(bool(np.array_equal(clean.plan.labels, labels)), "labels differ from regeneration")
    ck.expect(bool(np.array_equal(clean.plan.tags, tags)), "tags differ from regeneration")
    ck.expect(bool(np.array_equal(clean.contacts, contacts)), "contacts differ from regeneration")
    ck.expect(clean.ik_clamped == 0, f"{clean.ik_clamped} IK targets out of reach")
    # ---- bones constant
    worst = 0.0
    for a, b in BONES:
        length = np.linalg.norm(cj[:, a] - cj[:, b], axis=-1)
        worst = max(worst, float(length.max() - length.min()))
    stats["bone_range_mm"] = worst * 1000
    ck.expect(worst < 1e-6, f"bone length varies by {worst * 1000:.4f} mm")
    # ---- noise and drop-outs
    nan = np.isnan(j)
    ck.expect(bool((nan.all(-1) == nan.any(-1)).all()), "partially NaN joints")
    drop = nan.any(-1)
    expected = dropout_mask(rng_for(seed, idx, STREAM_DROP), t, 17)
    ck.expect(bool(np.array_equal(drop, expected)), "NaN outside the drop-out runs / mask mismatch")
    frac = float(drop.mean())
    stats["drop_frac"] = frac
    ck.expect(0.015 <= frac <= 0.025, f"drop-out fraction {frac:.4f}")
    longest = max((b - a for jj in range(17) for a, b in _runs(drop[:, jj])), default=0)
    ck.expect(longest <= MAX_RUN, f"drop-out run of {longest} frames")
    ext = drop[:, [9, 10, 15, 16]].mean()
    torso = drop[:, [5, 6, 11, 12]].mean()
    if t >= 900:  # statistical; only meaningful for longer sequences
        ck.expect(ext > torso, f"extremities dropped {ext:.4f} <= torso {torso:.4f}")
    res = (j.astype(np.float64) - cj)[~drop]
    sd = float(res.std())
    stats["noise_sd_cm"] = sd * 100
    ck.expect(
        0.0108 <= sd <= 0.0132 and abs(float(res.mean())) < 0.001, f"noise sd {sd:.4f} mean {res.mean():.4f}"
    )
    # ---- contacts vs ankles
    ank = cj[:, 15:17]
    ck.expect(not bool((~contacts).all(1).any()), "both feet airborne")
    zc = ank[..., 2][contacts]
    stats["ankle_z_contact"] = float(zc.max())
    ck.expect(
        bool(((zc >= 0.055) & (zc <= 0.13)).all()), f"ankle z in contact {zc.min():.3f}..{zc.max():.3f}"
    )
    speed = np.linalg.norm(np.diff(ank[..., :2], axis=0), axis=-1) * FPS
    both = contacts[1:] & contacts[:-1]
    vmax = float(speed[both].max())
    stats["contact_speed"] = vmax
    ck.expect(vmax < 0.1, f"contact foot slides at {vmax:.3f} m/s")
    za = ank[..., 2][~contacts]
    floor = clean.body.ankle_h
    ck.expect(bool((za > floor).all()), "airborne ankle at or below floor level")
    # ---- body placement
    r = np.linalg.norm(cj[:, 11:13, :2].mean(1), axis=-1)
    stats["max_radius"] = float(r.max())
    ck.expect(float(r.max()) < 0.75, f"person wanders {r.max():.2f} m from the origin")
    # ---- labels vs contacts
    lo_frames = {f: set(np.flatnonzero(contacts[:-1, f] & ~contacts[1:, f]) + 1) for f in range(2)}
    td_frames = {f: set(np.flatnonzero(~contacts[:-1, f] & contacts[1:, f]) + 1) for f in range(2)}
    airborne = ~contacts.all(1)
    still = labels == "still"
    bad_still = still & airborne & ~np.isin(tags, ["turn", "weight-shift"])
    ck.expect(not bool(bad_still.any()), f"{int(bad_still.sum())} still frames with a stepping swing")
    ck.expect(not bool(np.isin(tags[still], list(STEP_TAGS)).any()), "stepping tag on still frames")
    ck.expect(not bool(np.isin(tags[~still], list(STILL_TAGS)).any()), "still tag on stepping frames")
    bouts = _runs(~still)
    prev_end = -(10**9)
    for a, b in bouts:
        lab = set(labels[a:b].tolist())
        ck.expect(len(lab) == 1, f"bout {a}-{b} mixes labels {lab}")
        lab1 = labels[a]
        ck.expect(any(a in lo_frames[f] for f in range(2)), f"bout {a}-{b} does not start at a lift-off")
        ck.expect(
            any((b - 1) in td_frames[f] for f in range(2)), f"bout {a}-{b} does not end at a touch-down"
        )
        ck.expect(2.0 <= (b - a) / FPS <= 10.05, f"bout {a}-{b} lasts {(b - a) / FPS:.2f} s")
        ck.expect((a - prev_end - 1) / FPS >= 1.5 - 1e-9 or prev_end < 0, f"still gap before {a} too short")
        prev_end = b - 1
        for a2, b2 in _runs(contacts[a:b].all(1)):
            ck.expect((b2 - a2) / FPS <= 1.0 + 1e-9, f"pause of {(b2 - a2) / FPS:.2f} s inside bout {a}-{b}")
        # swings of the bout (foot, lift-off, touch-down)
        swings = []
        for f in range(2):
            for lo in sorted(x for x in lo_frames[f] if a <= x < b):
                td = min(x for x in td_frames[f] if x > lo)
                swings.append((lo, f, td))
        swings.sort()
        hips = cj[:, 11:13]
        if lab1 in ("left", "right"):
            lo, f, td = swings[0]
            right = hips[lo, 1, :2] - hips[lo, 0, :2]
            right /= np.linalg.norm(right)
            disp = float((ank[td, f, :2] - ank[lo - 1, f, :2]) @ right)
            want = 1.0 if lab1 == "right" else -1.0
            lead = 1 if lab1 == "right" else 0
            ck.expect(f == lead, f"{lab1} bout {a} starts with the wrong foot")
            ck.expect(disp * want > 0.05, f"{lab1} bout {a}: first step displaces {disp:+.3f} m sideways")
        if lab1 == "forward":
            feet_seq = [f for _, f, _ in swings]
            ck.expect(
                all(x != y for x, y in itertools.pairwise(feet_seq)), f"march bout {a} does not alternate"
            )
            for lo, f, td in swings:
                moved = float(np.linalg.norm(ank[td, f, :2] - ank[lo - 1, f, :2]))
                ck.expect(moved < 0.1, f"march bout {a}: foot moved {moved:.3f} m")
    return ck.errors, Counter(labels.tolist()), stats


def check_folder(folder: str | Path) -> list[str]:
    """Every problem of the blind4 files in ``folder`` as ``<file>: <problem>`` lines; [] when all pass."""
    files = sorted(Path(folder).glob("blind4_*.npz"))
    if not files:
        return [f"no blind4_*.npz files in {folder}"]
    return [f"{p.name}: {e}" for p in files for e in check_file(p)[0]]


def main(argv: list[str] | None = None) -> int:
    """Check a folder and print a per-file and overall summary."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or argv[0].startswith("-"):
        print("usage: python -m pipeline.sim.blind4.check OUT_DIR", file=sys.stderr)
        return 2
    files = sorted(Path(argv[0]).glob("blind4_*.npz"))
    if not files:
        print(f"error: no blind4_*.npz files in {argv[0]}", file=sys.stderr)
        return 2
    total: Counter[str] = Counter()
    n_bad = 0
    for p in files:
        errors, counts, stats = check_file(p)
        total.update(counts)
        status = "OK  " if not errors else "FAIL"
        n_bad += bool(errors)
        st = " ".join(f"{k}={v:.3g}" for k, v in stats.items())
        print(f"{status} {p.name}  {dict(sorted(counts.items()))}  {st}")
        for e in errors[:20]:
            print(f"     - {e}")
    n = sum(total.values())
    print("label frames:", {k: f"{v} ({100 * v / n:.1f}%)" for k, v in sorted(total.items())})
    print(f"{len(files) - n_bad}/{len(files)} files passed")
    return 0 if n_bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
