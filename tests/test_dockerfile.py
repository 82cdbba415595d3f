"""The Dockerfile cannot be built here (no Docker engine); check it by reading."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _stages(text: str) -> dict[str, list[str]]:
    stages: dict[str, list[str]] = {}
    current = None
    joined = re.sub(r"\\\n\s*", " ", text)
    for line in joined.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if m := re.match(r"FROM\s+\S+\s+AS\s+(\w+)", line, re.IGNORECASE):
            current = m.group(1)
            stages[current] = []
        elif current is not None:
            stages[current].append(line)
    return stages


def test_two_stages_model_export_then_slim_runtime() -> None:
    stages = _stages((ROOT / "Dockerfile").read_text())
    assert list(stages) == ["models", "runtime"], f"stages: {list(stages)}"
    models = " ".join(stages["models"])
    runtime = " ".join(stages["runtime"])
    assert "cavewalk models prepare" in models
    assert ".[models]" in models
    assert "torch" not in runtime and "[models]" not in runtime, "torch must stay out of the final image"
    assert "COPY --from=models /models /models" in runtime
    assert re.search(r'CMD \["cavewalk", "serve", "--host", "0\.0\.0\.0"', runtime)


def test_every_copied_path_exists() -> None:
    for stage, lines in _stages((ROOT / "Dockerfile").read_text()).items():
        for line in lines:
            if not line.startswith("COPY") or "--from=" in line:
                continue
            *sources, _dest = line.split()[1:]
            for src in sources:
                assert (ROOT / src).exists(), f"stage {stage}: COPY source {src} is missing"
