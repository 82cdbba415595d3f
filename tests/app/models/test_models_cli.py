"""``cavewalk models list|register|activate|rollback`` on a real database (issue 18 item 5)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.app.models.onnx_files import three_class_model, with_metadata


def cavewalk(*args: str) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "app.cli", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def test_register_activate_roll_back_and_refuse_from_the_command_line(tmp_path: Path) -> None:
    db = str(tmp_path / "c.db")
    r = cavewalk("models", "list", "--db", db)
    assert r.returncode == 0 and r.stdout.count("\n") == 1 and "*   1  base" in r.stdout, r.stdout + r.stderr

    bad = three_class_model(tmp_path / "three.onnx")
    r = cavewalk("models", "register", str(bad), "--db", db)
    assert r.returncode == 2 and r.stderr.startswith("error:") and "one output" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr

    model = with_metadata(tmp_path / "m.onnx", note="cli")
    card = tmp_path / "m.json"
    card.write_text(json.dumps({"window": 48}))
    r = cavewalk("models", "register", str(model), "--card", str(card), "--db", db)
    assert r.returncode == 2 and "card does not match" in r.stderr and "window" in r.stderr, r.stderr
    assert cavewalk("models", "list", "--db", db).stdout.count("\n") == 1, "a refused model registers nothing"

    card.write_text(json.dumps({"window": 32, "note": "cli"}))
    r = cavewalk("models", "register", str(model), "--card", str(card), "--activate", "--db", db)
    assert r.returncode == 0 and r.stdout.startswith("*   2  uploaded"), r.stdout + r.stderr
    r = cavewalk("models", "rollback", "--db", db)
    assert r.returncode == 0 and r.stdout.startswith("*   1  base"), r.stdout + r.stderr
    r = cavewalk("models", "activate", "7", "--db", db)
    assert r.returncode == 2 and "model 7 not found" in r.stderr, r.stderr
    listed = cavewalk("models", "list", "--db", db).stdout.splitlines()
    assert [line[:1] for line in listed] == ["*", " "], listed
