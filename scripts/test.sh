#!/usr/bin/env bash
# Lint, type-check and run the whole test suite (slow tests included).
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$PWD/.venv/bin:$PATH"
echo "==> ruff"
ruff check pipeline app tests scripts
echo "==> mypy"
mypy
echo "==> pytest"
# pytest exits 5 when it collects nothing: that is a failure here too.
exec pytest -p no:cacheprovider "$@"
