"""The hold kept beside the database (app.services.live.PipelineService's hold_file)."""

from __future__ import annotations

from pathlib import Path

from app.services.event_log import EventWriter
from app.services.live import HOLD_FILE, PipelineService


def service(hold_file: Path) -> PipelineService:
    return PipelineService(None, EventWriter(lambda: None), hold_file=hold_file)  # type: ignore[arg-type,return-value]


def test_the_hold_is_kept_and_read_back_and_an_unreadable_file_holds(tmp_path: Path) -> None:
    kept = tmp_path / HOLD_FILE
    first = service(kept)
    assert not first.held and not first.snapshot()["held"]
    assert first.set_held(True) and kept.read_text() == "held\n"
    again = service(kept)
    assert again.held and again.snapshot()["held"], "a new server process holds"
    assert not again.set_held(True), "already held: nothing changes"
    assert again.set_held(False) and not kept.exists()
    assert not service(kept).held
    kept.write_text("released?\n")
    assert not service(kept).held, "only the word the server writes holds"
    kept.unlink()
    kept.mkdir()  # cannot be read as a file: held, and said in the log
    assert service(kept).held
