#!/usr/bin/env bash
# Shared by run.sh and test.sh: make .venv (Python 3.11) and install the project into it.
# Re-installs only when pyproject.toml, constraints.txt or the requested extras change.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${OPENDS_GYM_VENV:-$ROOT/.venv}"
EXTRAS="${1:-}"

find_python() {
  for cand in "${PYTHON:-}" python3.11 python3 python; do
    [ -n "$cand" ] || continue
    if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)' 2>/dev/null; then
      echo "$cand"; return 0
    fi
  done
  return 1
}

if [ ! -x "$VENV/bin/python" ]; then
  if ! PY="$(find_python)"; then
    echo "opends_gym needs Python 3.11 (pybullet ships Linux wheels only up to 3.11;" >&2
    echo "on newer Pythons pip compiles it for several minutes). Set PYTHON=/path/to/python3.11." >&2
    exit 1
  fi
  "$PY" -m venv "$VENV"
fi

STAMP="$VENV/.install-stamp"
WANT="$(cat "$ROOT/pyproject.toml" "$ROOT/constraints.txt" | sha256sum | cut -c1-16)-$EXTRAS"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$WANT" ]; then
  "$VENV/bin/python" -m pip install --quiet --upgrade pip >/dev/null 2>&1 || true
  SPEC="$ROOT"
  [ -n "$EXTRAS" ] && SPEC="$ROOT[$EXTRAS]"
  # constraints.txt pins torch to the CPU build 2.13.0 (a local wheel on our CI machines)
  LOG="$VENV/pip-install.log"
  echo "installing opends_gym${EXTRAS:+[$EXTRAS]} into $VENV (log: $LOG)" >&2
  if ! "$VENV/bin/python" -m pip install -c "$ROOT/constraints.txt" -e "$SPEC" >"$LOG" 2>&1; then
    tail -n 30 "$LOG" >&2
    echo "pip install failed; see $LOG" >&2
    exit 1
  fi
  echo "$WANT" > "$STAMP"
fi
export PATH="$VENV/bin:$PATH"
