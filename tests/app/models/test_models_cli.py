"""``cavewalk models list|register|activate|rollback`` on a real database, through the real entry point
(``app.cli.main``, in this process) (issue 18 item 5)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.app.models.cli import run
from tests.app.models.onnx_files import three_class_model, with_metadata


def test_register_activate_roll_back_and_refuse_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def cavewalk(*args: str) -> tuple[int, str, str]:
        return run(capsys, monkeypatch, *args)

    db = str(tmp_path / "c.db")
    code, out, err = cavewalk("models", "list", "--db", db)
    assert code == 0 and out.count("\n") == 1 and "*   1  base" in out, out + err

    bad = three_class_model(tmp_path / "three.onnx")
    code, out, err = cavewalk("models", "register", str(bad), "--db", db)
    assert code == 2 and err.startswith("error:") and "one output" in err, err

    model = with_metadata(tmp_path / "m.onnx", note="cli")
    card = tmp_path / "m.json"
    card.write_text(json.dumps({"window": 48}))
    code, out, err = cavewalk("models", "register", str(model), "--card", str(card), "--db", db)
    assert code == 2 and "card does not match" in err and "window" in err, err
    assert cavewalk("models", "list", "--db", db)[1].count("\n") == 1, "a refused model registers nothing"

    card.write_text(json.dumps({"window": 32, "note": "cli"}))
    code, out, err = cavewalk("models", "register", str(model), "--card", str(card), "--activate", "--db", db)
    assert code == 0 and out.startswith("*   2  uploaded"), out + err
    code, out, err = cavewalk("models", "rollback", "--db", db)
    assert code == 0 and out.startswith("*   1  base"), out + err
    code, out, err = cavewalk("models", "activate", "7", "--db", db)
    assert code == 2 and "model 7 not found" in err, err
    listed = cavewalk("models", "list", "--db", db)[1].splitlines()
    assert [line[:1] for line in listed] == ["*", " "], listed
