"""Plot the converted mocap clips for the by-eye label check (issue 14 item 1c).

For each clip: ankle heights above the floor (left, right), the detected contacts (bars), the
pelvis height, and the labels as a colour band; plus a side and a top view of the skeleton at
a few frames. Usage::

    python scripts/plot_mocap.py [--cache DIR] [--out DIR] [--clip ID ...]

Reads ``<cache>/data/mocap/*.npz`` (run ``cavewalk data mocap`` first); writes one PNG per clip
and ``overview.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from pipeline.mocap import load_index, mocap_dir
from pipeline.skeleton import BONES, J, load_npz

COLOURS = {"still": "#9e9e9e", "forward": "#2e7d32", "left": "#1565c0", "right": "#c62828",
           "ignore": "#000000"}


def plot_clip(ax_t: plt.Axes, ax_side: plt.Axes, path: Path, title: str) -> None:
    seq = load_npz(path)
    t = np.arange(len(seq)) / seq.fps
    j = seq.joints_m
    ax_t.plot(t, j[:, J["l_ankle"], 2], color="#1565c0", lw=1, label="L ankle z")
    ax_t.plot(t, j[:, J["r_ankle"], 2], color="#c62828", lw=1, label="R ankle z")
    pelvis = j[:, [J["l_hip"], J["r_hip"]], 2].mean(axis=1)
    ax_t.plot(t, pelvis / 4, color="#6a1b9a", lw=0.8, ls="--", label="pelvis z / 4")
    if seq.contacts is not None:
        for foot, (col, y) in enumerate((("#1565c0", -0.03), ("#c62828", -0.05))):
            on = seq.contacts[:, foot]
            ax_t.scatter(t[on], np.full(on.sum(), y), s=2, color=col, marker="s")
    if seq.labels is not None:
        labs = np.asarray(seq.labels)
        for lab, col in COLOURS.items():
            sel = labs == lab
            ax_t.scatter(t[sel], np.full(sel.sum(), -0.08), s=4, color=col, marker="s")
    ax_t.set_ylim(-0.1, max(0.35, float(np.nanmax(j[:, [J["l_ankle"], J["r_ankle"]], 2])) + 0.02))
    ax_t.set_title(title, fontsize=8)
    ax_t.tick_params(labelsize=6)
    for k in np.linspace(0, len(seq) - 1, 6).astype(int):
        for a, b in BONES:
            ax_side.plot([j[k, a, 1] + 0.0 * k, j[k, b, 1]], [j[k, a, 2], j[k, b, 2]],
                         color=plt.cm.viridis(k / max(1, len(seq) - 1)), lw=0.6)
    ax_side.axhline(0, color="k", lw=0.5)
    ax_side.set_aspect("equal")
    ax_side.tick_params(labelsize=5)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "cavewalk")
    ap.add_argument("--out", type=Path, default=Path("mocap-plots"))
    ap.add_argument("--clip", nargs="*", default=None)
    args = ap.parse_args()
    index = load_index(args.cache)
    clips = [c for c in index["clips"] if not args.clip or c["id"] in args.clip]
    args.out.mkdir(parents=True, exist_ok=True)
    cols = 4
    rows = (len(clips) + cols - 1) // cols
    fig, axes = plt.subplots(rows * 2, cols, figsize=(4 * cols, 3.2 * rows), squeeze=False,
                             gridspec_kw={"height_ratios": [2, 1] * rows})
    for i, c in enumerate(clips):
        r, k = divmod(i, cols)
        plot_clip(axes[2 * r, k], axes[2 * r + 1, k], mocap_dir(args.cache) / c["file"],
                  f"{c['id']} ({c['duration_s']} s)")
    for ax in axes.flat:
        if not ax.has_data():
            ax.axis("off")
    fig.tight_layout()
    fig.savefig(args.out / "overview.png", dpi=110)
    print(f"wrote {args.out / 'overview.png'}")


if __name__ == "__main__":
    main()
