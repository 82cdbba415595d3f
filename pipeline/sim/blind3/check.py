"""The blind3 checker: every file of a set against the generator that wrote it.

``check_folder(OUT_DIR)`` (or ``python -m pipeline.sim.blind3.check OUT_DIR``, which also prints a
summary of the content) takes every ``OUT_DIR/blind3_<seed>_<idx>.npz`` and

  * checks the array names, shapes and dtypes;
  * regenerates the noise-free sequence from (seed, idx) with the generator (the clean copy
    is never written to disk) and checks that the file equals it up to the observation model
    (Gaussian noise of 1.2 cm per coordinate, 2 % of joint observations dropped in short runs,
    identical labels / tags / contacts);
  * on the clean copy: constant bone lengths; planted ankles at standing height and not sliding
    (> 2 cm) while their contact is true; lifted feet clearly above the floor and never below it;
    the first step of every left/right bout moves a foot to that side in the body frame (body
    frame taken from the hip keypoints); `still` frames have both feet on the floor except in
    turns (pivot steps) and weight shifts (heel raise); label segments run from a lift-off to a
    touch-down.

The command exits with status 0 when every check passes, 1 when one fails, 2 on a usage error.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind3.api import generate_clean

KEYS = {"joints", "fps", "labels", "tags", "contacts", "source"}
LABELS = {"still", "forward", "left", "right"}
BONES = {
    "l_thigh": (11, 13),
    "r_thigh": (12, 14),
    "l_shank": (13, 15),
    "r_shank": (14, 16),
    "l_upper_arm": (5, 7),
    "r_upper_arm": (6, 8),
    "l_forearm": (7, 9),
    "r_forearm": (8, 10),
    "hip_width": (11, 12),
    "shoulder_width": (5, 6),
    "nose_l_eye": (0, 1),
    "nose_r_eye": (0, 2),
    "eye_eye": (1, 2),
    "l_eye_ear": (1, 3),
    "r_eye_ear": (2, 4),
    "ear_ear": (3, 4),
    "nose_l_ear": (0, 3),
}
SLIDE_TOL = 0.02
Z_TOL = 0.003
LIFT_MIN = 0.015


def runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """(start, end_inclusive) of True runs in a 1-D bool array."""
    m = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(m)
    return list(zip(np.where(d == 1)[0], np.where(d == -1)[0] - 1, strict=True))


def segments(labels: list[str]) -> list[tuple[int, int, str]]:
    """(start, end_inclusive, value) of each run of equal labels."""
    out, a = [], 0
    for i in range(1, len(labels) + 1):
        if i == len(labels) or labels[i] != labels[a]:
            out.append((a, i - 1, labels[a]))
            a = i
    return out


class Report:
    """The failed checks, one line each."""

    def __init__(self) -> None:
        self.fail: list[str] = []

    def check(self, ok: bool, name: str, detail: str = "") -> bool:
        if not ok:
            self.fail.append(f"{name}: {detail}")
        return ok


def new_summary() -> dict[str, Any]:
    """The empty summary that check_file fills."""
    return dict(
        drop_rate=[],
        noise_sd=[],
        drop_runs=[],
        bone_range=0.0,
        contact_zdev=0.0,
        max_slide=0.0,
        min_lift=9.0,
        lift_peaks=[],
        bouts=[],
        turns=[],
        pivot_steps=[],
        shifts=0,
        heel_lift_frames=0,
        gestures={},
        heights=[],
        frames=0,
        label_frames={},
        max_corr=0.0,
        corr=[],
        lowering=0.0,
        pelvis_r=0.0,
    )


def set_files(folder: str | Path) -> list[Path]:
    """The blind3 files of a folder, sorted by name."""
    return sorted(Path(folder).glob("blind3_*_*.npz"))


def check_file(path: str | Path, rep: Report, summ: dict[str, Any]) -> None:
    """Check one file (see the module docstring); failures go to rep, measurements to summ."""
    name = Path(path).name
    m = re.match(r"blind3_(\d+)_(\d+)\.npz$", name)
    if m is None:
        rep.check(False, name, "unexpected file name")
        return
    seed, idx = int(m.group(1)), int(m.group(2))
    with np.load(path, allow_pickle=False) as z:
        keys = set(z.files)
        rep.check(keys == KEYS, f"{name} keys", f"{sorted(keys)}")
        J, fps = z["joints"], z["fps"]
        lab, tags, con, src = z["labels"], z["tags"], z["contacts"], z["source"]
    T = J.shape[0]
    rep.check(
        J.dtype == np.float32 and J.ndim == 3 and J.shape[1:] == (17, 3),
        f"{name} joints",
        f"{J.dtype} {J.shape}",
    )
    rep.check(
        fps.dtype == np.float64 and fps.shape == () and float(fps) == 30.0,
        f"{name} fps",
        f"{fps.dtype} {fps.shape} {fps}",
    )
    rep.check(lab.dtype.kind == "U" and lab.shape == (T,), f"{name} labels dtype", f"{lab.dtype} {lab.shape}")
    rep.check(set(np.unique(lab)) <= LABELS, f"{name} labels values", f"{np.unique(lab)}")
    rep.check(
        tags.dtype.kind == "U" and tags.shape == (T,), f"{name} tags dtype", f"{tags.dtype} {tags.shape}"
    )
    rep.check(con.dtype == np.bool_ and con.shape == (T, 2), f"{name} contacts", f"{con.dtype} {con.shape}")
    rep.check(
        src.dtype.kind == "U" and src.shape == () and str(src) == "blind3", f"{name} source", f"{src!r}"
    )

    # ---- regenerate the noise-free sequence
    g, C = generate_clean(seed, idx, duration=T / float(fps), fps=float(fps))
    rep.check(C.shape == J.shape, f"{name} regenerated shape", f"{C.shape}")
    rep.check(np.array_equal(lab, g.labels), f"{name} labels == model", "")
    rep.check(np.array_equal(tags, g.tags), f"{name} tags == model", "")
    contacts = g.gstate == 0
    rep.check(np.array_equal(con, contacts), f"{name} contacts == model", "")

    # ---- observation model: noise and drops
    nanj = np.isnan(J)
    rep.check(np.array_equal(nanj.any(2), nanj.all(2)), f"{name} NaN whole joints", "partial NaN coordinates")
    miss = nanj.any(2)
    rate = miss.mean()
    res = (J.astype(np.float64) - C)[~miss]
    sd, mu = res.std(), res.mean()
    rep.check(0.0190 <= rate <= 0.0210, f"{name} drop rate", f"{rate:.4f}")
    rep.check(abs(sd - 0.012) < 0.0004 and abs(mu) < 0.0005, f"{name} noise", f"sd={sd:.5f} mean={mu:.5f}")
    run_len = [b - a + 1 for k in range(17) for a, b in runs(miss[:, k])]
    rep.check(max(run_len) <= 12, f"{name} drop runs short", f"max run {max(run_len)}")
    summ["drop_rate"].append(rate)
    summ["noise_sd"].append(sd)
    summ["drop_runs"].extend(run_len)

    # ---- bone lengths (clean copy, and statistically on the file)
    worst = 0.0
    for bn, (i, j) in BONES.items():
        L = np.linalg.norm(C[:, i] - C[:, j], axis=1)
        worst = max(worst, L.max() - L.min())
        Lf = np.linalg.norm(J[:, i].astype(float) - J[:, j], axis=1)
        Lf = Lf[np.isfinite(Lf)]
        rep.check(
            abs(np.median(Lf) - np.median(L)) < 0.01,
            f"{name} bone {bn} in file",
            f"{np.median(Lf):.3f} vs {np.median(L):.3f}",
        )
    rep.check(worst < 1e-6, f"{name} bone lengths constant", f"max range {worst:.2e} m")
    summ["bone_range"] = max(summ["bone_range"], worst)

    # ---- feet
    ank = C[:, 15:17]
    zc = ank[:, :, 2][contacts]
    h_floor = float(np.median(zc))
    H = g.B.H
    rep.check(0.06 <= h_floor <= 0.10, f"{name} ankle standing height", f"{h_floor:.4f}")
    rep.check(
        abs(h_floor - g.B.ankle_h) < 1e-6, f"{name} ankle height = body model", f"{h_floor} vs {g.B.ankle_h}"
    )
    rep.check(
        np.abs(zc - h_floor).max() <= Z_TOL,
        f"{name} planted ankle height",
        f"max dev {np.abs(zc - h_floor).max():.4f}",
    )
    summ["contact_zdev"] = max(summ["contact_zdev"], float(np.abs(zc - h_floor).max()))
    max_slide = 0.0
    for s in (0, 1):
        for a, b in runs(contacts[:, s]):
            d = np.linalg.norm(ank[a : b + 1, s] - ank[a, s], axis=1).max()
            max_slide = max(max_slide, d)
    rep.check(max_slide <= SLIDE_TOL, f"{name} planted ankle slide", f"{max_slide:.4f} m")
    summ["max_slide"] = max(summ["max_slide"], max_slide)
    rep.check(
        ank[:, :, 2].min() >= h_floor - Z_TOL,
        f"{name} floor penetration",
        f"min ankle z {ank[:, :, 2].min():.4f}",
    )
    min_lift = 9.0
    for s in (0, 1):
        for a, b in runs(~contacts[:, s]):
            if a == 0 or b == T - 1:
                continue
            pk = ank[a : b + 1, s, 2].max() - h_floor
            min_lift = min(min_lift, pk)
            summ["lift_peaks"].append((str(tags[a]) or "still", pk))
    rep.check(min_lift >= LIFT_MIN, f"{name} lifted foot above floor", f"min peak lift {min_lift:.4f} m")
    summ["min_lift"] = min(summ["min_lift"], min_lift)

    # ---- body frame from the hips
    rv = C[:, 12, :2] - C[:, 11, :2]
    rv /= np.linalg.norm(rv, axis=1, keepdims=True)
    fv = np.stack([-rv[:, 1], rv[:, 0]], 1)  # forward = z x right
    yaw = np.unwrap(np.arctan2(fv[:, 1], fv[:, 0]))

    # ---- label segments
    for a, b, label in segments(list(lab)):
        if label == "still":
            continue
        ok_start = a > 0 and any((not contacts[a, s]) and contacts[a - 1, s] for s in (0, 1))
        ok_end = b < T - 1 and any(contacts[b, s] and not contacts[b - 1, s] for s in (0, 1))
        rep.check(
            ok_start and ok_end, f"{name} bout {a}-{b} {label} bounds", f"start ok {ok_start} end ok {ok_end}"
        )
        rep.check(
            contacts[b + 1].all() if b + 1 < T else True, f"{name} bout {a}-{b} followed by standing", ""
        )
        tg = set(np.unique(tags[a : b + 1])) - {"pause"}
        rep.check(len(tg) == 1, f"{name} bout {a}-{b} single kind", f"{tg}")
        kind = tg.pop() if tg else "?"
        dur = (b - a + 1) / float(fps)
        lifts = [
            (s, f) for s in (0, 1) for f in range(a, b + 1) if (not contacts[f, s]) and contacts[f - 1, s]
        ]
        lifts.sort(key=lambda x: x[1])
        prs = [(q - p + 1) / float(fps) for p, q in runs(tags[a : b + 1] == "pause")]
        for pdur in prs:
            rep.check(0.2 - 1e-9 <= pdur <= 1.0 + 1.5 / float(fps), f"{name} pause length", f"{pdur:.2f}s")
        b_info: dict[str, Any] = dict(
            file=name,
            label=label,
            kind=kind,
            start=int(a),
            end=int(b),
            duration=dur,
            n_steps=len(lifts),
            pauses=prs,
        )
        if label in ("left", "right"):
            s, f = lifts[0]
            # touch-down of that swing
            td = f
            while not contacts[td, s]:
                td += 1
            disp = ank[td, s, :2] - ank[f - 1, s, :2]
            lat = float(np.dot(disp, rv[f - 1]))
            want = 1 if label == "right" else -1
            ok = lat * want >= 0.05
            rep.check(
                ok,
                f"{name} bout {a}-{b} {label} first step direction",
                f"lateral {lat:+.3f} m (foot {'LR'[s]})",
            )
            b_info["first_step_lateral"] = lat
            b_info["first_step_foot"] = "LR"[s]
        else:
            # step rate between the first and the last lift-off, pauses excluded
            if len(lifts) >= 3:
                span = (lifts[-1][1] - lifts[0][1]) / float(fps)
                pz = sum(
                    (q - p + 1) / float(fps) for p, q in runs(tags[lifts[0][1] : lifts[-1][1] + 1] == "pause")
                )
                b_info["cadence"] = (len(lifts) - 1) / max(span - pz, 1e-6)
            pk = []
            for s, f in lifts:
                e = f
                while e < T and not contacts[e, s]:
                    e += 1
                pk.append(ank[f:e, s, 2].max() - h_floor)
            b_info["mean_lift"] = float(np.mean(pk)) if pk else float("nan")
        summ["bouts"].append(b_info)

    # ---- still frames: both feet down except turn pivot steps and heel-raising weight shifts
    still = lab == "still"
    off = still & ~contacts.all(1)
    bad = off & ~np.isin(tags, ["turn", "weight-shift"])
    rep.check(not bad.any(), f"{name} still frames feet down", f"{bad.sum()} frames, tags {set(tags[bad])}")
    # a still frame never moves a planted foot (covered by the slide check) -> count turns
    for a, b in runs(tags == "turn"):
        summ["turns"].append(float((yaw[b] - yaw[a]) * 180 / math.pi))
        n_piv = sum(1 for s in (0, 1) for p, q in runs(~contacts[a : b + 1, s]))
        summ["pivot_steps"].append(n_piv)
    for a, b in runs(tags == "weight-shift"):
        summ["shifts"] += 1
        summ["heel_lift_frames"] += int((~contacts[a : b + 1]).any(1).sum())
    for t in ("wave", "point", "look", "stretch", "bow"):
        summ["gestures"][t] = summ["gestures"].get(t, 0) + len(runs(tags == t))
    summ["heights"].append(H)
    summ["frames"] += T
    summ["label_frames"] = {k: summ["label_frames"].get(k, 0) + int((lab == k).sum()) for k in sorted(LABELS)}
    summ["max_corr"] = max(summ["max_corr"], float(g.corr[g.gstate != 2].max()))
    summ["corr"].append(g.corr[g.gstate != 2])
    summ["lowering"] = max(summ["lowering"], float(g.lower.max()))
    summ["pelvis_r"] = max(summ["pelvis_r"], float(np.linalg.norm(g.pel[:, :2], axis=1).max()))


def check_files(folder: str | Path, *, progress: bool = False) -> tuple[list[str], dict[str, Any]]:
    """The failed checks of every blind3 file in ``folder`` and the summary measured from them.

    A file that cannot be read or checked to the end is a failed check, not an exception."""
    files = set_files(folder)
    rep = Report()
    summ = new_summary()
    rep.check(len(files) > 0, "files", f"no blind3_*.npz in {folder}")
    for p in files:
        try:
            check_file(p, rep, summ)
        except Exception as exc:  # a malformed file is a failed check
            rep.check(False, f"{p.name} unreadable", f"{type(exc).__name__}: {exc}")
        if progress:
            print(f"checked {p.name}", flush=True)
    return rep.fail, summ


def check_folder(folder: str | Path) -> list[str]:
    """The problems found in the blind3 files of ``folder``: one line per failed check, [] if all pass."""
    return check_files(folder)[0]


def pct(x: Any, q: float) -> float:
    return float(np.percentile(x, q)) if len(x) else float("nan")


def _lo_hi(values: Any, fmt: str, scale: float = 1.0, sep: str = "-") -> str:
    """``min-max`` of values (times scale) in format fmt; ``nan-nan`` when there are none."""
    vals = [v * scale for v in values]
    lo, hi = (min(vals), max(vals)) if vals else (float("nan"), float("nan"))
    return f"{lo:{fmt}}{sep}{hi:{fmt}}"


def summary_lines(summ: dict[str, Any], n_files: int) -> list[str]:
    """The summary of a checked set, measured from its arrays (see check_files)."""
    nan = float("nan")
    B = summ["bouts"]
    drop_runs = summ["drop_runs"]
    corr = np.concatenate([c.ravel() for c in summ["corr"]]) if summ["corr"] else np.zeros(0)
    out = [
        f"files {n_files}, frames {summ['frames']}, label frames {summ['label_frames']}",
        f"body heights: {', '.join(f'{h:.2f}' for h in summ['heights'])}",
        f"drop rate per file: {_lo_hi(summ['drop_rate'], '.4f', sep='..')}; "
        f"drop runs mean {np.mean(drop_runs) if drop_runs else nan:.2f} "
        f"max {max(drop_runs, default=0)} frames",
        f"noise sd per file: {_lo_hi(summ['noise_sd'], '.5f', sep='..')} m",
        f"bone length range (clean): {summ['bone_range']:.2e} m",
        f"planted ankle: max |z - standing height| {summ['contact_zdev'] * 1000:.3f} mm, "
        f"max slide {summ['max_slide'] * 1000:.3f} mm",
        f"lifted feet: min peak lift {summ['min_lift'] * 100:.2f} cm",
        f"closed-chain correction of grounded legs: median {np.median(corr) if len(corr) else nan:.2f} deg, "
        f"p99 {pct(corr, 99):.2f}, max {corr.max() if len(corr) else nan:.2f}; "
        f"max pelvis lowering {summ['lowering'] * 1000:.1f} mm; "
        f"max pelvis distance from room centre {summ['pelvis_r']:.2f} m",
    ]
    for label in ("forward", "left", "right"):
        bl = [b for b in B if b["label"] == label]
        durations = [b["duration"] for b in bl]
        out.append(f"{label}: {len(bl)} bouts, durations {pct(durations, 0):.2f}-{pct(durations, 100):.2f} s")
    kinds = sorted({b["kind"] for b in B})
    for k in kinds:
        bk = [b for b in B if b["kind"] == k]
        sides = ", ".join(
            f"{label} {sum(1 for b in bk if b['label'] == label)}"
            for label in ("forward", "left", "right")
            if any(b["label"] == label for b in bk)
        )
        n_steps = [b["n_steps"] for b in bk]
        line = f"  {k}: {len(bk)} bouts ({sides}), steps/bout {pct(n_steps, 0):.0f}-{pct(n_steps, 100):.0f}"
        if k == "march":
            cad = [b["cadence"] for b in bk if "cadence" in b]
            line += (
                f", cadence (bouts >= 3 steps) {_lo_hi(cad, '.2f')} steps/s "
                f"(median {np.median(cad) if cad else nan:.2f}), "
                f"mean ankle lift per bout {_lo_hi([b['mean_lift'] for b in bk], '.1f', 100)} cm"
            )
        else:
            wd = [abs(b["first_step_lateral"]) for b in bk]
            line += f", first-step lateral width {_lo_hi(wd, '.1f', 100)} cm"
        out.append(line)
    prs = [p for b in B for p in b["pauses"]]
    pivots = summ["pivot_steps"]
    out += [
        f"pauses inside bouts: {len(prs)}, {min(prs) if prs else 0:.2f}-{max(prs) if prs else 0:.2f} s",
        f"turns: {len(summ['turns'])}, |angle| {_lo_hi([abs(t) for t in summ['turns']], '.0f')} deg, "
        f"pivot steps per turn {min(pivots, default=0)}-{max(pivots, default=0)}",
        f"weight shifts: {summ['shifts']} ({summ['heel_lift_frames']} heel-raised frames); "
        f"gestures: {summ['gestures']}",
        f"first-step direction checks: {sum(1 for b in B if b['label'] in ('left', 'right'))} side bouts",
    ]
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m pipeline.sim.blind3.check OUT_DIR``: check a set, print the summary and the result."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1 or args[0].startswith("-"):
        print("usage: python -m pipeline.sim.blind3.check OUT_DIR", file=sys.stderr)
        return 2
    problems, summ = check_files(args[0], progress=True)
    print("\n=== summary ===")
    for line in summary_lines(summ, len(set_files(args[0]))):
        print(line)
    print("\n=== result ===")
    if problems:
        print(f"FAILED {len(problems)} checks:")
        for f in problems[:60]:
            print("  " + f)
        return 1
    print("ALL CHECKS PASSED")
    return 0


if __name__ == "__main__":
    sys.exit(main())
