"""Bad command lines and bad files through the real entry point ``app.cli.main``: each ends with
exactly one ``error:`` line on stderr and a non-zero exit, never a traceback (issue 15: 0
tracebacks across 62 bad invocations held; usage errors were rich boxes, not one line).

Runs in this process (sixty interpreters would take minutes on two cores); an exception that
escaped ``main`` would fail the test with its traceback, which is what a user would have seen.
"""

from __future__ import annotations

import json
import logging
import sqlite3
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.core.config import set_settings


def run_cli(args: list[str], monkeypatch: pytest.MonkeyPatch) -> int:
    root = logging.getLogger()

    def drop_handlers() -> None:
        for h in [h for h in root.handlers if getattr(h, "_cavewalk", False)]:
            root.removeHandler(h)

    drop_handlers()
    monkeypatch.setattr(sys, "argv", ["cavewalk", *args])
    try:
        main()
    except SystemExit as exc:
        return int(exc.code or 0) if not isinstance(exc.code, str) else 1
    finally:
        drop_handlers()
        set_settings(None)
    return 0


def files(tmp: Path) -> dict[str, Path]:
    """Bad and good inputs: a text file, a folder, an empty file, NPZs of the wrong kinds."""
    out = {
        "text": tmp / "notes.txt", "folder": tmp / "folder", "empty": tmp / "empty.npz",
        "textnpz": tmp / "text.npz", "objnpz": tmp / "obj.npz", "shapenpz": tmp / "shape.npz",
        "nofps": tmp / "nofps.npz", "badtoml": tmp / "bad.toml", "keytoml": tmp / "key.toml",
        "tomlfolder": tmp / "cfg.toml", "json": tmp / "layout.json", "foreign": tmp / "foreign.db",
    }
    out["text"].write_text("these are notes\n" * 50)
    out["folder"].mkdir()
    out["empty"].write_bytes(b"")
    out["textnpz"].write_text("joints,fps\n1,2\n")
    np.savez(out["objnpz"], joints=np.array([{"a": 1}], dtype=object), fps=30.0)
    np.savez(out["shapenpz"], joints=np.zeros((10, 5, 3)), fps=30.0)
    np.savez(out["nofps"], joints=np.zeros((10, 17, 3)))
    out["badtoml"].write_text("[server\nport = 1\n")
    out["keytoml"].write_text("[server]\nprot = 8000\n")
    out["tomlfolder"].mkdir()
    out["json"].write_text(json.dumps({"dictionary": "DICT_4X4_250", "markers": "nope"}))
    con = sqlite3.connect(out["foreign"])
    con.execute("create table t (x)")
    con.commit()
    con.close()
    return out


P = Callable[[dict[str, Path]], list[str]]
#: (name, args(files) -> argv, a word the error line must hold)
CASES: list[tuple[str, P, str]] = [
    ("no such option", lambda f: ["--bogus"], "--bogus"),
    ("no such command", lambda f: ["nosuch"], "nosuch"),
    ("config missing", lambda f: ["--config", str(f["text"].with_name("none.toml")), "config", "show"],
     "not found"),
    ("config folder", lambda f: ["--config", str(f["tomlfolder"]), "config", "show"], "folder"),
    ("config syntax", lambda f: ["--config", str(f["badtoml"]), "config", "show"], "bad.toml"),
    ("config key", lambda f: ["--config", str(f["keytoml"]), "config", "show"], "prot"),
    ("config text", lambda f: ["--config", str(f["text"]), "config", "show"], "notes.txt"),
    ("config show option", lambda f: ["config", "show", "--yaml"], "--yaml"),
    ("models option", lambda f: ["models", "prepare", "--bogus"], "--bogus"),
    ("data no such", lambda f: ["data", "nosuch"], "nosuch"),
    ("process no calibration", lambda f: ["process", "--video", "cam01=x.mp4", "--out", "o.jsonl"],
     "--calibration"),
    ("process no equals", lambda f: ["process", "--video", "cam01", "--calibration", str(f["text"]),
                                     "--out", "o.jsonl"], "NAME=PATH"),
    ("process missing video", lambda f: ["process", "--video", f"cam01={f['folder'] / 'x.mp4'}",
                                         "--calibration", str(f["text"]), "--out", "o.jsonl"], "calibration"),
    ("process frames 0", lambda f: ["process", "--video", "a=b", "--calibration", "c", "--out", "o",
                                    "--frames", "0"], "--frames"),
    ("process frames text", lambda f: ["process", "--video", "a=b", "--calibration", "c", "--out", "o",
                                       "--frames", "many"], "--frames"),
    ("process calibration folder", lambda f: ["process", "--video", "cam01=x.mp4", "--calibration",
                                              str(f["folder"]), "--out", "o.jsonl"], "folder"),
    ("recognize missing", lambda f: ["recognize", "--skeletons", str(f["folder"] / "no.npz"), "--out", "o"],
     "not found"),
    ("recognize text npz", lambda f: ["recognize", "--skeletons", str(f["textnpz"]), "--out", "o"],
     "not an NPZ"),
    ("recognize text file", lambda f: ["recognize", "--skeletons", str(f["text"]), "--out", "o"],
     "not an NPZ"),
    ("recognize empty", lambda f: ["recognize", "--skeletons", str(f["empty"]), "--out", "o"], "not an NPZ"),
    ("recognize folder", lambda f: ["recognize", "--skeletons", str(f["folder"]), "--out", "o"], "folder"),
    ("recognize object npz", lambda f: ["recognize", "--skeletons", str(f["objnpz"]), "--out", "o"],
     "obj.npz"),
    ("recognize shape", lambda f: ["recognize", "--skeletons", str(f["shapenpz"]), "--out", "o"], "17"),
    ("recognize no fps", lambda f: ["recognize", "--skeletons", str(f["nofps"]), "--out", "o"], "fps"),
    ("recognize model text", lambda f: ["recognize", "--skeletons", str(f["nofps"]), "--out", "o",
                                        "--model", str(f["text"])], "nofps.npz"),
    ("evaluate text npz", lambda f: ["evaluate", "--skeletons", str(f["textnpz"])], "not an NPZ"),
    ("evaluate missing", lambda f: ["evaluate", "--skeletons", str(f["folder"] / "x.npz")], "not found"),
    ("evaluate no labels", lambda f: ["evaluate", "--skeletons", str(f["nofps"])], "nofps.npz"),
    ("calibrate no image", lambda f: ["calibrate", "--out", "c.json"], "--image"),
    ("calibrate image no equals", lambda f: ["calibrate", "--image", "front", "--out", "c.json"],
     "NAME=PATH"),
    ("calibrate missing image", lambda f: ["calibrate", "--image", f"cam01={f['folder'] / 'x.png'}",
                                           "--out", "c.json"], "x.png"),
    ("calibrate text image", lambda f: ["calibrate", "--image", f"cam01={f['text']}", "--out", "c.json"],
     "notes.txt"),
    ("calibrate bad layout", lambda f: ["calibrate", "--layout", str(f["json"]), "--image",
                                        f"cam01={f['text']}", "--out", "c.json"], "layout.json"),
    ("calibrate layout text", lambda f: ["calibrate", "--layout", str(f["text"]), "--image",
                                         f"cam01={f['text']}", "--out", "c.json"], "notes.txt"),
    ("calibration pattern layout", lambda f: ["calibration", "pattern", "--layout", str(f["text"]),
                                              "--wall", "front", "--out", str(f["folder"])], "notes.txt"),
    ("calibration no such", lambda f: ["calibration", "nosuch"], "nosuch"),
    ("serve port 0", lambda f: ["serve", "--port", "0"], "--port"),
    ("serve port big", lambda f: ["serve", "--port", "70000"], "--port"),
    ("serve port text", lambda f: ["serve", "--port", "http"], "--port"),
    ("serve viser port", lambda f: ["serve", "--viser-port", "-1"], "--viser-port"),
    ("serve emit", lambda f: ["serve", "--emit", "nohostport", "--db", str(f["folder"] / "a.db")], "--emit"),
    ("serve emit port", lambda f: ["serve", "--emit", "ws:99999", "--db", str(f["folder"] / "a.db")],
     "65535"),
    ("serve db folder", lambda f: ["serve", "--db", str(f["folder"])], "folder"),
    ("serve db text", lambda f: ["serve", "--db", str(f["text"])], "not a database"),
    ("serve db foreign", lambda f: ["serve", "--db", str(f["foreign"])], "not a cavewalk database"),
    ("serve config folder", lambda f: ["serve", "--config", str(f["tomlfolder"])], "folder"),
    ("demo people", lambda f: ["demo", "--people", "-3", "--db", str(f["folder"] / "a.db")], "--people"),
    ("demo option", lambda f: ["demo", "--bogus"], "--bogus"),
    ("receive no port", lambda f: ["receive"], "--port"),
    ("receive port text", lambda f: ["receive", "--port", "abc"], "--port"),
    ("receive count text", lambda f: ["receive", "--port", "9", "--count", "x"], "--count"),
    ("bench duration text", lambda f: ["bench", "--duration", "long"], "--duration"),
    ("simulate no out", lambda f: ["simulate"], "--out"),
    ("simulate script missing", lambda f: ["simulate", "--out", str(f["folder"] / "s.npz"), "--script",
                                           str(f["folder"] / "none.json")], "none.json"),
    ("simulate script text", lambda f: ["simulate", "--out", str(f["folder"] / "s.npz"), "--script",
                                        str(f["text"])], "notes.txt"),
    ("simulate fps text", lambda f: ["simulate", "--out", "s.npz", "--fps", "fast"], "--fps"),
    ("study report db missing", lambda f: ["study", "report", "--out", str(f["folder"] / "r"), "--db",
                                           str(f["folder"] / "none.db")], "not found"),
    ("study report db text", lambda f: ["study", "report", "--out", str(f["folder"] / "r"), "--db",
                                        str(f["text"])], "notes.txt"),
    ("study report db foreign", lambda f: ["study", "report", "--out", str(f["folder"] / "r"), "--db",
                                           str(f["foreign"])], "foreign.db"),
    ("study no such", lambda f: ["study", "nosuch"], "nosuch"),
    ("verbose value", lambda f: ["--verbose=yes", "config", "show"], "verbose"),
    ("plan cameras 0", lambda f: ["plan", "--cameras", "0", "--out", str(f["folder"] / "p")], "--cameras"),
    ("plan calibration missing", lambda f: ["plan", "--calibration", str(f["folder"] / "none.json"),
                                            "--out", str(f["folder"] / "p")], "none.json"),
]


def test_there_are_sixty_cases() -> None:
    assert len(CASES) >= 60 and len({c[0] for c in CASES}) == len(CASES)


@pytest.mark.parametrize(("name", "make", "word"), CASES, ids=[c[0] for c in CASES])
def test_a_bad_invocation_is_one_error_line_and_a_non_zero_exit(
    name: str, make: P, word: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    f = files(tmp_path)
    before = {p: (p.read_bytes() if p.is_file() else None) for p in f.values()}
    rc = run_cli(make(f), monkeypatch)
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert rc != 0, f"{name}: exit status 0\n{err}"
    assert len(errors) == 1, f"{name}: expected one error line, got:\n{err}"
    assert word.lower() in err.lower(), f"{name}: {err!r} does not mention {word!r}"
    assert "Traceback" not in err and "╭" not in err, f"{name}: {err}"
    after = {p: (p.read_bytes() if p.is_file() else None) for p in f.values()}
    assert after == before, f"{name}: a rejected command changed an input file"
