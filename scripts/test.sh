#!/usr/bin/env bash
# Install gaitwatch with its test tools into .venv and run lint and the test suite (SQLite),
# then the storage and API tests on PostgreSQL (scripts/test-postgres.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet -e '.[dev]'
.venv/bin/ruff check .
.venv/bin/ruff format --check .
.venv/bin/python -m pytest -q "$@"
# The storage and API tests again on PostgreSQL (a throw-away local server), for the whole suite
# only; skipped with a message where PostgreSQL's server programs are missing.
if [ $# -eq 0 ] && [ "${GAITWATCH_SKIP_POSTGRES:-0}" != 1 ]; then
  bash scripts/test-postgres.sh
fi
