"""Exports of the study: the long-format CSV, the tables, and a report folder with figures.

The long format has one row per participant x session x item (the raw answers; the stored
scores and the NASA-TLX pairwise choices follow as rows of kind ``score`` and ``pairwise``),
which R, SPSS and pandas read directly.
"""

from __future__ import annotations

import csv
import io
import json
import logging
from collections.abc import Callable, Iterable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from app.study.analysis import MEASURES, AnalysisConfig, analyse
from app.study.data import StudyData
from app.study.design import DesignConfig, design_summary
from app.study.figures import FORMATS, GROUPS, study_figure
from app.study.summary import SESSION_COLUMNS
from pipeline.errors import InputError

log = logging.getLogger(__name__)

EXPORT_COLUMNS: tuple[str, ...] = (
    "participant_id",
    "participant_code",
    "first_condition",
    "session_id",
    "condition",
    "planned_index",
    "session_status",
    "session_started_at",
    "questionnaire_id",
    "instrument",
    "phase",
    "submitted_at",
    "entered_by",
    "used_in_analysis",
    "not_used_because",
    "corrects_id",
    "kind",
    "item",
    "value",
)
MEASURE_COLUMNS: tuple[str, ...] = (
    "measure",
    "n",
    "mean_cc",
    "sd_cc",
    "median_cc",
    "iqr_cc",
    "mean_ec",
    "sd_ec",
    "median_ec",
    "iqr_ec",
    "mean_diff",
    "shapiro_w",
    "shapiro_p",
    "normal",
    "test",
    "statistic",
    "df",
    "z",
    "r",
    "p",
    "p_adjusted",
    "correction",
    "normality_note",
    "anova_F",
    "anova_df1",
    "anova_df2",
    "anova_p",
    "partial_eta_sq",
    "cohens_d",
    "cohens_d_ci_low",
    "cohens_d_ci_high",
    "effect_label",
    "note",
)


def _iso(t: datetime | None) -> str:
    return t.isoformat() if t is not None else ""


def export_rows(data: StudyData) -> list[dict[str, Any]]:
    """The long format: one row per participant x session x item (then the scores, the pairwise choices)."""
    rows: list[dict[str, Any]] = []
    for p in data.participants:
        for s in data.sessions_of(p.id):
            for r in data.responses_of(s.id):
                base = {
                    "participant_id": p.id,
                    "participant_code": p.code,
                    "first_condition": p.first_condition or "",
                    "session_id": s.id,
                    "condition": s.condition,
                    "planned_index": s.planned_index if s.planned_index is not None else "",
                    "session_status": s.status,
                    "session_started_at": _iso(s.started_at),
                    "questionnaire_id": r.id,
                    "instrument": r.instrument,
                    "phase": r.phase or "",
                    "submitted_at": _iso(r.created_at),
                    "entered_by": r.entered_by,
                    "used_in_analysis": "no" if data.why_not_used(r) else "yes",
                    "not_used_because": data.why_not_used(r) or "",
                    "corrects_id": r.corrects if r.corrects is not None else "",
                }
                parts: list[tuple[str, Mapping[str, Any]]] = [("answer", r.answers), ("score", r.scores)]
                if r.pairwise is not None:
                    parts.append(("pairwise", r.pairwise))
                for kind, items in parts:
                    for item, value in items.items():
                        rows.append({**base, "kind": kind, "item": item, "value": value})
    return rows


def to_csv(rows: Iterable[Mapping[str, Any]], columns: Sequence[str]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(columns), extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in columns})
    return buf.getvalue()


def export_csv(data: StudyData) -> str:
    return to_csv(export_rows(data), EXPORT_COLUMNS)


def measure_rows(analysis: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per measure: descriptives, the tests and the effect size."""
    rows = []
    for name, m in analysis["measures"].items():
        anova = m.get("anova") or {}
        ci = m.get("cohens_d_ci95") or [None, None]
        rows.append(
            {
                **{k: m.get(k) for k in MEASURE_COLUMNS},
                "measure": name,
                "anova_F": anova.get("F"),
                "anova_df1": anova.get("df1"),
                "anova_df2": anova.get("df2"),
                "anova_p": anova.get("p"),
                "partial_eta_sq": anova.get("partial_eta_sq"),
                "cohens_d_ci_low": ci[0],
                "cohens_d_ci_high": ci[1],
            }
        )
    return rows


def _fmt(x: Any, digits: int = 2) -> str:
    if x is None:
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def _p(p: float | None) -> str:
    if p is None:
        return "–"
    return "< .001" if p < 0.001 else f"{p:.3f}"


def markdown_report(analysis: Mapping[str, Any], design: Mapping[str, Any], figures: Sequence[str]) -> str:
    """A short Markdown report: the sample, the exclusions, one table of tests, the figures."""
    lines = [
        "# cavewalk user study: analysis",
        "",
        f"Generated {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}. "
        f"{analysis['participants']} participants registered, {design['completed_participants']} "
        f"completed both conditions (CC first: {design['first_condition_counts']['CC']}, "
        f"EC first: {design['first_condition_counts']['EC']})"
        + (f"; incomplete: {', '.join(design['incomplete'])}" if design["incomplete"] else "")
        + ".",
        "",
    ]
    if analysis.get("exclusions"):
        lines.append("Excluded by the operator:")
        lines += [f"- {e['kind']} {e['id']} ({e['code']}): {e['reason']}" for e in analysis["exclusions"]]
        lines.append("")
    if analysis["excluded"]:
        lines.append("Left out of the paired tests (one condition only):")
        lines += [f"- {code}: {analysis['excluded_reasons'][code]}" for code in analysis["excluded"]]
        lines.append("")
    if design["gap_warnings"]:
        lines.append("Design warnings:")
        lines += [f"- {w['message']}" for w in design["gap_warnings"]]
        lines.append("")
    lines += [
        "Differences are EC − CC. Shapiro-Wilk on the paired differences decides between the paired "
        "t-test (with the repeated-measures ANOVA F(1, n−1); sphericity is trivially met with two "
        "levels) and the Wilcoxon signed-rank test (Z, r = Z/√n). Effect size: Cohen's d_z with its exact "
        "95 % CI (noncentral t). "
        f"p: unadjusted; p_adj: {analysis.get('correction_text', '')}. "
        "normal: '(n small)' where the n is too small for Shapiro-Wilk to judge normality.",
        "",
        "| measure | n | CC mean (SD) | EC mean (SD) | normal | test | statistic | p | p_adj "
        "| d [95 % CI] | effect |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, m in analysis["measures"].items():
        if m["test"] is None:
            lines.append(
                f"| {name} | {m['n']} | {_fmt(m['mean_cc'])} ({_fmt(m['sd_cc'])}) | "
                f"{_fmt(m['mean_ec'])} ({_fmt(m['sd_ec'])}) | – | – | | | | | {m.get('note', '')} |"
            )
            continue
        stat = (
            f"t({m['df']}) = {_fmt(m['statistic'])}" if m["test"] == "paired_t" else f"Z = {_fmt(m.get('z'))}"
        )
        if m["test"] == "paired_t" and m.get("anova"):
            a = m["anova"]
            stat += f"; F(1, {a['df2']}) = {_fmt(a['F'])}, ηp² = {_fmt(a['partial_eta_sq'], 3)}"
        ci = m.get("cohens_d_ci95") or [None, None]
        lines.append(
            f"| {name} | {m['n']} | {_fmt(m['mean_cc'])} ({_fmt(m['sd_cc'])}) | "
            f"{_fmt(m['mean_ec'])} ({_fmt(m['sd_ec'])}) | {'yes' if m['normal'] else 'no'}"
            f"{' (n small)' if m.get('normality_underpowered') else ''} | {m['test']} | "
            f"{stat} | {_p(m['p'])} | {_p(m.get('p_adjusted'))} | "
            f"{_fmt(m['cohens_d'])} [{_fmt(ci[0])}, {_fmt(ci[1])}] | "
            f"{m['effect_label'] or '–'} |"
        )
    mssq = analysis["mssq"]
    lines += [
        "",
        f"MSSQ-short (n = {mssq['n']}): total mean {_fmt(mssq['total']['mean'])} "
        f"(SD {_fmt(mssq['total']['sd'])}), median {_fmt(mssq['total']['median'])}.",
        "",
    ]
    lines += [f"![{f}]({f})" for f in figures if f.endswith(".png")]
    return "\n".join(lines) + "\n"


def write_report(
    data: StudyData,
    out_dir: Path,
    analysis_config: AnalysisConfig | None = None,
    design_config: DesignConfig | None = None,
    progress: Callable[[str], None] | None = None,
    sessions: Sequence[Mapping[str, Any]] | None = None,
) -> list[Path]:
    """Write figures (PNG + SVG), tables (CSV), the whole analysis (JSON) and report.md into ``out_dir``."""
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the report folder {out_dir}: {exc}") from exc
    say = progress or (lambda _m: None)
    analysis = analyse(data, analysis_config)
    design = design_summary(data, design_config or DesignConfig())
    written: list[Path] = []

    def put(name: str, content: str | bytes) -> None:
        path = out_dir / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")
        written.append(path)
        say(f"  wrote {path}")

    figures = []
    for group in GROUPS:
        for fmt in FORMATS:
            name = f"{group}.{fmt}"
            put(name, study_figure(data, analysis, group, fmt))
            figures.append(name)
    put("measures.csv", to_csv(measure_rows(analysis), MEASURE_COLUMNS))
    put("responses_long.csv", export_csv(data))
    if sessions is not None:  # each session's summary (run time, time without a navigator, alarms)
        put("sessions.csv", to_csv(sessions, SESSION_COLUMNS))
    put(
        "completeness.csv",
        to_csv(
            [
                {
                    **c,
                    "missing": "; ".join(
                        f"{m['instrument']} {m['phase'] or ''} (session {m['session_id']})"
                        for m in c["missing"]
                    ),
                    "missing_conditions": " ".join(c["missing_conditions"]),
                }
                for c in design["completeness"]
            ],
            ("participant_id", "code", "sessions", "missing_conditions", "missing", "complete"),
        ),
    )
    put("analysis.json", json.dumps({"analysis": analysis, "design": design}, indent=2))
    put("report.md", markdown_report(analysis, design, figures))
    log.info("study report with %d measures written to %s", len(MEASURES), out_dir)
    return written
