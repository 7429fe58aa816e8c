#!/usr/bin/env bash
# The whole test suite: set up .venv (Python 3.11 where there is one) with the extras the tests
# use, lint, type-check, check the core package on a second Python (scripts/core_check.sh),
# run pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/_env.sh" "dev,rl,cluster,bullet,report,can,docs,study,data"
[ "${OPENDS_GYM_SKIP_COMPILE:-0}" = 1 ] || compile_kernels
cd "$ROOT"
# The drive-window test (tests/test_human_window.py) runs a real window under Xvfb.
# Install it once if missing (root, or sudo without a password); quiet, never fatal here.
if ! command -v Xvfb >/dev/null 2>&1; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo -n"
  if command -v apt-get >/dev/null 2>&1; then
    echo "== installing xvfb (for the window test)"
    { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq xvfb; } >/dev/null 2>&1 \
      || echo "could not install xvfb; tests/test_human_window.py will fail" >&2
  fi
fi
echo "== ruff"; ruff check .
ruff format --check .
echo "== mypy"; mypy
echo "== docs"; SITE="$(mktemp -d)"; NO_MKDOCS_2_WARNING=1 mkdocs build --strict --quiet -d "$SITE"; rm -rf "$SITE"
"$ROOT/scripts/core_check.sh"
echo "== pytest"
set +e
python -m pytest -n "${PYTEST_WORKERS:-auto}" "$@"
code=$?
set -e
if [ "$code" -eq 5 ]; then
  echo "pytest collected no tests: failing loudly (exit code 5)" >&2
  exit 5
fi
exit "$code"
