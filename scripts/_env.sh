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

HASH="$(cat "$ROOT/pyproject.toml" "$ROOT/constraints.txt" | sha256sum | cut -c1-16)"
# one stamp per installed set of extras; a request is satisfied by any stamp of the same
# project hash whose extras include all the requested ones
satisfied() {
  local stamp want have
  for stamp in "$VENV"/.install-stamp*; do
    [ -f "$stamp" ] || continue
    [ "$(head -n1 "$stamp")" = "$HASH" ] || continue
    have=",$(sed -n 2p "$stamp"),"
    for want in ${EXTRAS//,/ }; do
      case "$have" in *",$want,"*) ;; *) continue 2 ;; esac
    done
    return 0
  done
  return 1
}
if ! satisfied; then
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
  rm -f "$VENV"/.install-stamp*
  printf '%s\n%s\n' "$HASH" "$EXTRAS" > "$VENV/.install-stamp-${EXTRAS:-base}"
fi
export PATH="$VENV/bin:$PATH"
