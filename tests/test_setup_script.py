"""``apt_install`` of scripts/setup.sh (scripts/lib/apt.sh) as root, as a user with sudo, and
as a user without it (issue 15 S1).

Stand-in ``apt-get``, ``dpkg`` and ``sudo`` on PATH record how they were called (argv, the
uid they ran as, DEBIAN_FRONTEND): a test never installs real packages. PATH holds only
those stand-ins and the two tools the library needs (``id``, ``env``), so a real sudo or
apt-get on the machine can never be reached. The non-root cases drop to the user
``nobody`` for real (``setpriv``), so they need root to run; the library's ``id -u``
is the real one.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "scripts" / "lib" / "apt.sh"
NOBODY = 65534

#: records one line per call: tool, uid, DEBIAN_FRONTEND (or "-"), argv
RECORD = 'printf "%s|%s|%s|%s\\n" "{tool}" "$(id -u)" "${{DEBIAN_FRONTEND:--}}" "$*" >> "$LOG"\n'
STAND_INS = {
    # dpkg -s PKG: known only when PKG is listed in $INSTALLED
    "dpkg": RECORD.format(tool="dpkg")
    + 'case " $INSTALLED " in *" $2 "*) exit 0;; esac\nexit 1\n',
    "apt-get": RECORD.format(tool="apt-get") + "exit 0\n",
    # sudo [VAR=value...] CMD...: records the call, then runs CMD with those variables, as
    # the real sudo does (it cannot really become root here)
    "sudo": RECORD.format(tool="sudo") + 'exec env "$@"\n',
}


@pytest.fixture()
def sandbox() -> Iterator[Path]:
    """A world-readable folder (the non-root cases run as nobody) with the library and bin/."""
    root = Path(tempfile.mkdtemp(prefix="cavewalk-setup-"))
    try:
        (root / "bin").mkdir()
        for tool in ("id", "env"):
            real = shutil.which(tool)
            assert real is not None, f"{tool} is needed by apt.sh"
            (root / "bin" / tool).symlink_to(real)
        shutil.copy(LIB, root / "apt.sh")
        log = root / "calls.log"
        log.touch()
        for path in (root, root / "bin", root / "apt.sh"):
            path.chmod(0o755)
        log.chmod(0o666)
        yield root
    finally:
        shutil.rmtree(root)


def stand_in(sandbox: Path, tool: str) -> None:
    path = sandbox / "bin" / tool
    path.write_text("#!/bin/bash\n" + STAND_INS[tool])
    path.chmod(0o755)


def run_apt_install(sandbox: Path, *packages: str, user: int | None = None, installed: str = ""):
    """``apt_install PACKAGES`` in a clean bash, as root or (user) as that uid."""
    script = f'set -euo pipefail\n. "{sandbox}/apt.sh"\napt_install "$@"\n'
    cmd = ["/bin/bash", "-c", script, "apt_install", *packages]
    if user is not None:
        cmd = [SETPRIV or "setpriv", f"--reuid={user}", f"--regid={user}", "--clear-groups", *cmd]
    env = {"PATH": str(sandbox / "bin"), "LOG": str(sandbox / "calls.log"), "INSTALLED": installed}
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=30, cwd=sandbox)
    calls = [line.split("|", 3) for line in (sandbox / "calls.log").read_text().splitlines()]
    return proc, calls


SETPRIV = shutil.which("setpriv")  # util-linux
needs_root = pytest.mark.skipif(
    os.geteuid() != 0 or SETPRIV is None, reason="runs as root and drops to nobody for real (setpriv)"
)


@needs_root
def test_as_root_apt_get_runs_directly_with_the_noninteractive_frontend(sandbox: Path) -> None:
    for tool in ("dpkg", "apt-get", "sudo"):
        stand_in(sandbox, tool)
    proc, calls = run_apt_install(sandbox, "chromium", "chromium-driver", installed="chromium")
    assert proc.returncode == 0, f"apt_install failed as root: {proc.stderr}"
    assert "apt-get install chromium-driver" in proc.stdout
    assert [c for c in calls if c[0] == "dpkg"] == [
        ["dpkg", "0", "-", "-s chromium"],
        ["dpkg", "0", "-", "-s chromium-driver"],
    ]
    assert [c for c in calls if c[0] != "dpkg"] == [
        ["apt-get", "0", "noninteractive", "update -qq"],
        ["apt-get", "0", "noninteractive", "install -y -qq chromium-driver"],
    ], "as root: apt-get directly (no sudo), only the missing package, DEBIAN_FRONTEND set"


@needs_root
def test_as_a_user_with_sudo_apt_get_runs_through_sudo(sandbox: Path) -> None:
    for tool in ("dpkg", "apt-get", "sudo"):
        stand_in(sandbox, tool)
    proc, calls = run_apt_install(sandbox, "chromium", user=NOBODY)
    assert proc.returncode == 0, f"apt_install failed as a user: {proc.stderr}"
    uid = str(NOBODY)
    assert [c for c in calls if c[0] != "dpkg"] == [
        ["sudo", uid, "-", "env DEBIAN_FRONTEND=noninteractive apt-get update -qq"],
        ["apt-get", uid, "noninteractive", "update -qq"],
        ["sudo", uid, "-", "env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium"],
        ["apt-get", uid, "noninteractive", "install -y -qq chromium"],
    ], "as a user: every apt-get through sudo, DEBIAN_FRONTEND passed through env"


@needs_root
def test_nothing_missing_calls_no_apt_get(sandbox: Path) -> None:
    for tool in ("dpkg", "apt-get", "sudo"):
        stand_in(sandbox, tool)
    proc, calls = run_apt_install(sandbox, "chromium", user=NOBODY, installed="chromium")
    assert proc.returncode == 0 and proc.stdout == ""
    assert [c[0] for c in calls] == ["dpkg"]


@needs_root
def test_a_user_without_sudo_gets_one_clear_error(sandbox: Path) -> None:
    for tool in ("dpkg", "apt-get"):  # no sudo anywhere on PATH
        stand_in(sandbox, tool)
    proc, calls = run_apt_install(sandbox, "chromium", user=NOBODY)
    assert proc.returncode != 0, "apt_install must fail when it cannot become root"
    assert "error:" in proc.stderr and "needs root" in proc.stderr and "sudo" in proc.stderr, proc.stderr
    assert proc.stderr.count("error:") == 1, f"one error, not one per apt-get call: {proc.stderr}"
    assert [c for c in calls if c[0] == "apt-get"] == [], "apt-get was never run without root"


def test_setup_sh_uses_the_library() -> None:
    text = (ROOT / "scripts" / "setup.sh").read_text()
    assert ". scripts/lib/apt.sh" in text
    assert "apt_install chromium" in text
    assert "DEBIAN_FRONTEND" not in text.replace("# ", ""), "apt-get calls live in scripts/lib/apt.sh only"
