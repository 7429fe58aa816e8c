#!/usr/bin/env bash
# The main job: set up .venv if needed, then validate the bundled driving tasks.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$ROOT/scripts/_env.sh" ""
cd "$ROOT"
exec opends-gym validate "$@"
