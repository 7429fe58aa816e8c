#!/usr/bin/env bash
# Shared by _env.sh and core_check.sh: find a CPython of a given minor version on this machine.
# `find_python 3.11` prints the path of a python3.11 (PATH, then pyenv's versions, then uv's
# managed Pythons); it returns 1 if there is none. Each candidate is run once to check it
# really is that version (a pyenv shim for a version that is not selected fails that check).
find_python() {
  local want="$1" cand
  local -a cands=("python$want")
  for cand in "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$want".*/bin/python"$want" "$HOME"/.local/share/uv/python/cpython-"$want".*/bin/python"$want"; do
    [ -x "$cand" ] && cands+=("$cand")
  done
  if command -v uv >/dev/null 2>&1; then
    cand="$(uv python find --no-python-downloads "$want" 2>/dev/null || true)"
    [ -n "$cand" ] && cands+=("$cand")
  fi
  for cand in "${cands[@]}"; do
    command -v "$cand" >/dev/null 2>&1 || continue
    if [ "$("$cand" -c 'import sys, venv; print("%d.%d" % sys.version_info[:2])' 2>/dev/null)" = "$want" ]; then
      command -v "$cand"; return 0
    fi
  done
  return 1
}

# the CPython versions opends_gym supports (pyproject.toml requires-python), in order of preference
SUPPORTED_PYTHONS="3.11 3.12 3.13 3.10"

# `warn_if_low_disk DIR MB WHAT`: one line on stderr when the filesystem of DIR has less than MB
# megabytes free, naming what needs them (an install that runs out of space fails deep inside
# pip with "No space left on device"; this says beforehand how much it needs and where).
warn_if_low_disk() {
  local dir="$1" need="$2" what="$3" free
  free="$(df -Pm "$dir" 2>/dev/null | awk 'NR == 2 {print $4}')"
  [ -n "$free" ] || return 0
  if [ "$free" -lt "$need" ]; then
    echo "warning: $what needs about $need MB on $(df -P "$dir" | awk 'NR == 2 {print $6}'), which has $free MB free" >&2
  fi
}
