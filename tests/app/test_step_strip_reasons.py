"""Every reason the stepping-bout gate can give has words and a colour on the dashboard's step strip
(frontend/js/panels/steps.js, frontend/css/steps.css), so an operator can read why the command is
what it is; the browser test (tests/e2e/test_step_strip.py) shows the strip live."""

from __future__ import annotations

import re
from pathlib import Path

from pipeline.recognition.bout import REASONS

FRONTEND = Path(__file__).resolve().parents[2] / "frontend"


def test_every_gate_reason_has_words_and_a_colour() -> None:
    js = (FRONTEND / "js" / "panels" / "steps.js").read_text(encoding="utf-8")
    block = re.search(r"const REASON_TEXT = \{(.*?)\n\};", js, re.S)
    assert block is not None, "REASON_TEXT not found in steps.js"
    keys = set(re.findall(r'^\s*"?([a-z-]+)"?\s*:', block.group(1), re.M))
    css = (FRONTEND / "css" / "steps.css").read_text(encoding="utf-8")
    coloured = set(re.findall(r"\.tick\.gate\.([a-z-]+)", css))
    assert set(REASONS) <= keys, f"no words for {sorted(set(REASONS) - keys)}"
    assert set(REASONS) <= coloured, f"no colour for {sorted(set(REASONS) - coloured)}"
