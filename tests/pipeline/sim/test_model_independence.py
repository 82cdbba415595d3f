"""The motion models written without reading the product (blind3 to blind7) depend on nothing of it:
their modules import only numpy, scipy, the standard library, ``pipeline.errors`` and their own
package, and importing them loads no app code and no other motion model."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
# each model: its package's name and modules that must be there (one of them loaded on import)
MODELS = {
    "blind3": ({"__init__.py", "__main__.py", "api.py", "check.py", "model.py"}, "model"),
    "blind4": ({"__init__.py", "__main__.py", "sequence.py", "check.py", "com.py"}, "com"),
    "blind5": ({"__init__.py", "__main__.py", "script.py", "check.py", "skeleton.py"}, "skeleton"),
    "blind6": ({"__init__.py", "__main__.py", "script.py", "check.py", "oscillators.py"}, "oscillators"),
    "blind7": ({"__init__.py", "__main__.py", "check.py", "behaviours.py", "body.py", "timeline.py"}, "body"),
}


def _imports(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path.name}: relative import"
            assert node.module is not None
            names.add(node.module)
    return names


def _is_allowed(model: str, module: str) -> bool:
    top = module.split(".")[0]
    own = f"pipeline.sim.{model}"
    if module in {"pipeline.errors", own} or module.startswith(own + "."):
        return True
    return top != "pipeline" and (top in sys.stdlib_module_names or top in {"numpy", "scipy"})


@pytest.mark.parametrize("model", sorted(MODELS))
def test_the_package_imports_only_numpy_scipy_the_stdlib_and_itself(model: str) -> None:
    files = sorted((REPO / "pipeline" / "sim" / model).glob("*.py"))
    assert {p.name for p in files} >= MODELS[model][0]
    for path in files:
        bad = sorted(m for m in _imports(path) if not _is_allowed(model, m))
        assert not bad, f"{model}/{path.name} imports {bad}"


@pytest.mark.parametrize("model", sorted(MODELS))
def test_importing_the_package_loads_no_app_and_no_other_motion_model(model: str) -> None:
    pkg = f"pipeline.sim.{model}"
    code = f"import sys, {pkg}, {pkg}.__main__, {pkg}.check; print('\\n'.join(sorted(sys.modules)))"
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    loaded = r.stdout.split()
    assert f"{pkg}.{MODELS[model][1]}" in loaded
    assert not [m for m in loaded if m == "app" or m.startswith("app.")]
    ours = [m for m in loaded if m == "pipeline" or m.startswith("pipeline.")]
    shared = {"pipeline", "pipeline.sim", "pipeline.errors"}
    others = [m for m in ours if m not in shared and not _is_allowed(model, m)]
    assert not others, f"importing {model} loads {others}"
