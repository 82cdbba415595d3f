"""Building the runtime's ``Pipeline`` from the settings (pipeline/ never imports app/)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from sqlalchemy.orm import Session

from app.core.config import Settings
from app.services.live import PipelineFacade

log = logging.getLogger(__name__)


def runtime_factory(
    settings: Settings, session_factory: Callable[[], Session]
) -> tuple[Callable[[], PipelineFacade] | None, str]:
    """(a function that builds the pipeline, "") or (None, why it cannot be built)."""
    try:
        import pipeline.runtime as runtime
    except ImportError as exc:
        return None, f"pipeline.runtime cannot be imported: {exc}"
    pipeline_cls: Any = getattr(runtime, "Pipeline", None)
    if pipeline_cls is None:
        return None, "pipeline.runtime has no Pipeline yet"

    def build() -> PipelineFacade:
        raise NotImplementedError

    return build, ""
