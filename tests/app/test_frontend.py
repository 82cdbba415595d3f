"""The dashboard's static files are served at / and every ES module import resolves."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import urljoin

from fastapi.testclient import TestClient

FRONTEND = Path(__file__).resolve().parents[2] / "frontend"
IMPORT = re.compile(
    r"""(?:^|\n)\s*import\s+(?:[^'"]+\s+from\s+)?["']([^"']+)["']|import\(\s*["']([^"']+)["']\s*\)"""
)


def test_index_has_every_panel_and_docs_are_served(client: TestClient) -> None:
    html = client.get("/").text
    for panel in ("action-panel", "people-panel", "latency-panel", "cameras-panel", "viewer-panel",
                  "calibration-panel", "planner-panel", "study-panel", "questionnaire-panel",
                  "analysis-panel"):  # fmt: skip
        assert f'id="{panel}"' in html, panel
    page = client.get("/participant.html").text
    assert 'src="js/participant.js"' in page and "pipeline-start" not in page, "no operator controls"
    assert client.get("/docs").status_code == 200
    assert client.get("/openapi.json").json()["info"]["title"] == "cavewalk"


def test_every_module_import_resolves(client: TestClient) -> None:
    seen: set[str] = set()
    # the entry points: the dashboard, the participant page, the participant's prompt page (takes)
    todo = ["/js/main.js", "/js/participant.js", "/js/prompt.js"]
    while todo:
        url = todo.pop()
        if url in seen:
            continue
        seen.add(url)
        r = client.get(url)
        assert r.status_code == 200, f"{url} is not served"
        assert "javascript" in r.headers["content-type"], url
        for m in IMPORT.finditer(r.text):
            target = m.group(1) or m.group(2)
            if target.startswith("."):
                todo.append(urljoin(url, target))
    expected = {"/" + p.relative_to(FRONTEND).as_posix() for p in (FRONTEND / "js").rglob("*.js")}
    assert seen == expected, f"modules never imported: {expected - seen}; missing: {seen - expected}"
