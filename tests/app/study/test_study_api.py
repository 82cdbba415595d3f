"""The study endpoints through HTTP against the real app and a real SQLite file, and the report command."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from app.study.questionnaires import DEFINITIONS, SSQ_KEYS, TLX_PAIRS, TLX_SCALES
from tests.app.test_cli_errors import run_cli

API = "/api/v1"
IPQ_KEYS = [i.key for i in DEFINITIONS["ipq"].items]
MSSQ_KEYS = [i.key for i in DEFINITIONS["mssq"].items]
# SSQ with every symptom at k: each subscale sums 7 items -> total = 21 k x 3.74.
SSQ_TOTAL_PER_LEVEL = 21 * 3.74


def post(c: TestClient, path: str, body: dict[str, Any], expect: int = 201) -> dict[str, Any]:
    r = c.post(API + path, json=body)
    assert r.status_code == expect, r.text
    return r.json()  # type: ignore[no-any-return]


def submit(
    c: TestClient, session_id: int, instrument: str, phase: str | None, answers: dict[str, Any], **kw: Any
) -> None:
    post(
        c,
        f"/sessions/{session_id}/questionnaires",
        {"instrument": instrument, "phase": phase, "answers": answers, **kw},
    )


def run_session(
    c: TestClient, participant_id: int, condition: str, ssq_pre: int, ssq_post: int, sp: int, tlx: int
) -> int:
    sid = post(c, "/sessions", {"participant_id": participant_id, "condition": condition})["id"]
    submit(c, sid, "ssq", "pre", dict.fromkeys(SSQ_KEYS, ssq_pre))
    post(c, f"/sessions/{sid}/start", {}, expect=200)
    post(c, f"/sessions/{sid}/stop", {}, expect=200)
    submit(c, sid, "ssq", "post", dict.fromkeys(SSQ_KEYS, ssq_post))
    submit(c, sid, "ipq", "post", {k: (sp if k.startswith("SP") and k != "SP2" else 3) for k in IPQ_KEYS})
    submit(
        c,
        sid,
        "nasa_tlx",
        "post",
        {s: tlx for s in TLX_SCALES},
        pairwise={f"{a}_vs_{b}": a for a, b in TLX_PAIRS},
    )
    return int(sid)


# (code, CC: ssq pre, post, SP item, tlx) , (EC: ...). EC has less sickness, more presence.
PLAN = [
    ("P01", (0, 2, 2, 40), (0, 1, 5, 60)),
    ("P02", (1, 3, 3, 45), (0, 1, 6, 55)),
    ("P03", (0, 2, 1, 50), (1, 1, 4, 65)),
    ("P04", (0, 3, 2, 35), (0, 0, 5, 50)),
    ("P05", (1, 2, 3, 55), (1, 1, 6, 70)),
]


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    """The real app on one SQLite file for the module, with the study below (built once)."""
    from app.core.config import load_settings
    from app.main import create_app

    base = load_settings()
    settings = base.model_copy(
        update={
            "paths": base.paths.model_copy(update={"db": tmp_path_factory.mktemp("study") / "cavewalk.db"}),
            "server": base.server.model_copy(update={"viser": False, "allowed_hosts": ["testserver"]}),
        }
    )
    with TestClient(create_app(settings, pipeline_factory=None)) as client:
        populate(client)
        yield client


def populate(client: TestClient) -> None:
    """Five complete participants (both conditions) and P06 with the first session only."""
    for code, cc, ec in PLAN:
        p = post(client, "/participants", {"code": code})
        first = p["first_condition"]
        plans = {"CC": cc, "EC": ec}
        for cond in (first, "EC" if first == "CC" else "CC"):
            run_session(client, p["id"], cond, *plans[cond])
        submit(client, run_session_id(client, p["id"]), "mssq", "pre", dict.fromkeys(MSSQ_KEYS, 1))
    p6 = post(client, "/participants", {"code": "P06"})
    run_session(client, p6["id"], p6["first_condition"], 0, 1, 3, 40)


def run_session_id(c: TestClient, participant_id: int) -> int:
    return int(c.get(f"{API}/participants/{participant_id}/sessions").json()[0]["id"])


def test_analysis_endpoint(study: TestClient) -> None:
    r = study.get(f"{API}/analysis")
    assert r.status_code == 200, r.text
    a = r.json()
    assert a["participants"] == 6 and a["excluded"] == ["P06"]
    ssq = a["measures"]["ssq_total_post"]
    assert ssq["n"] == 5
    cc_post = [cc[1] * SSQ_TOTAL_PER_LEVEL for _, cc, _ in PLAN]
    ec_post = [ec[1] * SSQ_TOTAL_PER_LEVEL for _, _, ec in PLAN]
    assert ssq["mean_cc"] == pytest.approx(sum(cc_post) / 5) and ssq["mean_ec"] == pytest.approx(
        sum(ec_post) / 5
    )
    assert ssq["test"] in ("paired_t", "wilcoxon") and 0 <= ssq["p"] <= 1
    delta = a["measures"]["ssq_total_delta"]
    expected = sum((cc[1] - cc[0]) for _, cc, _ in PLAN) / 5 * SSQ_TOTAL_PER_LEVEL
    assert delta["mean_cc"] == pytest.approx(expected)
    tlx = a["measures"]["tlx_raw"]
    assert tlx["mean_ec"] == pytest.approx(sum(ec[3] for _, _, ec in PLAN) / 5)
    assert set(a["measures"]) >= {"ipq_SP", "tlx_frustration", "ssq_disorientation_post"}
    assert a["mssq"]["n"] == 5 and a["mssq"]["total"]["mean"] == pytest.approx(18.0), "all 1s: 9 + 9"


def test_analysis_json_download(study: TestClient) -> None:
    r = study.get(f"{API}/analysis.json")
    assert r.status_code == 200 and "attachment" in r.headers["content-disposition"]
    body = r.json()
    assert body["analysis"]["measures"]["ipq_SP"]["n"] == 5 and "completeness" in body["design"]


@pytest.mark.parametrize("name", ["ssq", "ipq", "tlx"])
def test_figures(study: TestClient, name: str) -> None:
    png = study.get(f"{API}/analysis/figures/{name}.png")
    assert png.status_code == 200 and png.headers["content-type"] == "image/png"
    assert png.content.startswith(b"\x89PNG\r\n\x1a\n") and len(png.content) > 5000
    svg = study.get(f"{API}/analysis/figures/{name}.svg")
    assert svg.status_code == 200 and svg.headers["content-type"].startswith("image/svg+xml")
    assert b"<svg" in svg.content[:2000]


@pytest.mark.parametrize(
    "path", ["/analysis/figures/sus.png", "/analysis/figures/ssq.gif", "/analysis/sessions/999/timeline.png"]
)
def test_unknown_figures_are_404(client: TestClient, path: str) -> None:
    assert client.get(API + path).status_code == 404


@pytest.mark.parametrize("session_id", ["0", "-3", "99999999999999999999999", "abc"])
def test_bad_session_ids_are_422(client: TestClient, session_id: str) -> None:
    assert client.get(f"{API}/analysis/sessions/{session_id}/timeline.png").status_code == 422


def test_figures_with_an_empty_database(client: TestClient) -> None:
    r = client.get(f"{API}/analysis/figures/tlx.png")
    assert r.status_code == 200 and r.content.startswith(b"\x89PNG")
    a = client.get(f"{API}/analysis").json()
    assert a["participants"] == 0 and a["measures"]["tlx_raw"]["test"] is None


def test_timeline_from_action_events(study: TestClient) -> None:
    from app.db.models import Event

    sid = run_session_id(study, 1)
    with study.app.state.session_factory() as db:  # type: ignore[attr-defined]
        labels = ["still", "forward", "forward", "left", "still", "right"]
        db.add_all(
            Event(session_id=sid, ts=1000.0 + i, kind="action", payload={"label": lab})
            for i, lab in enumerate(labels)
        )
        db.commit()
    r = study.get(f"{API}/analysis/sessions/{sid}/timeline.png")
    assert r.status_code == 200 and r.content.startswith(b"\x89PNG")
    assert study.get(f"{API}/analysis/sessions/{sid}/timeline.svg").status_code == 200


def test_export_csv_long_format(study: TestClient) -> None:
    r = study.get(f"{API}/export.csv")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    rows = list(csv.DictReader(io.StringIO(r.text)))
    answers = [x for x in rows if x["kind"] == "answer"]
    # per complete participant: 2 sessions x (2 SSQ x 16 + 14 IPQ + 6 TLX) + 18 MSSQ; P06: 1 session.
    per_session = 2 * 16 + 14 + 6
    assert len(answers) == 5 * (2 * per_session + 18) + per_session
    assert len([x for x in rows if x["kind"] == "pairwise"]) == 11 * 15
    one = [
        x
        for x in answers
        if x["participant_code"] == "P02" and x["instrument"] == "ssq" and x["phase"] == "post"
    ]
    assert len(one) == 32 and {x["condition"] for x in one} == {"CC", "EC"}
    assert {x["item"] for x in one} == set(SSQ_KEYS)
    assert {x["value"] for x in one if x["condition"] == "CC"} == {"3"}


def test_instruments_endpoint(client: TestClient) -> None:
    defs = client.get(f"{API}/questionnaires/instruments").json()
    assert set(defs) == {"ssq", "mssq", "ipq", "nasa_tlx"}
    assert [i["key"] for i in defs["ssq"]["items"]] == list(SSQ_KEYS)


def test_design_endpoints(study: TestClient) -> None:
    d = study.get(f"{API}/study/design").json()
    assert d["participants"] == 6 and d["balanced"] is True
    # Both sessions of each participant were run seconds apart: one gap warning each for P01-P05.
    assert sorted(w["code"] for w in d["gap_warnings"]) == ["P01", "P02", "P03", "P04", "P05"]
    assert study.get(f"{API}/study/warnings").json() == d["gap_warnings"]
    comp = {c["code"]: c for c in study.get(f"{API}/study/completeness").json()}
    assert comp["P01"]["complete"] is True
    p6_first = next(p for p in study.get(f"{API}/participants").json() if p["code"] == "P06")[
        "first_condition"
    ]
    assert comp["P06"]["missing_conditions"] == ["EC" if p6_first == "CC" else "CC"]
    assert {m["instrument"] for m in comp["P06"]["missing"]} == {"mssq"}
    order = study.get(f"{API}/study/order", params={"n": 20}).json()
    assert len(order) == 20 and sum(o["order"] == ["CC", "EC"] for o in order) == 10
    assert study.get(f"{API}/study/order", params={"n": 0}).status_code == 422


BAD_SUBMISSIONS = [
    ("ssq", "pre", {**dict.fromkeys(SSQ_KEYS, 0), "vertigo": 5}, "vertigo"),
    ("ssq", "pre", {k: 0 for k in SSQ_KEYS if k != "fatigue"}, "fatigue"),
    ("ssq", "pre", {**dict.fromkeys(SSQ_KEYS, 0), "itch": 1}, "itch"),
    ("ssq", None, dict.fromkeys(SSQ_KEYS, 0), "phase"),
    ("ipq", "post", {**dict.fromkeys(IPQ_KEYS, 3), "REAL2": 9}, "REAL2"),
    ("mssq", None, {**dict.fromkeys(MSSQ_KEYS, 1), "adult_ships": "sometimes"}, "adult_ships"),
]


@pytest.mark.parametrize(("instrument", "phase", "answers", "item"), BAD_SUBMISSIONS)
def test_bad_submission_is_422_and_stores_nothing(
    study: TestClient, instrument: str, phase: str | None, answers: dict[str, Any], item: str
) -> None:
    before = study.get(f"{API}/export.csv").text
    r = study.post(
        f"{API}/sessions/1/questionnaires",
        json={"instrument": instrument, "phase": phase, "answers": answers},
    )
    assert r.status_code == 422 and (item in r.json().get("items", []) or item in r.text), r.text
    assert study.get(f"{API}/export.csv").text == before, "a rejected sheet leaves the stored data unchanged"


@pytest.mark.slow
def test_report_command(study: TestClient, tmp_path: Path) -> None:
    from app.cli import cli

    db = study.app.state.settings.paths.db  # type: ignore[attr-defined]
    out = tmp_path / "report"
    result = CliRunner().invoke(cli, ["study", "report", "--out", str(out), "--db", str(db)])
    assert result.exit_code == 0, result.output
    names = {p.name for p in out.iterdir()}
    assert {
        "ssq.png",
        "ssq.svg",
        "ipq.png",
        "tlx.svg",
        "measures.csv",
        "responses_long.csv",
        "sessions.csv",
        "analysis.json",
        "report.md",
    } <= names
    md = (out / "report.md").read_text()
    assert "ssq_total_post" in md and "P06" in md and "![ssq.png](ssq.png)" in md
    measures = list(csv.DictReader((out / "measures.csv").open()))
    assert len(measures) == 17 and measures[0]["measure"] == "ssq_total_post" and measures[0]["n"] == "5"
    assert json.loads((out / "analysis.json").read_text())["analysis"]["excluded"] == ["P06"]
    sessions = list(csv.DictReader((out / "sessions.csv").open()))
    assert len(sessions) == 11 and {r["participant_code"] for r in sessions} == {c for c, *_ in PLAN} | {
        "P06"
    }


def test_sessions_csv_carries_each_sessions_summary(study: TestClient) -> None:
    r = study.get(f"{API}/export/sessions.csv")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv"), r.text
    rows = list(csv.DictReader(io.StringIO(r.text)))
    assert len(rows) == 11, "5 participants x 2 sessions + P06's first"
    for row in rows:
        summary = study.get(f"{API}/sessions/{row['session_id']}/summary").json()
        assert row["status"] == summary["status"] == "stopped"
        assert float(row["duration_s"]) == summary["duration_s"] and summary["duration_s"] >= 0
        assert float(row["without_navigator_s"]) == summary["without_navigator_s"], "no pipeline: all of it"
        assert int(row["questionnaires"]) == summary["questionnaires"] >= 4
        assert row["condition"] in ("CC", "EC") and row["started_at"]
        held = row["condition"] == "CC"  # a controller session holds navigation while it runs
        assert float(row["held_s"]) == summary["held_s"] <= summary["duration_s"]
        assert int(row["holds"]) == summary["holds"] == int(held), (row, summary)


def _bad_db(tmp_path: Path, kind: str) -> Path:
    db = tmp_path / "x.db"
    if kind == "not_sqlite":
        db.write_text("hello")
    elif kind == "not_cavewalk":
        import sqlite3

        con = sqlite3.connect(db)
        con.execute("create table t (x)")
        con.commit()
        con.close()
    return db


@pytest.mark.parametrize(
    ("kind", "match"),
    [
        ("missing", "database not found"),
        ("not_sqlite", "not an SQLite database"),
        ("not_cavewalk", "not a cavewalk"),
    ],
)
def test_report_command_bad_database(tmp_path: Path, kind: str, match: str) -> None:
    from app.cli import cli
    from pipeline.errors import CavewalkError

    db = _bad_db(tmp_path, kind)
    before = db.read_bytes() if db.exists() else None
    result = CliRunner().invoke(cli, ["study", "report", "--out", str(tmp_path / "o"), "--db", str(db)])
    assert isinstance(result.exception, CavewalkError) and match in str(result.exception)
    assert (db.read_bytes() if db.exists() else None) == before, "a rejected database is left unchanged"
    assert not (tmp_path / "o").exists(), "nothing is written for a rejected database"


def test_report_command_bad_database_exit_code(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """Through the real entry point app.cli.main, in this process (an interpreter costs ~3 s of imports;
    an exception escaping main() fails the test): one line on stderr, exit status 2, no traceback."""
    db = _bad_db(tmp_path, "not_sqlite")
    code = run_cli(["study", "report", "--out", str(tmp_path), "--db", str(db)], monkeypatch)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.strip().splitlines()[-1].startswith("error: ") and "Traceback" not in err
