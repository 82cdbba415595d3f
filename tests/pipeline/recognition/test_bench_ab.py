"""scripts/bench_ab.py: two checkouts' recognisers timed in turns over the same frames (the pairing
and the report, not how fast this machine is)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts" / "bench_ab.py"


def _slowed_checkout(tmp: Path) -> Path:
    """A copy of this checkout's pipeline whose recogniser waits 3 ms more per update()."""
    other = tmp / "slow"
    shutil.copytree(ROOT / "pipeline", other / "pipeline", ignore=shutil.ignore_patterns("__pycache__"))
    recognizer = other / "pipeline" / "recognition" / "recognizer.py"
    text = recognizer.read_text()
    marker = '        """Add one skeleton (17, 3) metres'
    assert marker in text
    head, tail = text.split(marker, 1)
    body_start = tail.index('"""', 3) + 3  # after the docstring
    slowed = (
        head + marker + tail[:body_start] + "\n        __import__('time').sleep(0.003)" + tail[body_start:]
    )
    recognizer.write_text(slowed)
    return other


@pytest.mark.slow
def test_a_checkout_that_waits_3_ms_more_per_frame_is_measured_so(tmp_path: Path) -> None:
    baseline = _slowed_checkout(tmp_path)
    out = tmp_path / "ab.json"
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--baseline", str(baseline), "--frames", "150", "--passes", "1",
         "--json", str(out)],
        capture_output=True, text=True, check=False, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    got = json.loads(out.read_text())
    assert got["frames"] == 150 and got["passes"] == 1 and got["chunk"] == 30
    assert got["baseline"] == str(baseline.resolve()) and got["this"] == str(ROOT)
    # the baseline sleeps 3 ms in every update(): this checkout is the faster side in every frame
    assert got["baseline_ms"]["median"] >= got["this_ms"]["median"] + 2.9, got
    assert got["per_frame_ratio"]["p75"] < 1.0 and got["ratio_of_medians"] < 1.0, got
    assert 0 < got["this_ms"]["median"] <= got["this_ms"]["p95"]
    assert got["machine"]["cpu_model"] and got["cpu"] in done.stdout, (
        "the machine is printed with the figures"
    )


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--frames", "0"], "--frames, --chunk and --passes must be at least 1, got 0, 30, 3"),
        (["--chunk", "0"], "must be at least 1, got 1800, 0, 3"),
        (
            ["--baseline", "/nonexistent"],
            "/nonexistent is not a cavewalk checkout with a model (pipeline/recognition/action.onnx missing)",
        ),
    ],
)
def test_bad_arguments_are_one_error_line_and_write_nothing(
    tmp_path: Path, args: list[str], words: str
) -> None:
    out = tmp_path / "ab.json"
    base = [] if "--baseline" in args else ["--baseline", str(ROOT)]
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *base, *args, "--json", str(out)],
        capture_output=True, text=True, check=False, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("bench_ab.py: error: ") and last.endswith(words), done.stderr
    assert not out.exists()
