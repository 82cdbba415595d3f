"""Building the runtime's ``Pipeline`` from the settings (pipeline/ never imports app/)."""

from __future__ import annotations

import logging
from collections.abc import Callable

from sqlalchemy.orm import Session

from app.core.config import Settings
from app.db.repositories import active_calibration_run
from app.services.live import PipelineFacade

log = logging.getLogger(__name__)


def simulator_factory(settings: Settings) -> object | None:
    """The simulator source of the settings (None when the simulator is not installed)."""
    try:
        from pipeline.runtime import SimWorldFactory

        return SimWorldFactory.from_settings(settings.sim, settings.cave.geometry())
    except ImportError as exc:
        log.warning("no simulator source: %s", exc)
        return None


def runtime_factory(
    settings: Settings, session_factory: Callable[[], Session]
) -> tuple[Callable[[], PipelineFacade] | None, str]:
    """(a function that builds the pipeline, "") or (None, why it cannot be built).

    The pipeline gets the active calibration's cameras (for the real cameras and videos)
    and the simulator's own cameras for the simulator source.
    """
    try:
        from pipeline.runtime import Pipeline
    except ImportError as exc:
        return None, f"pipeline.runtime cannot be imported: {exc}"

    def build() -> PipelineFacade:
        from app.services.calibration import cameras_from_result

        with session_factory() as db:
            run = active_calibration_run(db)
            cameras = cameras_from_result(run.result) if run is not None and run.result else None
        sim = simulator_factory(settings)
        pipeline: PipelineFacade = Pipeline.from_settings(settings, cameras, sim_factory=sim)  # type: ignore[arg-type]
        return pipeline

    return build, ""
