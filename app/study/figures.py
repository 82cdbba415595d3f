"""The paper's figures: grouped bars per condition with error bars, the participants' points and
significance stars (SSQ, IPQ, NASA-TLX), and a per-session timeline of the recognised actions.

Drawn with matplotlib's object API on the Agg canvas (no pyplot, no global state), returned as
PNG or SVG bytes.
"""

from __future__ import annotations

import io
import logging
from collections.abc import Mapping, Sequence
from typing import Any, Final

import numpy as np

from app.study.analysis import condition_values
from app.study.data import CONDITIONS, EventRecord, StudyData

log = logging.getLogger(__name__)

FORMATS: Final[dict[str, str]] = {"png": "image/png", "svg": "image/svg+xml"}
COLOURS: Final[dict[str, str]] = {"CC": "#4C72B0", "EC": "#DD8452"}
CONDITION_NAMES: Final[dict[str, str]] = {"CC": "Controller (CC)", "EC": "Embodied (EC)"}
#: figure name -> (title, y label, [(measure, bar label)])
GROUPS: Final[dict[str, tuple[str, str, tuple[tuple[str, str], ...]]]] = {
    "ssq": (
        "SSQ after the session",
        "score",
        (
            ("ssq_total_post", "Total"),
            ("ssq_nausea_post", "Nausea"),
            ("ssq_oculomotor_post", "Oculomotor"),
            ("ssq_disorientation_post", "Disorientation"),
        ),
    ),
    "ipq": (
        "IPQ presence",
        "mean rating (0-6)",
        (("ipq_G1", "PRES (G1)"), ("ipq_SP", "SP"), ("ipq_INV", "INV"), ("ipq_REAL", "REAL")),
    ),
    "tlx": (
        "NASA-TLX workload",
        "rating (0-100)",
        (
            ("tlx_raw", "Raw TLX"),
            ("tlx_weighted", "Weighted"),
            ("tlx_mental", "Mental"),
            ("tlx_physical", "Physical"),
            ("tlx_temporal", "Temporal"),
            ("tlx_performance", "Performance"),
            ("tlx_effort", "Effort"),
            ("tlx_frustration", "Frustration"),
        ),
    ),
}
#: The dashboard's action colours (frontend/css/dashboard.css, ``--still`` ...): one palette for the
#: Command panel and the timeline (a test compares the two).
ACTION_COLOURS: Final[dict[str, str]] = {
    "still": "#9ca3af",
    "forward": "#2563eb",
    "left": "#16a34a",
    "right": "#9333ea",
}
#: Text sizes (points) readable when the dashboard shows a figure at about 600 px wide.
FONT = {"base": 13, "title": 15, "ticks": 12.5, "legend": 12.5, "stars": 15}


def stars(p: float | None, alpha: float = 0.05) -> str:
    """``***`` p < .001, ``**`` p < .01, ``*`` p < alpha, else empty."""
    if p is None or not np.isfinite(p):
        return ""
    if p < 0.001:
        return "***"
    if p < 0.01:
        return "**"
    return "*" if p < alpha else ""


def _render(fig: Any, fmt: str) -> bytes:
    if fmt not in FORMATS:
        raise ValueError(f"figure format must be one of {list(FORMATS)}, got {fmt!r}")
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=120, bbox_inches="tight")
    return buf.getvalue()


def _new_figure(width: float, height: float) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def bar_figure(
    values: Mapping[str, Mapping[str, Sequence[float]]],
    labels: Sequence[tuple[str, str]],
    p_values: Mapping[str, float | None],
    title: str,
    ylabel: str,
    fmt: str = "png",
    alpha: float = 0.05,
) -> bytes:
    """Grouped bars: for each (measure, label) the CC and EC means with SE bars and every value.

    ``values[measure][condition]`` holds the participants' values; ``p_values[measure]`` the
    test's p, drawn as stars over the pair of bars.
    """
    fig = _new_figure(1.4 + 0.95 * len(labels), 4.4)
    ax = fig.add_subplot()
    width = 0.38
    rng = np.random.default_rng(0)  # fixed jitter: the same data draws the same figure
    top = 0.0
    x = np.arange(len(labels))
    for j, cond in enumerate(CONDITIONS):
        offset = (j - 0.5) * width
        for i, (measure, _) in enumerate(labels):
            v = np.asarray(values.get(measure, {}).get(cond, ()), dtype=float)
            if v.size == 0:
                continue
            mean = float(v.mean())
            se = float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else 0.0
            ax.bar(
                x[i] + offset,
                mean,
                width,
                yerr=se,
                capsize=4,
                color=COLOURS[cond],
                alpha=0.85,
                label=CONDITION_NAMES[cond] if i == 0 else None,
                edgecolor="black",
                linewidth=0.6,
            )
            jitter = rng.uniform(-width / 4, width / 4, v.size)
            ax.scatter(x[i] + offset + jitter, v, s=12, color="black", alpha=0.6, zorder=3, linewidths=0)
            top = max(top, float(v.max()), mean + se)
    span = top if top > 0 else 1.0
    for i, (measure, _) in enumerate(labels):
        mark = stars(p_values.get(measure), alpha)
        if mark:
            y = top + 0.06 * span
            ax.plot(
                [x[i] - width / 2, x[i] - width / 2, x[i] + width / 2, x[i] + width / 2],
                [y - 0.02 * span, y, y, y - 0.02 * span],
                color="black",
                linewidth=0.8,
            )
            ax.text(x[i], y + 0.01 * span, mark, ha="center", va="bottom", fontsize=FONT["stars"])
    crowded = len(labels) > 5 or sum(len(label) for _, label in labels) > 8 * len(labels)
    ax.set_xticks(x, [label for _, label in labels], fontsize=FONT["ticks"],
                  rotation=25 if crowded else 0, ha="right" if crowded else "center")
    ax.tick_params(axis="y", labelsize=FONT["ticks"])
    ax.set_ylabel(f"{ylabel} (mean ± SE)", fontsize=FONT["base"])
    ax.set_title(title, fontsize=FONT["title"])
    ax.set_ylim(bottom=min(0.0, ax.get_ylim()[0]), top=top + 0.18 * span)
    ax.spines[["top", "right"]].set_visible(False)
    handles, names = ax.get_legend_handles_labels()
    if handles:
        ax.legend(handles, names, frameon=False, loc="lower center", bbox_to_anchor=(0.5, 1.06), ncol=2,
                  fontsize=FONT["legend"])
    else:
        ax.text(0.5, 0.5, "no data yet", transform=ax.transAxes, ha="center", va="center", color="grey")
    return _render(fig, fmt)


def study_figure(data: StudyData, analysis: Mapping[str, Any], name: str, fmt: str = "png") -> bytes:
    """One of the paper's figures (``ssq``, ``ipq``, ``tlx``) from the study records and their analysis."""
    if name not in GROUPS:
        raise ValueError(f"figure must be one of {list(GROUPS)}, got {name!r}")
    title, ylabel, labels = GROUPS[name]
    values: dict[str, dict[str, list[float]]] = {}
    for measure, _ in labels:
        per = condition_values(data, measure)
        values[measure] = {c: [v[c] for v in per.values() if c in v] for c in CONDITIONS}
    measures = analysis.get("measures", {})
    # stars from the p corrected for multiple comparisons (the analysis table's p_adj)
    p_values = {m: measures[m].get("p_adjusted", measures[m]["p"]) for m, _ in labels if m in measures}
    return bar_figure(values, labels, p_values, title, ylabel, fmt, float(analysis.get("alpha", 0.05)))


def action_label(payload: Mapping[str, Any]) -> str | None:
    """The action's label in an ``action`` event's payload (``label``, or ``action`` as text or object)."""
    label = payload.get("label")
    if label is None:
        action = payload.get("action")
        label = action.get("label") if isinstance(action, Mapping) else action
    return str(label) if label is not None else None


def action_segments(
    events: Sequence[EventRecord], end_ts: float | None = None
) -> list[tuple[str, float, float]]:
    """(label, start_s, duration_s) per run of one action, times from the first event."""
    points = [(e.ts, action_label(e.payload)) for e in events if e.kind == "action"]
    points = sorted((t, lab) for t, lab in points if lab is not None)
    if not points:
        return []
    t0 = points[0][0]
    last = end_ts if end_ts is not None and end_ts > points[-1][0] else points[-1][0]
    out: list[tuple[str, float, float]] = []
    for (t, lab), nxt in zip(points, [*points[1:], (last, None)], strict=True):
        duration = nxt[0] - t
        if out and out[-1][0] == lab and abs(out[-1][1] + out[-1][2] - (t - t0)) < 1e-9:
            prev = out[-1]
            out[-1] = (lab, prev[1], prev[2] + duration)
        else:
            out.append((str(lab), t - t0, duration))
    return out


def timeline_figure(events: Sequence[EventRecord], title: str, fmt: str = "png") -> bytes:
    """The session's recognised actions over time: one lane per action, a bar while it was active."""
    segments = action_segments(events)
    lanes = list(ACTION_COLOURS)
    lanes += sorted({s[0] for s in segments} - set(lanes))
    fig = _new_figure(9.0, 2.8)
    ax = fig.add_subplot()
    for i, lane in enumerate(lanes):
        spans = [(start, max(dur, 1e-3)) for lab, start, dur in segments if lab == lane]
        if spans:
            ax.broken_barh(spans, (i - 0.4, 0.8), color=ACTION_COLOURS.get(lane, "#6A1B9A"))
    ax.set_yticks(range(len(lanes)), lanes, fontsize=FONT["ticks"])
    ax.tick_params(axis="x", labelsize=FONT["ticks"])
    ax.set_xlabel("time since the first action (s)", fontsize=FONT["base"])
    ax.set_title(title, fontsize=FONT["title"])
    if not segments:
        ax.text(
            0.5, 0.5, "no action events in this session", transform=ax.transAxes, ha="center", va="center"
        )
        ax.set_xlim(0, 1)
    ax.spines[["top", "right"]].set_visible(False)
    return _render(fig, fmt)
