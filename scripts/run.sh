#!/usr/bin/env bash
# The main job: set up .venv if needed, then drive the Lane Change Test with the rule-based
# driver and print the metrics (extra arguments go to `opends-gym run`).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/_env.sh" ""
cd "$ROOT"
if [ "$#" -eq 0 ]; then
  set -- OpenDS/LaneChangeTest-v0 --agent rule --episodes 3
fi
exec opends-gym run "$@"
