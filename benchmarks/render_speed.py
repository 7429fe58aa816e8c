"""How fast are the Panda3D views? One table from one run: frames (or env steps) per second per case.

Goals (issue 20): the human window (screens, rear mirror, HUD, drawn into a real window when
there is an X display, else into an offscreen surface of the same size) >= 30 fps at 1280x720
on the software pipe (p3tinydisplay), >= 60 fps at 1920x1080 on a GPU; `driver_view`
observations at 84x84 >= 5000 env steps/s, `topdown` >= 2000. The driver-view goal is for the
way RL users consume pixels: a vector env, here `gymnasium.make_vec("OpenDS/LaneChangeTest-v0",
num_envs=BATCH, vectorization_mode="vector_entry_point", observation="driver_view")` (the native
batch; its N views drawn as one Panda3D frame), counted in env steps; the single env's row stays. The GPU row is measured in the
same run when an OpenGL pipe (GLX with an X display, else EGL) opens on a hardware renderer (shadows on, as
`shadows="auto"` draws them there); otherwise the table says why it was not measured.
Both wall-clock and process-CPU rates are printed: on a shared machine the CPU rate is the
steadier figure.

    python benchmarks/render_speed.py [--seconds 2.0] [--pipe tinydisplay|gl|egl] [--batch 16]
    xvfb-run -s "-screen 0 1920x1080x24" python benchmarks/render_speed.py   # a real window
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

TASK = "LaneChangeTest"
BATCH = 16  # envs in the batched driver-view row


def rate(fn: Callable[[], object], seconds: float) -> tuple[float, float]:
    from opends_gym.jit import wait_compiled

    fn()
    wait_compiled()  # the kernels compile in the background and run as Python until then: time compiled code
    n = 0
    t0, c0 = time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < seconds:
        fn()
        n += 1
    return n / (time.perf_counter() - t0), n / max(time.process_time() - c0, 1e-9)


def env_steps(observation: str) -> Callable[[], object]:
    import gymnasium as gym
    import numpy as np

    import opends_gym  # noqa: F401

    env = gym.make(f"OpenDS/{TASK}-v0", observation=observation)
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, np.float32)

    def step() -> object:
        _, _, term, trunc, _ = env.step(zero)
        if term or trunc:
            env.reset()
        return None

    return step


def batch_steps(observation: str, n: int) -> Callable[[], object]:
    """One step of the native LCT batch of `n` envs with image observations (n env steps per call)."""
    import gymnasium as gym
    import numpy as np

    import opends_gym  # noqa: F401

    venv = gym.make_vec(f"OpenDS/{TASK}-v0", num_envs=n, vectorization_mode="vector_entry_point", observation=observation)
    venv.reset(seed=0)
    zero = np.zeros((n, *venv.single_action_space.shape), np.float32)  # (autoresets: the batch resets ended envs itself)
    return lambda: venv.step(zero)


def view_frames(width: int, height: int) -> Callable[[], object]:
    """The driver view alone (no env step) on the LCT after 300 steps: the steadier figure on a loaded host."""
    import gymnasium as gym
    import numpy as np

    import opends_gym  # noqa: F401
    from opends_gym.render import make_renderer

    env = gym.make(f"OpenDS/{TASK}-v0")
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, np.float32)
    for _ in range(300):
        env.step(zero)
    view = make_renderer("driver_view", env.unwrapped.world)  # type: ignore[attr-defined]
    return lambda: view.render(width, height)


def window_frames(width: int, height: int) -> Callable[[], object]:
    import dataclasses

    from opends_gym.render import _pg
    from opends_gym.render.compose import ViewComposer
    from opends_gym.sim.world import World
    from opends_gym.task.bundled import BUNDLED_DIR

    world = World(BUNDLED_DIR / TASK)
    world.run(3.0)
    g = dataclasses.replace(world.task.settings.general, mirror_mode="back_only")
    composer = ViewComposer(world, g)
    pg = _pg.pygame()
    if os.environ.get("DISPLAY"):
        pg.display.init()
        surface = pg.display.set_mode((width, height))
        flip = pg.display.flip
    else:
        surface = _pg.new_surface(width, height)
        flip = lambda: None  # noqa: E731
    dt = 1.0 / 60.0

    def frame() -> object:
        world.run(dt)
        composer.draw(surface)
        flip()
        return None

    return frame


SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "software", "lavapipe")


def gpu_pipe() -> tuple[str | None, str]:
    """(pipe, renderer) of an OpenGL pipe on a hardware renderer, else (None, why there is none)."""
    from opends_gym.render.engine import PIPE_ENV, Offscreen

    why = []
    before = os.environ.get(PIPE_ENV)
    # GLX needs an X display, EGL does not (one of them only: the two modules clash in one process)
    for name in ("gl",) if os.environ.get("DISPLAY") else ("egl",):
        os.environ[PIPE_ENV] = name
        try:
            probe = Offscreen(4, 4)
            probe.engine.openWindows()
            gsg = probe.buffer.getGsg()
            renderer = str(gsg.getDriverRenderer()) if gsg is not None else ""
            probe.close()
        except RuntimeError as e:
            why.append(f"{name}: {e}")
            continue
        finally:
            if before is None:
                os.environ.pop(PIPE_ENV, None)
            else:
                os.environ[PIPE_ENV] = before
        if not renderer or any(k in renderer.lower() for k in SOFTWARE_GL):
            why.append(f"{name}: renderer {renderer or 'unknown'!r} is not a GPU")
            continue
        return name, renderer
    return None, "; ".join(why)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="measuring time per case")
    ap.add_argument("--batch", type=int, default=BATCH, help="envs in the batched driver-view row")
    ap.add_argument("--pipe", choices=("tinydisplay", "gl", "egl"), default=None, help="Panda3D pipe (OPENDS_GYM_RENDER_PIPE)")
    args = ap.parse_args()
    if args.pipe:
        os.environ["OPENDS_GYM_RENDER_PIPE"] = args.pipe
    from opends_gym.render.engine import PIPE_ENV, pipe_name

    cases: list[tuple[str, str, float, Callable[[], object], int]] = [
        ("env steps, kinematics", "-", 0.0, env_steps("kinematics"), 1),
        ("env steps, driver_view", "84x84", 5000.0, env_steps("driver_view"), 1),
        (f"driver_view, batch of {args.batch}", "84x84", 5000.0, batch_steps("driver_view", args.batch), args.batch),
        ("env steps, topdown", "84x84", 2000.0, env_steps("topdown"), 1),
        ("driver_view frame alone", "84x84", 0.0, view_frames(84, 84), 1),
        ("human window", "1280x720", 30.0, window_frames(1280, 720), 1),
    ]
    where = "window" if os.environ.get("DISPLAY") else "offscreen"
    print(f"pipe {pipe_name()}, task {TASK}, human window drawn {where}")
    print(f"{'case':<26}{'size':>10}{'per s (wall)':>14}{'per s (cpu)':>13}{'goal':>8}")

    def row(name: str, size: str, goal: float, fn: Callable[[], object], per_call: int = 1) -> None:
        wall, cpu = (per_call * r for r in rate(fn, args.seconds))
        print(f"{name:<26}{size:>10}{wall:>14.0f}{cpu:>13.0f}{(f'{goal:.0f}' if goal else '-'):>8}", flush=True)

    for name, size, goal, fn, per_call in cases:
        row(name, size, goal, fn, per_call)
    gpu, detail = gpu_pipe()
    if gpu is None:
        print(f"{'human window, GPU':<26}{'1920x1080':>10}{'not measured':>27}{60:>8}")
        print(f"  (no OpenGL pipe on a GPU here: {detail})")
        return
    before = os.environ.get(PIPE_ENV)
    os.environ[PIPE_ENV] = gpu
    try:
        row(f"human window, GPU ({gpu})", "1920x1080", 60.0, window_frames(1920, 1080))
    finally:
        if before is None:
            os.environ.pop(PIPE_ENV, None)
        else:
            os.environ[PIPE_ENV] = before
    print(f"  (GPU row: {detail}, shadows on)")


if __name__ == "__main__":
    main()
