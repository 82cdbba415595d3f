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
# Two test processes where there are two cores (much of the suite waits on servers, browsers and
# worker processes); each test file runs whole, in its order, in one of them (--dist loadfile).
# `bash scripts/test.sh -n 0` runs everything in one process.
exec pytest -p no:cacheprovider -n auto --maxprocesses 2 --dist loadfile "$@"
