"""Calibration from the dashboard: wall patterns, a run on the simulator's wall images, history, roll back."""

from __future__ import annotations

import time
from typing import Any

import cv2
import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient

from pipeline.calibration.patterns import make_layout
from pipeline.sim.scene import default_cameras
from tests.waiting import wait_until

#: CPU seconds of this process (the app runs in it, under TestClient) a run may use: about 5 on an
#: idle machine (rendering four 1920 x 1080 wall views, solving, the overlays)
RUN_CPU_BUDGET_S = 120.0


def wait_run(c: httpx.Client, run_id: int) -> dict[str, Any]:
    """The run once it is done or failed (``c``: a TestClient, or an httpx client of a served app).

    Rendering the four cameras' wall images and solving is CPU work: seconds on an idle machine,
    many minutes of wall time at load 20-30 on two cores (issue 15 S3: a 60 s deadline saw it
    still at 0.05, "showing the patterns"). So its budget is counted on a clock the test controls,
    the CPU time this process gets, not the wall clock; the wall-clock limit only ends a hung run."""
    cpu0 = time.process_time()

    def finished() -> dict[str, Any] | None:
        run: dict[str, Any] = c.get(f"/api/v1/calibration/runs/{run_id}").json()
        if run["status"] in ("done", "failed"):
            return run
        used = time.process_time() - cpu0
        assert used < RUN_CPU_BUDGET_S, f"run {run_id} used {used:.0f} CPU seconds and is still at {run}"
        return None

    return wait_until(finished, f"calibration run {run_id} to finish", timeout_s=800, poll_s=0.5)


def test_wall_patterns_are_served_and_decode_to_the_layout_ids(client: TestClient) -> None:
    settings = client.app.state.settings
    assert client.get("/api/v1/calibration/walls").json() == ["front", "right", "back", "left"]
    layout = make_layout(settings.cave.geometry())
    r = client.get("/api/v1/calibration/patterns/right.png")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    img = cv2.imdecode(np.frombuffer(r.content, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert img.shape[::-1] == settings.cave.wall_resolution_px
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250))
    _corners, ids, _rejected = detector.detectMarkers(img)
    assert ids is not None
    assert sorted(ids.ravel().tolist()) == sorted(m.id for m in layout.on_wall("right"))
    r = client.get("/api/v1/calibration/patterns/ceiling.png")
    assert r.status_code == 404 and "ceiling" in r.json()["detail"]


def test_no_active_calibration_and_unknown_runs(client: TestClient) -> None:
    assert client.get("/api/v1/calibration/runs").json() == []
    assert client.get("/api/v1/status").json()["active_calibration_id"] is None
    r = client.get("/api/v1/calibration/active")
    assert r.status_code == 404 and "no calibration" in r.json()["detail"]
    assert client.get("/api/v1/calibration/runs/5").status_code == 404
    r = client.post("/api/v1/calibration/runs/5/activate")
    assert r.status_code == 404 and "run 5" in r.json()["detail"]
    assert client.get("/api/v1/calibration/runs").json() == [], "rejected requests store nothing"


@pytest.mark.slow
@pytest.mark.timeout(1200)  # the runs' own limit is their CPU budget (wait_run)
def test_calibration_run_on_the_simulator_then_roll_back(client: TestClient) -> None:
    r = client.post("/api/v1/calibration/runs")
    assert r.status_code == 202, r.text
    first = r.json()["id"]
    run = wait_run(client, first)
    assert run["status"] == "done", run["message"]
    assert not run["active"] and run["progress"] == 1.0, "a finished run waits for the operator's accept"
    assert client.get("/api/v1/status").json()["active_calibration_id"] is None
    cmp = client.get(f"/api/v1/calibration/runs/{first}/compare").json()
    assert cmp["active_id"] is None and all(c["active"] is None for c in cmp["cameras"])
    assert client.post(f"/api/v1/calibration/runs/{first}/activate").json()["active"]
    truth = {c.name: c for c in default_cameras(client.app.state.settings.cave.geometry())}
    assert [c["name"] for c in run["cameras"]] == sorted(truth)
    for cam in run["cameras"]:
        assert cam["rms_px"] < 1.0, cam
        assert cam["verdict"] in ("good", "fair"), cam
        assert len(cam["walls_seen"]) >= 2, cam
    for stored in run["result"]["cameras"]:  # the poses are the simulator's cameras, in the SPEC JSON form
        true = truth[stored["name"]]
        centre = -np.asarray(stored["R"]).T @ np.asarray(stored["t"])
        true_centre = -true.R.T @ true.t
        assert np.linalg.norm(centre - true_centre) < 0.02, (stored["name"], centre, true_centre)
    png = client.get(f"/api/v1/calibration/runs/{first}/overlays/cam02.png")
    assert png.status_code == 200 and png.content[:8] == b"\x89PNG\r\n\x1a\n"
    assert client.get(f"/api/v1/calibration/runs/{first}/overlays/cam99.png").status_code == 404

    second = client.post("/api/v1/calibration/runs").json()["id"]
    assert wait_run(client, second)["status"] == "done"
    cmp = client.get(f"/api/v1/calibration/runs/{second}/compare").json()
    assert cmp["active_id"] == first and len(cmp["cameras"]) == 4
    for cam in cmp["cameras"]:  # the same virtual cameras: side by side, they agree
        assert cam["active"]["rms_px"] is not None and cam["new"]["rms_px"] is not None
        assert cam["moved_m"] < 0.02 and cam["turned_deg"] < 0.5, cam
    assert client.get("/api/v1/status").json()["active_calibration_id"] == first, "not before it is accepted"
    client.post(f"/api/v1/calibration/runs/{second}/activate")
    history = client.get("/api/v1/calibration/runs").json()
    assert [(h["id"], h["active"]) for h in history] == [(second, True), (first, False)]
    assert client.get("/api/v1/status").json()["active_calibration_id"] == second
    rolled = client.post(f"/api/v1/calibration/runs/{first}/activate").json()
    assert rolled["active"] and client.get("/api/v1/calibration/active").json()["id"] == first
    assert [h["active"] for h in client.get("/api/v1/calibration/runs").json()] == [False, True]
    client.app.state.events.flush()
    kinds = [e.payload.get("state") for e in _calibration_events(client)]
    assert kinds.count("done") == 2 and "activated" in kinds and "patterns" in kinds


def _calibration_events(client: TestClient) -> list[Any]:
    from app.db.repositories import list_events

    with client.app.state.session_factory() as db:
        return list(list_events(db, kind="calibration"))
