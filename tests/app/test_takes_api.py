"""Takes through the real app: the simulator pipeline on a real socket, a real SQLite file, real files."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest

from pipeline.takes.files import check_files, sha256_of
from pipeline.takes.protocol import frame_labels, label_spans, load_protocol, parse_protocol_text
from tests.app.conftest import Served, make_settings

pytestmark = pytest.mark.slow

PROTOCOL = """
name = "short"
steps = ["still 2 s", "forward 3 s", "crouch 1 s (label still)"]
"""


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    settings = make_settings(Path(tmp_path_factory.mktemp("takes")))
    with Served(settings) as s:
        s.wait_status(lambda st: st["state"] == "running" and st["navigator"] is not None, 60)
        yield s


def wait_take(base: str, take_id: int, timeout_s: float = 40) -> dict:
    deadline = time.monotonic() + timeout_s
    row: dict = {}
    while time.monotonic() < deadline:
        row = httpx.get(f"{base}/takes/{take_id}").json()
        if row["status"] != "recording":
            return row
        time.sleep(0.2)
    raise AssertionError(f"take never finished: {row}")


def test_a_protocol_take_from_the_simulator_is_written_indexed_and_labelled(served: Served) -> None:
    base = f"{served.base}/api/v1"
    r = httpx.post(
        f"{base}/takes", json={"participant_code": "P07", "protocol_toml": PROTOCOL, "margin_s": 0.4}
    )
    assert r.status_code == 201, r.text
    take = r.json()
    assert take["status"] == "recording" and take["protocol"] == "short" and take["source"] == "simulator"
    cur = httpx.get(f"{base}/takes/current").json()
    assert cur["recording"] and cur["take_id"] == take["id"]
    # the prompt is the protocol's step at the take's elapsed time
    proto = parse_protocol_text(PROTOCOL)
    p = cur["prompt"]
    step = proto.steps[p["index"]]
    assert (p["label"], p["text"], p["steps"]) == (step.label, step.text, 3), cur
    step_end = proto.starts_s()[p["index"]] + step.duration_s
    assert abs(cur["elapsed_s"] + p["remaining_s"] - step_end) < 0.05, cur
    # a second take while one records: 409, nothing new stored
    assert httpx.post(f"{base}/takes", json={"duration_s": 2}).status_code == 409
    done = wait_take(base, take["id"])
    assert done["status"] == "complete", done
    # the newest frame's time: frames at 6 s or later are not written, and the manifest rounds to 1 ms
    # (a frame at 5.9996 s reads 6.0); the lower bound is loose: 2 shared cores
    assert 4.5 <= done["duration_s"] <= 6.0 and done["frames"] >= 5, done
    folder = Path(served.settings.paths.db.parent / "takes" / done["uid"])
    assert {"frames.jsonl", "skeletons.npz", "labels.csv", "calibration.json"} <= set(done["files"])
    assert check_files(folder) == []
    for name, info in done["files"].items():
        assert sha256_of(folder / name) == info["sha256"], name
    manifest = json.loads((folder / "take.json").read_text())
    assert manifest["complete"] is True and manifest["participant_code"] == "P07"
    assert "token" not in manifest["settings"]["server"] and manifest["model"]["sha256"]
    active = httpx.get(f"{base}/models/active").json()  # the registry's model the pipeline runs
    assert manifest["model"]["registry_id"] == active["id"]
    assert manifest["model"]["sha256"] == active["sha256"]
    lines = [json.loads(x) for x in (folder / "frames.jsonl").read_text().splitlines()]
    assert {"frame", "t", "ts", "views", "people3d", "navigator", "action"} <= set(lines[0])
    assert lines[0]["views"] and lines[0]["views"][0]["camera"] == "cam01"
    assert all(0 <= x["t"] < 6.0 for x in lines) and [x["t"] for x in lines] == sorted(x["t"] for x in lines)
    with np.load(folder / "skeletons.npz") as npz:
        uid = int(npz["user_id"])
        assert npz[f"joints_{uid}"].shape == (len(lines), 17, 3)
        labels = npz[f"labels_{uid}"].tolist()
        nav = npz["navigator"].tolist()
        t = npz["t"].tolist()
    expected = frame_labels(t, label_spans(parse_protocol_text(PROTOCOL), 0.4))
    assert [lab if n == uid else "ignore" for lab, n in zip(expected, nav, strict=True)] == labels
    assert "forward" in labels and "still" in labels, labels
    in_margin = [lab for lab, x, n in zip(labels, t, nav, strict=True) if 2.0 <= x < 2.4 and n == uid]
    assert set(in_margin) <= {"ignore"}, "the reaction margin after still -> forward"
    # the file route serves the listed files only
    got = httpx.get(f"{base}/takes/{take['id']}/files/labels.csv")
    assert got.status_code == 200 and got.content == (folder / "labels.csv").read_bytes()
    assert httpx.get(f"{base}/takes/{take['id']}/files/../cavewalk.db").status_code == 404


@pytest.mark.parametrize(
    ("body", "status", "match"),
    [
        ({"protocol": "no-such-protocol"}, 422, "unknown protocol"),
        ({"protocol_toml": 'name = "x"\nsteps = ["jump 3 s"]'}, 422, "unknown label 'jump'"),
        ({"protocol_toml": 'name = "x"\nsteps = ["still 3 s (label hop)"]'}, 422, "unknown label 'hop'"),
        ({"protocol_toml": "name = [", "margin_s": 0.5}, 422, "not valid TOML"),
        ({"protocol": "four-actions", "margin_s": 9}, 422, "margin_s must be"),
        ({"protocol": "four-actions", "margin_s": -1}, 422, "margin_s must be"),
        ({"duration_s": 3, "session_id": 999}, 404, "session 999 not found"),
        ({}, 422, "needs a duration_s or a protocol"),
        ({"duration_s": 3, "videos": True}, 409, "the simulator source has no camera images"),
    ],
)
def test_bad_take_requests_are_refused_and_store_nothing(
    served: Served, body: dict, status: int, match: str
) -> None:
    base = f"{served.base}/api/v1"
    before = httpx.get(f"{base}/takes").json()
    folder = served.settings.paths.db.parent / "takes"
    files_before = sorted(folder.iterdir()) if folder.is_dir() else []
    r = httpx.post(f"{base}/takes", json=body)
    assert r.status_code == status and match in r.json()["detail"], r.text
    assert httpx.get(f"{base}/takes").json() == before
    assert (sorted(folder.iterdir()) if folder.is_dir() else []) == files_before


def test_unknown_take_ids_are_404(served: Served) -> None:
    base = f"{served.base}/api/v1"
    for r in (
        httpx.get(f"{base}/takes/4242"),
        httpx.post(f"{base}/takes/4242/stop"),
        httpx.get(f"{base}/takes/4242/files/take.json"),
    ):
        assert r.status_code == 404 and "4242" in r.json()["detail"], r.text


def test_a_take_stopped_early_is_complete_and_a_stopped_take_cannot_stop_again(served: Served) -> None:
    base = f"{served.base}/api/v1"
    take = httpx.post(f"{base}/takes", json={"duration_s": 60, "participant_code": "P08"}).json()
    time.sleep(1.0)
    r = httpx.post(f"{base}/takes/{take['id']}/stop")
    assert r.status_code == 200 and r.json()["status"] == "complete", r.text
    assert 0.5 < r.json()["duration_s"] < 5 and "labels.csv" not in r.json()["files"]
    again = httpx.post(f"{base}/takes/{take['id']}/stop")
    assert again.status_code == 409 and "not recording" in again.json()["detail"]
    assert [t["uid"] for t in httpx.get(f"{base}/takes", params={"participant_code": "P08"}).json()] == [
        take["uid"]
    ]


def test_shipped_protocols_parse_and_are_listed(served: Served) -> None:
    got = {p["file"]: p for p in httpx.get(f"{served.base}/api/v1/protocols").json()}
    assert {"four-actions", "no-intent", "teach"} <= set(got)
    assert {s["label"] for s in got["four-actions"]["steps"]} == {"still", "forward", "left", "right"}
    assert {s["label"] for s in got["no-intent"]["steps"]} <= {"still", "forward"}
    assert got["teach"]["duration_s"] == 60
    assert load_protocol(Path("protocols/no-intent.toml")).steps[1].tag == "look-around"


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_labels_are_edited_in_place_and_bad_edits_change_nothing(served: Served) -> None:
    base = f"{served.base}/api/v1"
    take = httpx.post(f"{base}/takes", json={"protocol_toml": PROTOCOL, "duration_s": 4}).json()
    done = wait_take(base, take["id"])
    folder = served.settings.paths.db.parent / "takes" / done["uid"]
    got = httpx.get(f"{base}/takes/{take['id']}/labels").json()
    spans = got["spans"]
    assert [s["label"] for s in spans] == ["still", "ignore", "forward"], spans
    assert spans[-1]["t_end"] <= done["duration_s"] + 0.5, "the protocol's spans end with the take"
    before = _snapshot(folder)
    bad = [
        ([{**spans[0], "label": "hop"}], 422, "unknown label 'hop'"),
        ([{**spans[0], "t_end": 999}], 422, "past the take's end"),
        ([{**spans[0], "t_start": 2, "t_end": 1}], 422, "t_start < t_end"),
        ([{**spans[0], "colour": "red"}], 422, "colour"),
    ]
    for body, status, match in bad:
        r = httpx.put(f"{base}/takes/{take['id']}/labels", json={"spans": body})
        assert r.status_code == status and match in r.text, r.text
    r = httpx.put(f"{base}/takes/4242/labels", json={"spans": spans})
    assert r.status_code == 404 and "4242" in r.json()["detail"]
    assert _snapshot(folder) == before, "a refused edit changes no file"
    # relabel the forward span as left and move the boundary after the margin to 2.8 s
    edited = [dict(s) for s in spans]
    edited[1]["t_end"] = edited[2]["t_start"] = 2.8
    edited[2]["label"] = "left"
    r = httpx.put(f"{base}/takes/{take['id']}/labels", json={"spans": edited})
    assert r.status_code == 200, r.text
    assert check_files(folder) == [], "the checksums follow the edit"
    row = httpx.get(f"{base}/takes/{take['id']}").json()
    assert row["files"]["labels.csv"]["sha256"] == sha256_of(folder / "labels.csv")
    with np.load(folder / "skeletons.npz") as npz:
        uid = int(npz["user_id"])
        t, labels, nav = npz["t"], npz[f"labels_{uid}"], npz["navigator"]
    mine = nav == uid
    assert set(labels[mine & (t >= 2.8)].tolist()) <= {"left"} and "forward" not in labels.tolist()
    assert set(labels[mine & (t >= 2.0) & (t < 2.8)].tolist()) <= {"ignore"}
