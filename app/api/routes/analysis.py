"""The study analysis: tests per measure, figures (PNG/SVG), the whole analysis as JSON, CSV export."""

from __future__ import annotations

from dataclasses import replace
from datetime import UTC, datetime
from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Query, Response, status
from fastapi import Path as PathParam
from fastapi.responses import JSONResponse

from app.api.deps import SessionDep, SettingsDep
from app.core.config import Settings
from app.db.models import StudySession
from app.schemas.study import AnalysisPublic
from app.study.analysis import AnalysisConfig, analyse
from app.study.data import load_events, load_study
from app.study.design import design_summary
from app.study.figures import FORMATS, GROUPS, study_figure, timeline_figure
from app.study.report import export_csv, to_csv
from app.study.summary import SESSION_COLUMNS, session_rows

router = APIRouter(tags=["analysis"])

_IMAGE_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {"content": {mime: {} for mime in FORMATS.values()}, "description": "The figure."},
    404: {"description": "Unknown figure, format or session."},
}


def _format(ext: str) -> str:
    if ext not in FORMATS:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"unknown figure format {ext!r}; use one of {list(FORMATS)}"
        )
    return ext


CorrectionQuery = Annotated[
    Literal["holm", "bonferroni", "none"] | None,
    Query(description="Multiple-comparison correction (default: settings study.analysis.correction, Holm)."),
]


def _analysis_config(settings: Settings, correction: str | None) -> AnalysisConfig:
    """The settings' analysis, with the correction a request asks for."""
    return replace(settings.study.analysis, correction=correction) if correction else settings.study.analysis


@router.get("/analysis", response_model=AnalysisPublic)
def get_analysis(db: SessionDep, settings: SettingsDep, correction: CorrectionQuery = None) -> dict[str, Any]:
    """Per measure: descriptives per condition, Shapiro-Wilk, the chosen paired test, Cohen's d_z with its
    exact CI, and the p-values corrected for multiple comparisons (Holm by default)."""
    return analyse(load_study(db), _analysis_config(settings, correction))


@router.get("/analysis.json")
def get_analysis_json(db: SessionDep, settings: SettingsDep) -> JSONResponse:
    """The whole analysis and the design summary as a downloadable JSON file."""
    data = load_study(db)
    body = {
        "generated_at": datetime.now(UTC).isoformat(),
        "analysis": analyse(data, settings.study.analysis),
        "design": design_summary(data, settings.study.design),
    }
    return JSONResponse(
        body, headers={"Content-Disposition": 'attachment; filename="cavewalk-analysis.json"'}
    )


@router.get("/analysis/figures/{name}.{ext}", response_class=Response, responses=_IMAGE_RESPONSES)
def get_figure(name: str, ext: str, db: SessionDep, settings: SettingsDep) -> Response:
    """The paper's bar chart for ``ssq``, ``ipq`` or ``tlx`` as ``png`` or ``svg``."""
    fmt = _format(ext)
    if name not in GROUPS:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"unknown figure {name!r}; use one of {list(GROUPS)}")
    data = load_study(db)
    analysis = analyse(data, settings.study.analysis)
    return Response(study_figure(data, analysis, name, fmt), media_type=FORMATS[fmt])


@router.get(
    "/analysis/sessions/{session_id}/timeline.{ext}", response_class=Response, responses=_IMAGE_RESPONSES
)
def get_timeline(
    session_id: Annotated[int, PathParam(ge=1, le=2**63 - 1)], ext: str, db: SessionDep
) -> Response:
    """The session's recognised actions over time (from its ``action`` events)."""
    fmt = _format(ext)
    session = db.get(StudySession, session_id)
    if session is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"study session {session_id} not found")
    events = load_events(db, session_id, kind="action")
    title = f"session {session_id} ({session.condition}): actions over time"
    return Response(timeline_figure(events, title, fmt), media_type=FORMATS[fmt])


@router.get(
    "/export/sessions.csv",
    response_class=Response,
    responses={200: {"content": {"text/csv": {}}, "description": "One row per session: its summary."}},
)
def get_sessions_export(db: SessionDep) -> Response:
    """Every session's summary: run time, time without a navigator, locomotion alarms and gaps,
    navigator changes, seconds per action, questionnaires and corrections."""
    return Response(
        to_csv(session_rows(db), SESSION_COLUMNS),
        media_type="text/csv; charset=utf-8",
        headers={"Content-Disposition": 'attachment; filename="cavewalk-sessions.csv"'},
    )


@router.get(
    "/export.csv",
    response_class=Response,
    responses={200: {"content": {"text/csv": {}}, "description": "Long format, one row per item."}},
)
def get_export(db: SessionDep) -> Response:
    """Every questionnaire in long format: one row per participant x session x item (then scores)."""
    return Response(
        export_csv(load_study(db)),
        media_type="text/csv; charset=utf-8",
        headers={"Content-Disposition": 'attachment; filename="cavewalk-study.csv"'},
    )
