"""The Python environment the set-up makes: exactly one OpenCV distribution (issue 15 S2).

ultralytics pulls opencv-python (the GUI build) next to opencv-python-headless; both write
``cv2/``, so the one that wins is whichever pip installed last. ``scripts/one_opencv.py``
(run by scripts/setup.sh) leaves headless alone.
"""

from __future__ import annotations

import importlib.util
import sys
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("one_opencv", ROOT / "scripts" / "one_opencv.py")
assert spec is not None and spec.loader is not None
one_opencv = importlib.util.module_from_spec(spec)
sys.modules["one_opencv"] = one_opencv
spec.loader.exec_module(one_opencv)


def test_exactly_one_opencv_distribution_is_installed() -> None:
    names = sorted(
        (d.metadata["Name"] or "").lower().replace("_", "-")
        for d in metadata.distributions()
        if (d.metadata["Name"] or "").lower().replace("_", "-").startswith("opencv")
    )
    assert names == ["opencv-python-headless"], (
        f"OpenCV distributions in this environment: {names}; run  python scripts/one_opencv.py"
    )
    import cv2

    assert Path(cv2.__file__).parent.name == "cv2"
    assert cv2.__version__.split(".")[0] == metadata.version("opencv-python-headless").split(".")[0]


@pytest.mark.parametrize(
    ("installed", "expected"),
    [
        ({"opencv-python-headless": "5.0.0.93"}, []),
        (
            {"opencv-python-headless": "5.0.0.93", "opencv-python": "5.0.0.93"},
            [
                ["uninstall", "-y", "opencv-python"],
                ["install", "--no-deps", "--force-reinstall", "opencv-python-headless==5.0.0.93"],
            ],
        ),
        (
            {"opencv-python": "4.10.0.84", "opencv-contrib-python": "4.10.0.84"},
            [
                ["uninstall", "-y", "opencv-contrib-python", "opencv-python"],
                ["install", "--no-deps", "--force-reinstall", "opencv-python-headless==4.10.0.84"],
            ],
        ),
    ],
)
def test_the_plan_removes_every_other_build_and_restores_headless(
    installed: dict[str, str], expected: list[list[str]]
) -> None:
    assert one_opencv.plan(installed) == expected
