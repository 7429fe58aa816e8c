#!/usr/bin/env bash
# The whole test suite: set up .venv with every extra, lint, type-check, run pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/_env.sh" "dev,rl"
cd "$ROOT"
echo "== ruff"; ruff check .
ruff format --check .
echo "== mypy"; mypy
echo "== pytest"
set +e
python -m pytest "$@"
code=$?
set -e
if [ "$code" -eq 5 ]; then
  echo "pytest collected no tests: failing loudly (exit code 5)" >&2
  exit 5
fi
exit "$code"
