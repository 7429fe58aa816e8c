#!/usr/bin/env bash
# The core package on a second Python: when a CPython 3.13 or 3.12 is on this machine,
# install opends_gym with no extras (so no torch, no pybullet) into its own venv
# (.venv-core-3.X) and run the Lane Change Test with the rule driver and Gymnasium's env
# checker on every environment there; check that an extra's feature (the PPO agent, the
# bullet backend) answers with the one-line `pip install "opends-gym[...]"` hint.
# No such interpreter: says so and succeeds (nothing is downloaded to get one).
# Any failure fails the script (test.sh runs it before pytest).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/_python.sh"

PY=""
for v in ${CORE_CHECK_PYTHONS:-3.13 3.12}; do
  if PY="$(find_python "$v")"; then break; fi
  PY=""
done
if [ -z "$PY" ]; then
  echo "== core check: no python3.13 or python3.12 on this machine; skipped"
  exit 0
fi
VER="$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
VENV="${OPENDS_GYM_CORE_VENV:-$ROOT/.venv-core-$VER}"
echo "== core check on Python $VER ($PY): $VENV"
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
HASH="$(cat "$ROOT/pyproject.toml" "$ROOT/constraints.txt" | sha256sum | cut -c1-16)"
if [ "$(cat "$VENV/.install-stamp-core" 2>/dev/null)" != "$HASH" ]; then
  LOG="$VENV/pip-install.log"
  echo "installing opends_gym (no extras) into $VENV (log: $LOG)"
  warn_if_low_disk "$ROOT" 800 "the core check's venv (0.6 GB measured)"
  # editable: nothing is built into the source tree's build/ (the wheel itself is tests/test_wheel.py's);
  # --no-cache-dir: the downloaded wheels are not kept a second time in pip's cache (CI disks can be small)
  if ! "$VENV/bin/python" -m pip install --no-cache-dir -c "$ROOT/constraints.txt" -e "$ROOT" >"$LOG" 2>&1; then
    tail -n 30 "$LOG" >&2
    echo "core check: pip install failed on Python $VER; see $LOG" >&2
    exit 1
  fi
  echo "$HASH" > "$VENV/.install-stamp-core"
fi

cd "$(mktemp -d)"
trap 'rm -rf "$PWD"' EXIT
PYBIN="$VENV/bin/python"
"$PYBIN" - <<'PY'
import importlib.util
import sys
import warnings

missing = [m for m in ("torch", "stable_baselines3", "pybullet", "ray") if importlib.util.find_spec(m) is not None]
assert not missing, f"the core install pulled in {missing}"

import gymnasium as gym
from gymnasium.utils.env_checker import check_env

import opends_gym

ids = sorted(k for k in gym.registry if k.startswith("OpenDS/"))
assert len(ids) >= 6, ids
for env_id in ids:
    kwargs = {"task": "ReactionTest"} if env_id == "OpenDS/DrivingTask-v0" else {}
    env = gym.make(env_id, physics="fast", **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env.unwrapped, skip_render_check=True)
    env.close()
    print(f"env checker: {env_id} ok")
print(f"opends_gym {opends_gym.__version__} on Python {sys.version.split()[0]}: {len(ids)} environments pass the env checker")
PY
"$VENV/bin/opends-gym" run OpenDS/LaneChangeTest-v0 --agent rule --episodes 1 --json >run.json
"$PYBIN" -c '
import json, sys
ep = json.load(open("run.json"))["episodes"][0]
print("rule driver, LCT: %d/18 lane changes correct, MDEV %.3f m, %d steps" % (ep["lane_changes_correct"], ep["mdev_basic_m"], ep["steps"]))
sys.exit(0 if ep["lane_changes_correct"] == 18 else "core check: the rule driver did not answer all 18 LCT signs")
'

expect_extra() {  # command must exit 2 with one line naming the extra's pip command
  local extra="$1"; shift
  set +e
  "$VENV/bin/opends-gym" "$@" >out.txt 2>err.txt
  local code=$?
  set -e
  if [ "$code" -ne 2 ] || [ "$(wc -l <err.txt)" -ne 1 ] || ! grep -qF "pip install \"opends-gym[$extra]\"" err.txt; then
    echo "core check: 'opends-gym $*' without the $extra extra: exit $code, stderr:" >&2
    cat err.txt >&2
    exit 1
  fi
  echo "without [$extra]: $(cat err.txt)"
}
expect_extra rl run OpenDS/LaneChangeTest-v0 --agent ppo:lct --max-seconds 1
expect_extra bullet run OpenDS/LaneChangeTest-v0 --physics bullet --max-seconds 1
echo "== core check on Python $VER passed"
