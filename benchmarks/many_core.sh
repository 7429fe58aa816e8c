#!/usr/bin/env bash
# The many-core figures of the native batches in one run (a 16-core host in the docs):
#   1. what the host is (cores, CPU, Python, numpy, numba);
#   2. `opends-gym compile` of the three native batches' kernels (timed), so no probe compiles;
#   3. benchmarks/scaling.py for the LCT (1, 2, 4, 8, 16 threads, 2,048 envs per thread);
#   4. the same for the brake and platoon tests at 1 and 16 threads;
#   5. benchmarks/throughput.py --native (4,096 envs; the table the 2-core figures come from).
# Each part's table also goes to OUTDIR (default benchmarks/results/many_core).
#
#     bash benchmarks/many_core.sh [OUTDIR] [SECONDS] [ROUNDS]
#
# Needs numpy, numba, gymnasium and lxml importable (the repository on PYTHONPATH is enough).
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:-$here/benchmarks/results/many_core}"
seconds="${2:-2}"
rounds="${3:-2}"
mkdir -p "$out"
cd "$here" || exit 1
export PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
py="${PYTHON:-python3}"

{
  date -u +%Y-%m-%dT%H:%MZ
  echo "cores: $(nproc)  cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
  "$py" -c "import sys, numpy, numba, gymnasium; print('python', sys.version.split()[0], 'numpy', numpy.__version__, 'numba', numba.__version__, 'gymnasium', gymnasium.__version__, 'threading layer default', numba.config.THREADING_LAYER)"
} 2>&1 | tee "$out/host.txt"

start=$(date +%s)
"$py" -c "import sys; sys.argv = ['opends-gym', 'compile', '--kind', 'native', '--only', 'LaneChangeTest', 'BrakeReaction', 'ThreeVehiclePlatoon']
from opends_gym.cli.main import main; sys.exit(main())" 2>&1 | tail -5 | tee "$out/compile.txt"
echo "compile: $(( $(date +%s) - start )) s wall" | tee -a "$out/compile.txt"

"$py" benchmarks/scaling.py --seconds "$seconds" --rounds "$rounds" 2>&1 | tee "$out/scaling_lct.txt"
for id in OpenDS/BrakeReaction-v0 OpenDS/ThreeVehiclePlatoon-v0; do
  "$py" benchmarks/scaling.py --env "$id" --threads 1 16 --seconds "$seconds" --rounds "$rounds" 2>&1 | tee "$out/scaling_${id#OpenDS/}.txt"
done
"$py" benchmarks/throughput.py --native --seconds "$seconds" 2>&1 | tee "$out/throughput_native.txt"
