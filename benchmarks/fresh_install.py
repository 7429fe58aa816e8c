"""The first step after a fresh install, measured in a fresh venv: what a new user meets.

    python benchmarks/fresh_install.py                 # native batches of 4,096 envs
    python benchmarks/fresh_install.py --envs 1024 --keep /tmp/fresh
    python benchmarks/fresh_install.py --warm           # then compiled ahead, as scripts/test.sh does

Copies this source tree (without .git, venvs and caches), installs it with `pip install`
(no extras, the project's constraints; no `opends-gym compile`) into a new venv of this
Python, then, from outside the tree (so `import opends_gym` is the installed package), runs
`benchmarks/cold_native.py` for each native batch and its single env with numba's default
cache location: the installed package's own `__pycache__`, empty as after `pip install`.
Between runs the compile child a run leaves behind is stopped and the cache files it wrote
are removed, so every run starts from the fresh install. `--warm` then runs `opends-gym
compile` in the venv (what `scripts/test.sh` does) and the same runs with the cache it
filled: a later program's first step. Prints the install time and one table: batch, cache,
envs, import s, make_vec+reset s, first step s, slowest of the next 7 s, kernels compiled,
loaded, calls run as Python.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MOTORWAY = ROOT / "tests" / "data" / "opends-tasks" / "opends-cts" / "MotorwayTask"
IGNORED = shutil.ignore_patterns(".git", ".venv*", "__pycache__", "*.egg-info", "build", "dist", "runs", ".mypy_cache", ".ruff_cache")


def _install(where: Path) -> tuple[Path, float]:
    """A venv under `where` with this tree installed; (its python, seconds taken). A venv
    already there (`--keep` of an earlier run) is used as it is (0 s)."""
    src, venv = where / "src", where / "venv"
    if (venv / "bin" / "python").exists():
        return venv / "bin" / "python", 0.0
    shutil.copytree(ROOT, src, ignore=IGNORED)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    done = subprocess.run(
        [str(python), "-m", "pip", "install", "--no-cache-dir", "-q", "-c", str(src / "constraints.txt"), str(src)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise SystemExit(f"pip install failed:\n{done.stdout[-3000:]}{done.stderr[-3000:]}")
    return python, time.perf_counter() - start


def _children_of(python: Path) -> list[int]:
    """Compile children (`opends_gym.jit_child`) run by this venv's python."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if cmdline[:1] == [str(python).encode()] and b"opends_gym.jit_child" in cmdline:
            found.append(int(pid))
    return found


def _forget_compiles(python: Path, package: Path) -> None:
    """Back to the fresh install: stop the compile children, remove numba's cache files."""
    for pid in _children_of(python):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    for pattern in ("*.nbi", "*.nbc"):
        for path in package.rglob(pattern):
            path.unlink()


def _first_steps(python: Path, run: list[str], where: Path, env: dict[str, str]) -> str:
    """`cold_native.py`'s row for one batch, run by the venv's python from outside the tree."""
    done = subprocess.run([str(python), "-W", "ignore", str(ROOT / "benchmarks" / "cold_native.py"), *run, "--steps", "8"],
                          cwd=where, env=env, capture_output=True, text=True, timeout=900)  # fmt: skip
    rows = [line for line in done.stdout.splitlines() if line.startswith("| OpenDS/")]
    if done.returncode != 0 or not rows:
        raise SystemExit(f"{run[0]} failed:\n{done.stdout[-2000:]}{done.stderr[-3000:]}")
    return rows[-1]


def _print_row(row: str, cache: str) -> None:
    cells = row.split("|")
    name = cells[1].strip() + (" (MotorwayTask, no metrics)" if "DrivingTask" in cells[1] else "")
    print("|".join(["", f" {name} ", f" {cache} ", *cells[2:]]), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--envs", type=int, default=4096, help="envs of each native batch (the MotorwayTask's run without metrics)")
    ap.add_argument(
        "--keep", type=Path, help="install here and keep it, or use the install kept there (default: a temporary folder, removed)"
    )
    ap.add_argument("--warm", action="store_true", help="then `opends-gym compile` in the venv and the same runs with its cache")
    args = ap.parse_args()
    where = args.keep or Path(tempfile.mkdtemp(prefix="opends-fresh-"))
    where.mkdir(parents=True, exist_ok=True)
    try:
        python, install_s = _install(where)
        package = Path(
            subprocess.run([str(python), "-c", "import opends_gym, os; print(os.path.dirname(opends_gym.__file__))"], cwd=where,
                           capture_output=True, text=True, check=True).stdout.strip()
        )  # fmt: skip
        print(f"fresh venv: {python} ({sys.version.split()[0]}), pip install {install_s:.0f} s, package at {package}")
        runs = [
            ["OpenDS/LaneChangeTest-v0", str(args.envs)],
            ["OpenDS/BrakeReaction-v0", str(args.envs)],
            ["OpenDS/ThreeVehiclePlatoon-v0", str(args.envs)],
            ["OpenDS/DrivingTask-v0", str(args.envs), "--task", str(MOTORWAY), "--no-metrics"],
        ]
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
        print(
            "| batch | cache | envs | import s | make_vec+reset s | first step s | slowest of the next 7 s | compiled | loaded |"
            " calls as Python |"
        )
        print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for run in runs:
            _forget_compiles(python, package)
            _print_row(_first_steps(python, run, where, env), "empty")
        _forget_compiles(python, package)
        if args.warm:
            start = time.perf_counter()
            subprocess.run([str(where / "venv" / "bin" / "opends-gym"), "compile"], cwd=where, env=env, check=True, capture_output=True)
            print(f"(then `opends-gym compile` in the venv: {time.perf_counter() - start:.0f} s)")
            for run in runs:
                _print_row(_first_steps(python, run, where, env), "filled")
    finally:
        if args.keep is None:
            shutil.rmtree(where, ignore_errors=True)


if __name__ == "__main__":
    main()
