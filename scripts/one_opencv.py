"""Leave exactly one OpenCV distribution in this Python environment: opencv-python-headless.

ultralytics (the ``models`` extra) requires ``opencv-python``, the GUI build, which pip installs
next to our ``opencv-python-headless``. Both write the same ``cv2/`` package, so whichever was
installed last wins file by file, and uninstalling either breaks the other. This removes every
other OpenCV distribution and reinstalls headless (the same version, no dependencies) over the
remains. ``scripts/setup.sh`` runs it after each install; tests/test_environment.py checks the
outcome. Run it with the environment's own python: ``.venv/bin/python scripts/one_opencv.py``.
"""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata

KEEP = "opencv-python-headless"
#: every distribution that ships the cv2 package
OPENCV_DISTRIBUTIONS = (
    "opencv-python",
    "opencv-python-headless",
    "opencv-contrib-python",
    "opencv-contrib-python-headless",
)


def installed_opencv() -> dict[str, str]:
    """name -> version of the OpenCV distributions installed in this environment."""
    found: dict[str, str] = {}
    for dist in metadata.distributions():
        name = (dist.metadata["Name"] or "").lower().replace("_", "-")
        if name in OPENCV_DISTRIBUTIONS:
            found[name] = dist.version
    return found


def plan(installed: dict[str, str]) -> list[list[str]]:
    """The pip commands (argument lists after ``pip``) that leave only headless installed."""
    others = sorted(name for name in installed if name != KEEP)
    if not others:
        return []
    version = installed.get(KEEP) or installed[others[0]]
    return [
        ["uninstall", "-y", *others],
        ["install", "--no-deps", "--force-reinstall", f"{KEEP}=={version}"],
    ]


def main() -> int:
    steps = plan(installed_opencv())
    for args in steps:
        print("==> pip " + " ".join(args), flush=True)
        subprocess.run([sys.executable, "-m", "pip", "-q", "--disable-pip-version-check", *args], check=True)
    left = installed_opencv()
    if list(left) != [KEEP]:
        print(f"error: OpenCV distributions installed: {left or 'none'}; expected only {KEEP}",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
