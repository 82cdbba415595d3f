"""A check figure of one generated sequence: ankle heights, contacts and labels over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.sim.blind.generate import Generated
from pipeline.skeleton import J

LABEL_COLOURS = {
    "still": "#dddddd",
    "forward": "#4c9be8",
    "left": "#e8a33c",
    "right": "#5cbf5c",
    "ignore": "#ffffff",
}


def plot_check(g: Generated, path: str | Path, span_s: tuple[float, float] | None = None) -> Path:
    """Save a PNG of ``g``: clean ankle heights with contacts, pelvis height, labels and tags."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seq, clean = g.sequence, g.clean
    t = np.arange(len(seq)) / seq.fps
    lo, hi = (0, len(seq)) if span_s is None else (int(span_s[0] * seq.fps), int(span_s[1] * seq.fps))
    sl = slice(lo, hi)
    fig, axes = plt.subplots(3, 1, figsize=(16, 8), sharex=True, gridspec_kw={"height_ratios": [3, 1.3, 1]})
    ax = axes[0]
    for j, name, colour in (
        (J["l_ankle"], "left ankle", "tab:blue"),
        (J["r_ankle"], "right ankle", "tab:red"),
    ):
        z = clean.joints_m[sl, j, 2]
        ax.plot(t[sl], z, color=colour, lw=1.2, label=name)
        foot = 0 if j == J["l_ankle"] else 1
        down = clean.contact[sl, foot]
        ax.plot(t[sl][down], z[down], ".", color=colour, ms=2)
    ax.set_ylabel("ankle z (m); dots = contact")
    ax.legend(loc="upper right")
    ax.set_title(
        f"{seq.source}: height {g.body.height_m:.2f} m, cadence {g.style.cadence_hz:.2f}/s, "
        f"lift {100 * g.style.march_lift_m:.0f} cm, law {g.style.law}"
    )
    axes[1].plot(t[sl], clean.pelvis_m[sl, 2], color="k", lw=1)
    axes[1].plot(t[sl], clean.joints_m[sl, J["nose"], 2] - 0.7, color="tab:purple", lw=1)
    axes[1].set_ylabel("pelvis z /\nnose z − 0.7")
    ax = axes[2]
    labels, tags = seq.labels or (), seq.tags or ()
    k = lo
    while k < hi:
        e = k
        while e + 1 < hi and labels[e + 1] == labels[k] and tags[e + 1] == tags[k]:
            e += 1
        ax.axvspan(t[k], t[e] + 1 / seq.fps, color=LABEL_COLOURS[labels[k]], lw=0)
        if tags[k] and (e - k) > seq.fps * 0.6:
            ax.text(t[k], 0.5, tags[k], fontsize=7, va="center", rotation=90 if (e - k) < 2 * seq.fps else 0)
        k = e + 1
    ax.set_yticks([])
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in LABEL_COLOURS.values()]
    ax.legend(handles, list(LABEL_COLOURS), loc="upper right", ncol=5, fontsize=7)
    ax.set_xlabel("time (s)")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
