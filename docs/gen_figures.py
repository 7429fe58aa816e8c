"""Regenerate the documentation's generated parts: env reference snippets, view pictures, CLI help.

Why: spaces, options, info keys, metrics, pictures and `--help` texts typed by hand go stale
the day the code changes; this script reads them from the real envs and the real parser.
Deterministic (seed 0, the rule driver, fixed terminal width) so a rerun on unchanged code
changes no file. Run from the repository root:

    python docs/gen_figures.py            # writes docs/generated/ and docs/images/envs/

`tests/test_docs.py` imports the cheap generators (`spaces_markdown`, `options_markdown`,
`env_slug`) and checks the committed snippets against them.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import io
import os
import re
import struct
import sys
import zlib
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import opends_gym

DOCS = Path(__file__).resolve().parent
GENERATED = DOCS / "generated"
IMAGES = DOCS / "images" / "envs"
SEED = 0
HELP_COLUMNS = "100"  # argparse wraps to $COLUMNS: fixed so the help text is the same everywhere
PICTURE_SIZE = (640, 360)
# simulated second at which each env's pictures are taken: just after the first stimulus shows in
# the observation with seed 0 (LCT sign_visible 9.6 s, reaction-test sign_kind 17.8 s, lead brake
# light 15.5 s, lead turn signal 79.1 s, ConTRe light 11.4 s), so the picture shows the task
PICTURE_AT_S = {
    "OpenDS/DrivingTask-v0": 18.4,
    "OpenDS/LaneChangeTest-v0": 10.2,
    "OpenDS/ReactionTest-v0": 18.4,
    "OpenDS/ConTRe-v0": 12.0,
    "OpenDS/BrakeReaction-v0": 16.0,
    "OpenDS/ThreeVehiclePlatoon-v0": 79.5,
}
DEFAULT_PICTURE_AT_S = 10.0


def env_ids() -> list[str]:
    """Every registered OpenDS env id, in registration order."""
    return [k for k in gym.registry if k.startswith("OpenDS/")]


def env_slug(env_id: str) -> str:
    """`OpenDS/LaneChangeTest-v0` -> `lane-change-test` (page and picture names)."""
    name = env_id.split("/", 1)[1].rsplit("-v", 1)[0]
    name = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "-", name)
    return name.lower()


def _env_class(env_id: str) -> type:
    module, _, cls = str(gym.spec(env_id).entry_point).partition(":")
    return getattr(__import__(module, fromlist=[cls]), cls)  # type: ignore[no-any-return]


def _space(space: gym.Space[Any]) -> str:
    return f"`{space!r}`"


def _space_rows(env_id: str, default: Any, option: str, names: Any) -> list[str]:
    """A markdown table of the space each value of `option` ("observation" or "action") gives."""
    rows = [f"| `{option}=` | space |", "|---|---|"]
    chosen = getattr(default.config, option)
    for name in names:
        env = default if name == chosen else gym.make(env_id, **{option: name}).unwrapped
        mark = " (default)" if name == chosen else ""
        rows.append(f"| `{name}`{mark} | {_space(getattr(env, f'{option}_space'))} |")
        if env is not default:
            env.close()
    return rows


def spaces_markdown(env_id: str) -> str:
    """Observation and action spaces of every `observation=` / `action=` choice, from the env itself."""
    from opends_gym.envs.actions import ACTION_TYPES
    from opends_gym.envs.observations import OBSERVATION_TYPES

    default = gym.make(env_id).unwrapped
    cfg = default.config
    out = ["### Observation spaces", ""]
    out += _space_rows(env_id, default, "observation", OBSERVATION_TYPES)
    names = getattr(default.obs_type, "names", ())
    out += ["", f"Slots of the default `{cfg.observation}` observation (SI units in the names):", ""]
    out += ["| index | name |", "|---:|---|"]
    out += [f"| {i} | `{n}` |" for i, n in enumerate(names)]
    out += ["", "### Action spaces", ""]
    out += _space_rows(env_id, default, "action", ACTION_TYPES)
    default.close()
    return "\n".join(out) + "\n"


def options_markdown(env_id: str) -> str:
    """The env's keyword arguments (its config dataclass) with their defaults."""
    cls = _env_class(env_id)
    out = ["### Options", "", f"Keyword arguments of `gym.make({env_id!r}, ...)` (`{cls.config_class.__name__}`):", ""]
    out += ["| option | default |", "|---|---|"]
    for f in dataclasses.fields(cls.config_class):
        value = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        out.append(f"| `{f.name}` | `{value!r}` |")
    return "\n".join(out) + "\n"


def _fmt(value: Any) -> str:
    if isinstance(value, bool | np.bool_):
        return str(bool(value))
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        v = float(value)
        return "0" if abs(v) < 1e-12 else f"{v:.4g}"  # rounding noise (1e-16) is not information
    return type(value).__name__


def manual_markdown(env_id: str) -> str:
    """The env class's docstring (its manual), headings moved under the page's own."""
    doc = inspect.getdoc(_env_class(env_id)) or ""
    return re.sub(r"^## ", "### ", doc, flags=re.MULTILINE) + "\n"


def run_episode(env_id: str) -> tuple[str, dict[str, np.ndarray]]:
    """Drive one seeded episode with the rule driver: info/metrics markdown and the two pictures."""
    from opends_gym.drivers.agents import make_agent
    from opends_gym.render import make_renderer

    env = gym.make(env_id)
    agent = make_agent("rule")
    obs, info = env.reset(seed=SEED)
    agent.reset(env.unwrapped, SEED)
    world = env.unwrapped.world
    at_s = PICTURE_AT_S.get(env_id, DEFAULT_PICTURE_AT_S)
    pictures: dict[str, np.ndarray] = {}
    first_info: dict[str, Any] | None = None
    steps = 0
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        steps += 1
        first_info = first_info or info
        if not pictures and world.t_s >= at_s - 1e-9:
            for view in ("driver_view", "topdown"):
                pictures[view] = make_renderer(view, world).render(*PICTURE_SIZE)
        if terminated or truncated:
            break
    metrics = info["episode_metrics"]
    how = "terminated" if terminated else "truncated"
    env.close()
    out = ["### Info keys", "", "Keys of `info` on every step, with their values on the first step of the episode below:", ""]
    out += ["| key | type | first step |", "|---|---|---:|"]
    for k, v in sorted(first_info.items()):
        kind = "tuple of event dicts" if k == "events" else type(v).__name__
        out.append(f"| `{k}` | {kind} | {'' if k == 'events' else _fmt(v)} |")
    out += ["", "`episode_metrics` (a dict) is added on the last step.", ""]
    out += ["### Episode metrics", ""]
    out += [
        f"`info['episode_metrics']` of one episode with the rule driver (`--agent rule`, seed {SEED}, default options): "
        f"{how} after {steps} policy steps ({world.t_s:.1f} simulated s).",
        "",
        "| metric | value |",
        "|---|---:|",
    ]
    out += [f"| `{k}` | {_fmt(v)} |" for k, v in sorted(metrics.items())]
    return "\n".join(out) + "\n", pictures


def pictures_markdown(env_id: str) -> str:
    slug = env_slug(env_id)
    at_s = PICTURE_AT_S.get(env_id, DEFAULT_PICTURE_AT_S)
    return (
        f"![{env_id}: driver view](../images/envs/{slug}-driver_view.png)\n"
        f"![{env_id}: top-down view](../images/envs/{slug}-topdown.png)\n\n"
        f'*Driver view (`render_view="driver_view"`) and top-down view (the default `rgb_array` render) '
        f"{at_s:g} simulated seconds into a seeded episode with the rule driver.*\n"
    )


ANALYZER_ENV, ANALYZER_AGENT = "OpenDS/LaneChangeTest-v0", "distracted:moderate"


def analyzer_figures() -> dict[str, Path]:
    """Record one seeded LCT episode of the moderately distracted driver, run the analyzer's
    report on it and copy its reaction, path and time-series pages to docs/images/analyzer-*.png."""
    import shutil
    import tempfile

    from opends_gym.drivers.agents import make_agent
    from opends_gym.record import RecordDrive, analyze, write_report

    with tempfile.TemporaryDirectory() as tmp:
        env = RecordDrive(gym.make(ANALYZER_ENV), Path(tmp) / "drive.mcap")
        agent = make_agent(ANALYZER_AGENT)
        obs, info = env.reset(seed=SEED)
        agent.reset(env.unwrapped, SEED)
        while True:
            obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
            if terminated or truncated:
                break
        env.close()
        pages = write_report(analyze(Path(tmp) / "drive.mcap"), Path(tmp) / "report.pdf")
        out: dict[str, Path] = {}
        for k, name in enumerate(pages, start=1):
            if name in ("reactions", "path", "timeseries"):
                out[name] = DOCS / "images" / f"analyzer-{name}.png"
                shutil.copyfile(Path(tmp) / f"report_{k}_{name}.png", out[name])
        return out


def write_png(path: Path, rgb: np.ndarray) -> None:
    """A plain RGB PNG with no timestamp or other metadata, so equal pixels give equal bytes."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def cli_help(command: str | None) -> str:
    """`opends-gym [COMMAND] --help` as the user sees it at a 100-column terminal."""
    from opends_gym.cli.main import build_parser

    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_COLUMNS
    try:
        parser, _ = build_parser()
        if command is not None:
            sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
            parser = sub.choices[command]
        buf = io.StringIO()
        parser.print_help(buf)
        return buf.getvalue()
    finally:
        if saved is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = saved


def cli_commands() -> list[str]:
    from opends_gym.cli.main import COMMANDS

    return [name for name, _, _ in COMMANDS]


def extras_markdown() -> str:
    """The optional dependency groups of pyproject.toml, as `pip install` sees them."""
    import tomllib  # Python 3.11+; only this generator needs it

    project = tomllib.loads((DOCS.parent / "pyproject.toml").read_text())["project"]
    out = ["| extra | installs |", "|---|---|"]
    out += [f"| `{name}` | {', '.join(f'`{r}`' for r in reqs)} |" for name, reqs in project["optional-dependencies"].items()]
    core = ", ".join(f"`{r}`" for r in project["dependencies"])
    return f"Core dependencies: {core}.\n\n" + "\n".join(out) + "\n"


def agents_markdown() -> str:
    """The `--agent` names and the distracted driver's levels, from the driver modules."""
    from opends_gym.drivers.agents import AGENT_FACTORIES
    from opends_gym.drivers.distracted import LEVEL_ORDER, LEVELS, DistractionParams

    fields = [f.name for f in dataclasses.fields(DistractionParams)]
    out = ["`--agent` names: " + ", ".join(f"`{n}`" for n in AGENT_FACTORIES) + ".", ""]
    out += ["| level | " + " | ".join(f"`{f}`" for f in fields) + " |", "|---|" + "---:|" * len(fields)]
    for level in LEVEL_ORDER:
        p = LEVELS[level]
        out.append(f"| `{level}` | " + " | ".join(f"{getattr(p, f):g}" for f in fields) + " |")
    return "\n".join(out) + "\n"


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text() != text:
        path.write_text(text)
        print(f"wrote {path.relative_to(DOCS.parent)}")


def main() -> int:
    for env_id in env_ids():
        slug = env_slug(env_id)
        episode_md, pictures = run_episode(env_id)
        parts = [pictures_markdown(env_id), "## Manual\n", manual_markdown(env_id), "## Reference\n"]
        parts += [spaces_markdown(env_id), options_markdown(env_id), episode_md]
        _write(GENERATED / "envs" / f"{slug}.md", "\n".join(parts))
        IMAGES.mkdir(parents=True, exist_ok=True)
        for view, rgb in pictures.items():
            write_png(IMAGES / f"{slug}-{view}.png", rgb)
    for name, path in analyzer_figures().items():
        print(f"wrote {path.relative_to(DOCS.parent)} (analyzer {name} page)")
    _write(GENERATED / "extras.md", extras_markdown())
    _write(GENERATED / "agents.md", agents_markdown())
    _write(GENERATED / "cli" / "opends-gym.txt", cli_help(None))
    for command in cli_commands():
        _write(GENERATED / "cli" / f"{command}.txt", cli_help(command))
    return 0


if __name__ == "__main__":
    assert opends_gym.__version__
    sys.exit(main())
