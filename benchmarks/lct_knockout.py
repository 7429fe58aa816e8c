"""Where does the native LCT batch's compiled pass spend its time? Each part left out in turn.

The pass (`vector.lct_step`) inlines the car model, the trigger search, the lane and path
measures and the trace rows into one loop per car, so a profiler sees one function. This
script copies the package into a scratch folder once per variant, leaves one part out of
`_substeps_range` by a text replacement (it stops, naming the variant, if the code no
longer has the text), compiles the variant's LCT batch into its own numba cache, and runs
`benchmarks/native_profile.py --parts` on each variant, variants alternating round by
round. Printed: CPU ns per env-step of the pass (`lct_step`) without and with metrics, the
median of the rounds and their range, and each variant's saving against the code as is: an
estimate of what the part costs (leaving a part out changes what the cars do, so the
savings need not add up). One thread, 4,096 envs, random actions with resets.

Variants: the code as is; no car model (the car moves straight on at its speed: cruise
control, powertrain and body left out); no trigger search (no car touches a trigger box:
no signs, no reaction timers); no lane measures (lateral position only: no lane, offset,
SDLP terms).

    python benchmarks/lct_knockout.py [--rounds 3] [--steps 300] [--envs 4096]

Takes ~1 minute per variant to compile, then ~15 s per variant and round.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STEP = "opends_gym/vector/lct_step.py"

CAR = """                xe, ze, yawe, ue, ve, re, geare, rpme, fu, fl, con, cint, gi, bi, sy, cy = ego_step_wheels(
                    car, wc, engine_on, suppress_cruise_off, min_speed, dt, xe, ze, yawe, ue, ve, re, geare, rpme, pv, fu, fl, con,
                    cruise_target[e], cint, cos_a[e], sin_a[e], gas[e], brake[e],
                )  # fmt: skip
"""
STRAIGHT = """                sy, cy = math.sin(yawe), math.cos(yawe)
                xe, ze, gi, bi = xe - ue * sy * dt, ze - ue * cy * dt, gas[e], brake[e]
"""
LANES = """            la, ln, off, sn, sm, sm2, _, _ = lane_measures(
                xe, ze, False, sign, centres, half_width, keep_m, off, sn, sm, sm2, False, 0.0, 0.0, 0.0, 0.0
            )
"""
VARIANTS: dict[str, list[tuple[str, str]]] = {
    "as is": [],
    "no car model": [(CAR, STRAIGHT)],
    "no trigger search": [("                    j, nr = nearest_volume(bx, bz, vols, nr)\n", "                    j = -1\n")],
    "no lane measures": [(LANES, "            la = -sign * xe\n")],
}


def make_variant(name: str, patches: list[tuple[str, str]], scratch: Path) -> Path:
    """A copy of the package with `patches` applied to the pass; returns the folder to put on PYTHONPATH."""
    folder = scratch / re.sub(r"\W+", "_", name)
    shutil.copytree(ROOT / "opends_gym", folder / "opends_gym", ignore=shutil.ignore_patterns("__pycache__"))
    path = folder / STEP
    text = path.read_text()
    for old, new in patches:
        if text.count(old) != 1:
            sys.exit(f"lct_knockout: variant {name!r}: {STEP} no longer has the text it replaces: {old.strip()[:60]!r}")
        text = text.replace(old, new)
    path.write_text(text)
    return folder


def env_for(folder: Path, scratch: Path) -> dict[str, str]:
    """The environment that runs `folder`'s package with its own numba cache, on one thread."""
    env = dict(os.environ, PYTHONPATH=str(folder), NUMBA_CACHE_DIR=str(scratch / f"cache_{folder.name}"), NUMBA_NUM_THREADS="1")
    return env


def compile_variant(folder: Path, scratch: Path) -> None:
    """`opends-gym compile` of the LCT batch into the variant's cache; checks the variant's package is the one imported."""
    env = env_for(folder, scratch)
    where = subprocess.run([sys.executable, "-c", "import opends_gym; print(opends_gym.__file__)"], env=env, cwd=folder,
                           capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    if not where.startswith(str(folder)):
        sys.exit(f"lct_knockout: {folder.name} imports opends_gym from {where}, not from its copy")
    argv = ["compile", "--kind", "native", "--only", "LaneChangeTest", "--jobs", "1"]
    code = f"import sys; from opends_gym.cli.main import main; sys.exit(main({argv!r}))"
    subprocess.run([sys.executable, "-c", code], env=env, cwd=folder, check=True, capture_output=True)


def pass_ns(folder: Path, scratch: Path, steps: int, envs: int) -> tuple[float, float]:
    """`native_profile.py --parts`' CPU ns per env-step of the pass (`lct_step`), without and with metrics."""
    script = str(ROOT / "benchmarks" / "native_profile.py")
    command = [sys.executable, script, "--parts", "--steps", str(steps), "--envs", str(envs)]
    out = subprocess.run(command, env=env_for(folder, scratch), cwd=folder, capture_output=True, text=True, check=True).stdout
    found = [float(v) for v in re.findall(r"one-pass step \(lct_step\)\s+([\d,]+) ns", out.replace(",", ""))]
    if len(found) != 2:
        sys.exit(f"lct_knockout: native_profile.py printed no pass times for {folder.name}:\n{out}")
    return found[0], found[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--envs", type=int, default=4096)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="lct_knockout_") as tmp:
        scratch = Path(tmp)
        folders = {name: make_variant(name, patches, scratch) for name, patches in VARIANTS.items()}
        for name, folder in folders.items():
            print(f"compiling {name} ...", flush=True)
            compile_variant(folder, scratch)
        runs: dict[str, list[tuple[float, float]]] = {name: [] for name in folders}
        for r in range(args.rounds):
            for name, folder in folders.items():
                runs[name].append(pass_ns(folder, scratch, args.steps, args.envs))
            print(f"round {r + 1} of {args.rounds} done", flush=True)
    base = [statistics.median(v[i] for v in runs["as is"]) for i in (0, 1)]
    print(f"\n`python benchmarks/lct_knockout.py --rounds {args.rounds} --steps {args.steps}` ({args.envs:,} LCT envs, one thread, "
          "random actions with resets): the compiled pass (`lct_step`), CPU ns per env-step, median (range) of the rounds\n")  # fmt: skip
    print("| variant | no metrics | saving | metrics | saving |")
    print("|---|---:|---:|---:|---:|")
    for name, values in runs.items():
        cells = []
        for i in (0, 1):
            vals = [v[i] for v in values]
            med = statistics.median(vals)
            cells += [f"{med:,.0f} ({min(vals):,.0f}-{max(vals):,.0f})", "-" if name == "as is" else f"{base[i] - med:,.0f}"]
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
