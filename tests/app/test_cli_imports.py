"""``cavewalk --help`` and every command's start must feel instant: starting the command line loads
none of the heavy packages (the web app, the database, scipy, the pose and action models, OpenCV).

Each command imports those where it uses them (``app/commands/*.py``), and the settings take every
stage's config from its light ``config`` module. Checked in a fresh interpreter, by the modules
loaded rather than by the time taken (machines are noisy): a new top-level import of any of them
anywhere on the way fails here, with the chain that pulled it named by ``python -X importtime``.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("fastapi", "sqlalchemy", "scipy", "torch", "onnxruntime", "cv2", "uvicorn")
REPORT = f"sorted(m for m in {HEAVY!r} if m in sys.modules)"


def _heavy_loaded(code: str, tmp_path: Path) -> list[str]:
    """The heavy packages loaded once ``code`` ran in a fresh interpreter (its last stdout line)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("CAVEWALK_CONFIG", None)
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, f"the interpreter failed: {proc.stderr[-2000:]}"
    last = proc.stdout.strip().splitlines()[-1]
    return list(ast.literal_eval(last))  # the list REPORT printed


def test_importing_the_command_line_loads_no_heavy_package(tmp_path: Path) -> None:
    loaded = _heavy_loaded(f"import app.cli, sys; print({REPORT})", tmp_path)
    assert loaded == [], (
        f"`import app.cli` loaded {loaded}; import them inside the command that needs them "
        "(see `python -X importtime -c 'import app.cli'` for who pulled them in)"
    )


@pytest.mark.parametrize("args", [["--help"], ["receive", "--help"], ["config", "show"]])
def test_a_help_or_a_light_command_loads_no_heavy_package(args: list[str], tmp_path: Path) -> None:
    # `receive --help` and `config show` run the root callback too: logging and the settings
    code = (
        "import sys\n"
        "from app.cli import main\n"
        f"sys.argv = ['cavewalk', *{args!r}]\n"
        "try:\n"
        "    main()\n"
        "except SystemExit as exc:\n"
        "    assert not exc.code, exc.code\n"
        f"print({REPORT})\n"
    )
    loaded = _heavy_loaded(code, tmp_path)
    assert loaded == [], f"`cavewalk {' '.join(args)}` loaded {loaded}"
