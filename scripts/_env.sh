#!/usr/bin/env bash
# Shared by run.sh and test.sh: make .venv and install the project into it.
# Re-installs only when pyproject.toml, constraints.txt or the requested extras change.
# The interpreter: $PYTHON if set, else any supported CPython (3.10 to 3.13) found on this
# machine, 3.11 first: the `bullet` extra (pybullet) has Linux wheels only up to 3.11, so the
# full test suite, which needs it, runs there; on 3.12+ pip compiles pybullet from source.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${OPENDS_GYM_VENV:-$ROOT/.venv}"
EXTRAS="${1:-}"
source "$ROOT/scripts/_python.sh"

pick_python() {
  local v
  if [ -n "${PYTHON:-}" ]; then
    if "$PYTHON" -c 'import sys; sys.exit(0 if (3, 10) <= sys.version_info[:2] <= (3, 13) else 1)' 2>/dev/null; then
      echo "$PYTHON"; return 0
    fi
    echo "PYTHON=$PYTHON is not a CPython 3.10 to 3.13" >&2
    return 1
  fi
  for v in $SUPPORTED_PYTHONS; do
    find_python "$v" && return 0
  done
  return 1
}

if [ ! -x "$VENV/bin/python" ]; then
  if ! PY="$(pick_python)"; then
    echo "opends_gym needs CPython 3.10 to 3.13 (3.11 for the full test suite: pybullet has Linux" >&2
    echo "wheels only up to 3.11). Set PYTHON=/path/to/python3.11." >&2
    exit 1
  fi
  case ",$EXTRAS," in
    *,bullet,*)
      "$PY" -c 'import sys; sys.exit(0 if sys.version_info[:2] <= (3, 11) else 1)' \
        || echo "note: $PY is newer than 3.11: pip compiles pybullet (the bullet extra) from source, several minutes" >&2 ;;
  esac
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
  # (measured: the test suite's extras take 2.8 GB in the venv; no extras, 0.6 GB)
  if [ -n "$EXTRAS" ]; then warn_if_low_disk "$ROOT" 3500 "this install"; else warn_if_low_disk "$ROOT" 800 "this install"; fi
  # --no-cache-dir: the downloaded wheels are not kept a second time in pip's cache (CI disks can be small)
  if ! "$VENV/bin/python" -m pip install --no-cache-dir -c "$ROOT/constraints.txt" -e "$SPEC" >"$LOG" 2>&1; then
    tail -n 30 "$LOG" >&2
    echo "pip install failed; see $LOG" >&2
    exit 1
  fi
  rm -f "$VENV"/.install-stamp*
  printf '%s\n%s\n' "$HASH" "$EXTRAS" > "$VENV/.install-stamp-${EXTRAS:-base}"
fi
export PATH="$VENV/bin:$PATH"

# compile_kernels: compile the kernels into this machine's numba cache (`opends-gym compile`), so
# that no first step waits for a compile later; again only when the package's sources (or
# NUMBA_CACHE_DIR) changed since (a warm cache takes seconds). Never fatal: on failure the
# kernels compile on first use, as without this step. OPENDS_GYM_SKIP_COMPILE=1 skips it.
# test.sh calls it (the tests then load the kernels instead of compiling them); run.sh does
# not, since its one LCT env runs its kernels as Python until their background compile is done.
compile_kernels() {
  local stamp="$VENV/.compile-stamp" log="$VENV/compile.log" want
  want="$( (cd "$ROOT" && find opends_gym -name '*.py' -print0 | LC_ALL=C sort -z | xargs -0 cat; echo "${NUMBA_CACHE_DIR:-}") | sha256sum | cut -c1-16)"
  [ "$(cat "$stamp" 2>/dev/null)" = "$want" ] && return 0
  echo "compiling the kernels into this machine's numba cache (opends-gym compile; log: $log)" >&2
  if "$VENV/bin/opends-gym" compile >"$log" 2>&1; then
    echo "$want" > "$stamp"
    echo "  $(tail -n 1 "$log")" >&2
  else
    echo "opends-gym compile failed (see $log); the kernels will compile on first use instead" >&2
  fi
}
