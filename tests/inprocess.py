"""A command line run in the test's own process: for the many refusals a test checks, without an
interpreter's start for each (one real ``python -m`` call per command line stays in its tests)."""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import io
import subprocess
import sys


def run_main(module: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``python -m module args...`` in this process: the module's (or its package's ``__main__``'s)
    ``main(argv)`` with stdout and stderr captured, its exit code from the return value or
    ``SystemExit`` (no interpreter start)."""
    spec = importlib.util.find_spec(module)
    target = f"{module}.__main__" if spec is not None and spec.submodule_search_locations else module
    main = importlib.import_module(target).main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:
            code = exc.code
    if not isinstance(code, int):
        code = 0 if code is None else 1
    return subprocess.CompletedProcess(
        [sys.executable, "-m", module, *args], code, out.getvalue(), err.getvalue()
    )
