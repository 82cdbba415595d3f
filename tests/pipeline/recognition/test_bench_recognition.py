"""scripts/bench_recognition.py: what it reports (the layout and the machine, not how fast it is)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "bench_recognition.py"
sys.path.insert(0, str(SCRIPT.parent))
import bench_recognition  # noqa: E402


@pytest.mark.slow
def test_the_bench_reports_update_with_and_without_the_model_and_names_the_machine(tmp_path: Path) -> None:
    out = tmp_path / "bench.json"
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--frames", "90", "--calls", "20", "--json", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    got = json.loads(out.read_text())
    assert got["frames"] == 90 and got["gate"] is True and got["features"] in ("v1", "v2", "v3")
    timings = {"update", "update_cpu", "update_without_model", "model", "features", "step_evidence"}
    assert {k.removesuffix("_ms") for k in got if k.endswith("_ms")} == timings
    for key in (f"{t}_ms" for t in timings):
        s = got[key]
        assert 0 < s["median"] <= s["p95"] <= s["p99"] <= s["max"], (key, s)
    # each frame's time without its model call is at most the frame's time: so is every quantile
    for q in ("median", "p95", "p99", "max"):
        assert got["update_without_model_ms"][q] <= got["update_ms"][q]
    machine = got["machine"]
    assert machine["cpu_model"] and isinstance(machine["extensions"], list) and machine["logical_cores"] >= 1
    assert got["cpu"].startswith(machine["cpu_model"]) and "onnxruntime" in got["cpu"]
    assert got["cpu"] in done.stdout, "the machine is printed with the figures"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--frames", "0"], "--frames, --threads and --calls must be at least 1, got 0, 1, 1000"),
        (["--threads", "0"], "must be at least 1, got 3000, 0, 1000"),
        (["--calls", "-5"], "must be at least 1, got 3000, 1, -5"),
        (["--model", "/nonexistent.onnx"], "no model file /nonexistent.onnx"),
    ],
)
def test_bad_arguments_are_one_error_line_and_write_nothing(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    words: str,
) -> None:
    out = tmp_path / "bench.json"
    monkeypatch.setattr(sys, "argv", ["bench_recognition.py", *args, "--json", str(out)])
    with pytest.raises(SystemExit) as done:
        bench_recognition.main()
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert done.value.code == 2 and "error: " in last and last.endswith(words), last
    assert not out.exists()
