"""Navigation modes through the API (issue 20 item 1) on the real app and runtime: the simulator with
three stepping people, served by uvicorn; the status shows each person's command, the session log
records each person's command changes, and bad requests change nothing."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.app.conftest import Served, make_settings
from tests.waiting import HTTP_TIMEOUT_S, wait_until

pytestmark = pytest.mark.slow

http = httpx.Client(timeout=HTTP_TIMEOUT_S)


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    s = make_settings(Path(tmp_path_factory.mktemp("navigation")))
    settings = s.model_copy(update={"sim": replace(s.sim, people=3, bystanders=0)})
    with Served(settings) as srv:
        yield srv


def navigating(status: dict[str, Any]) -> list[int]:
    return sorted(p["user_id"] for p in status["people"] if p["navigating"])


def test_each_and_group_modes_and_bad_requests(served: Served) -> None:
    base = f"{served.base}/api/v1"
    pid = http.post(f"{base}/participants", json={"code": "NAV1"}).json()["id"]
    sid = http.post(f"{base}/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
    assert http.post(f"{base}/sessions/{sid}/start").status_code == 200
    served.wait_status(lambda s: len(s["people"]) == 3 and s["running_session_id"] == sid)

    r = http.put(f"{base}/navigator", json={"mode": "each"})
    assert r.status_code == 200, r.text
    assert r.json()["navigation"] == "each" and r.json()["user_ids"] == []
    st = served.wait_status(lambda s: s["navigation"]["mode"] == "each" and len(navigating(s)) == 3)
    for p in st["people"]:
        assert p["command"]["label"] in ("still", "forward", "left", "right"), p
        assert 0.0 <= p["command"]["confidence"] <= 1.0
    assert http.get(f"{base}/navigator").json()["navigation"] == "each"

    for body, code, match in [
        ({"mode": "crowd"}, 422, "literal_error"),
        ({"mode": "each", "user_ids": [1, 1]}, 422, "distinct"),
        ({"mode": "group", "user_id": 2}, 422, "user_ids"),
        ({"mode": "auto", "user_ids": [1]}, 422, "user_ids"),
        ({"mode": "group", "user_ids": [987654]}, 404, "987654"),
    ]:
        r = http.put(f"{base}/navigator", json=body)
        assert r.status_code == code and match in r.text, (body, r.status_code, r.text)
    after = served.wait_status(lambda s: True)
    assert after["navigation"]["mode"] == "each", "a rejected request leaves the mode as it was"

    def choose_two() -> list[int] | None:  # a person seen may be lost before the request lands
        ids = [p["user_id"] for p in served.wait_status(lambda s: len(s["people"]) == 3)["people"]][:2]
        r = http.put(f"{base}/navigator", json={"mode": "group", "user_ids": ids})
        return sorted(ids) if r.status_code == 200 else None

    two = wait_until(choose_two, "two tracked people chosen as the group")
    def grouped(s: dict[str, Any]) -> bool:  # both chosen people tracked in the same status
        g = s["navigation"]["group"]
        return s["navigation"]["mode"] == "group" and bool(g) and g["members"] == two

    st = served.wait_status(grouped)
    group = st["navigation"]["group"]
    assert group["members"] == two and sum(group["votes"].values()) == 2, group
    assert group["label"] in ("still", "forward", "left", "right")
    assert navigating(st) == two, "only the chosen people navigate"

    assert http.put(f"{base}/navigator", json={"mode": "auto"}).status_code == 200
    served.wait_status(lambda s: s["navigation"]["mode"] == "single")

    def logged() -> list[dict[str, Any]] | None:  # the event log is written in batches
        events = http.get(f"{base}/sessions/{sid}/events").json()
        own = [e["payload"] for e in events if e["kind"] == "action" and e["payload"].get("mode") == "each"]
        return own if len({p["user_id"] for p in own}) >= 2 else None

    own = wait_until(logged, "each person's command changes in the session's log")
    assert all(p["user_id"] is not None and "label" in p and "previous" in p for p in own), own
    events = http.get(f"{base}/sessions/{sid}/events").json()
    modes = [e["payload"].get("mode") for e in events if e["kind"] == "navigator"]
    assert "each" in modes and "group" in modes, f"the mode changes are in the log: {modes}"
    assert http.post(f"{base}/sessions/{sid}/stop").status_code == 200
