"""How fast are the headless renderers? Frames per second per view, size and task.

Targets: the 84x84 top-down observation at >= 2000 frames/s (image-based training), the
driver view at >= 30 frames/s at 1280x720 (a human session), the full human frame
(`compose_view`: view, rear mirror, HUD) likewise. Worlds are advanced a few seconds so
traffic and signs are in view. Both wall-clock and process-CPU rates are printed: on a
shared machine the CPU rate is the steadier figure.

    python benchmarks/render_speed.py [--seconds 2.0]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

from opends_gym.render import make_renderer
from opends_gym.render.compose import ViewComposer
from opends_gym.sim.world import World
from opends_gym.task.bundled import BUNDLED_DIR

CASES = (
    ("topdown", 84, 84),
    ("driver_view", 84, 84),
    ("topdown", 640, 360),
    ("driver_view", 640, 360),
    ("driver_view", 1280, 720),
    ("chase", 1280, 720),
    ("human", 1280, 720),
)
TASKS = ("LaneChangeTest", "ReactionTest", "ThreeVehiclePlatoon")


def rate(render: object, width: int, height: int, seconds: float) -> tuple[float, float]:
    fn = render.render  # type: ignore[attr-defined]
    fn(width, height)
    n = 0
    t0, c0 = time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < seconds:
        fn(width, height)
        n += 1
    return n / (time.perf_counter() - t0), n / max(time.process_time() - c0, 1e-9)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="measuring time per case")
    args = ap.parse_args()
    print(f"{'task':<22}{'view':<13}{'size':>10}{'fps (wall)':>13}{'fps (cpu)':>12}")
    for task in TASKS:
        world = World(BUNDLED_DIR / task)
        world.run(3.0)
        for view, w, h in CASES:
            if view == "human":
                g = dataclasses.replace(world.task.settings.general, mirror_mode="back_only")
                r: object = ViewComposer(world, g)
            else:
                r = make_renderer(view, world)
            wall, cpu = rate(r, w, h, args.seconds)
            print(f"{task:<22}{view:<13}{f'{w}x{h}':>10}{wall:>13.0f}{cpu:>12.0f}")


if __name__ == "__main__":
    main()
