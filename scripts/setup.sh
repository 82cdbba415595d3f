#!/usr/bin/env bash
# cavewalk set-up: one command installs everything, then starts the demo or runs the tests.
#   bash scripts/setup.sh demo   # venv + all extras + pose model + demo data, then `cavewalk demo`
#   bash scripts/setup.sh test   # the same + headless Chromium, then the whole test suite
# Works on a fresh Debian/Ubuntu machine with Python 3.11 (root or sudo for apt-get).
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-}"
case "$mode" in demo|test|install) ;; *) echo "usage: bash scripts/setup.sh demo|test|install" >&2; exit 2;; esac
shift || true

PY="${PYTHON:-python3.11}"
command -v "$PY" >/dev/null 2>&1 || PY=python3
# shellcheck source=scripts/lib/apt.sh
. scripts/lib/apt.sh  # as_root, apt_install

"$PY" -c 'import venv, ensurepip' 2>/dev/null || apt_install python3-venv
if [ ! -x .venv/bin/python ]; then
  echo "==> creating .venv with $PY"
  "$PY" -m venv .venv
fi
echo "==> installing cavewalk with its extras (torch from local wheels where present)"
.venv/bin/python -m pip install -q --disable-pip-version-check -U pip wheel setuptools
# torch/torchvision first, pinned, so ultralytics does not pull another build.
.venv/bin/python -m pip install -q --disable-pip-version-check torch==2.14.1 torchvision==0.29.1
.venv/bin/python -m pip install -q --disable-pip-version-check -e '.[models,train,test]'
# ultralytics requires opencv-python (the GUI build) next to our opencv-python-headless: both
# write cv2/, so keep only headless (issue 15 S2)
.venv/bin/python scripts/one_opencv.py

echo "==> preparing the pose model and the demo data"
.venv/bin/cavewalk models prepare
.venv/bin/cavewalk data demo

case "$mode" in
  demo)
    echo "==> starting the demo: dashboard http://127.0.0.1:8000  (Ctrl-C to stop)"
    exec .venv/bin/cavewalk demo "$@"
    ;;
  test)
    apt_install chromium chromium-driver
    exec bash scripts/test.sh "$@"
    ;;
  install) ;;
esac
