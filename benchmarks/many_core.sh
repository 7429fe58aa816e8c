#!/usr/bin/env bash
# The many-core figures of the native batches in one run (a 16-core host in the docs):
#   1. what the host is (cores, CPU, Python, numpy, numba);
#   2. `opends-gym compile` of the three native batches' kernels (timed), so no probe compiles;
#   3. benchmarks/scaling.py for the LCT (1, 2, 4, 8, 16 threads, 2,048 envs per thread);
#   4. the same for the brake and platoon tests at 1 and 16 threads;
#   5. benchmarks/throughput.py --native (4,096 envs; the table the 2-core figures come from).
# With --profile instead of 3-5: the profile of what limits the scaling, i.e.
#   benchmarks/serial_share.py (wall time per kernel and in Python outside them) for each batch,
#   with and without metrics, on 1 thread with 2,048 envs and on 16 threads with 32,768, and
#   benchmarks/scaling.py for the brake and platoon tests at 1, 2, 4, 8 and 16 threads (one round).
# Each part's table also goes to OUTDIR (default benchmarks/results/many_core).
#
#     bash benchmarks/many_core.sh [--profile] [OUTDIR] [SECONDS] [ROUNDS]
#
# Needs numpy, numba, gymnasium and lxml importable (the repository on PYTHONPATH is enough).
set -uo pipefail
profile=0
if [ "${1:-}" = "--profile" ]; then profile=1; shift; fi
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

if [ "$profile" = 1 ]; then
  for task in LaneChangeTest BrakeReaction ThreeVehiclePlatoon; do
    for m in "" --metrics; do
      NUMBA_NUM_THREADS=1 "$py" benchmarks/serial_share.py --task "$task" --envs 2048 --steps 60 $m
      NUMBA_NUM_THREADS=16 "$py" benchmarks/serial_share.py --task "$task" --envs 32768 --steps 60 $m
    done
  done 2>&1 | tee "$out/serial_share.txt"
  for id in OpenDS/BrakeReaction-v0 OpenDS/ThreeVehiclePlatoon-v0; do
    "$py" benchmarks/scaling.py --env "$id" --seconds "$seconds" --rounds 1 2>&1 | tee "$out/scaling_${id#OpenDS/}.txt"
  done
  exit 0
fi
"$py" benchmarks/scaling.py --seconds "$seconds" --rounds "$rounds" 2>&1 | tee "$out/scaling_lct.txt"
for id in OpenDS/BrakeReaction-v0 OpenDS/ThreeVehiclePlatoon-v0; do
  "$py" benchmarks/scaling.py --env "$id" --threads 1 16 --seconds "$seconds" --rounds "$rounds" 2>&1 | tee "$out/scaling_${id#OpenDS/}.txt"
done
"$py" benchmarks/throughput.py --native --seconds "$seconds" 2>&1 | tee "$out/throughput_native.txt"
