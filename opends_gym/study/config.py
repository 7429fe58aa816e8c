"""STUDY.yaml -> a frozen `Study`; every mistake is one line naming the file, line and key.

Why: a study runs for minutes to hours; a typo (`conditons:`, an env option the env does not
have, a condition without an agent) must stop it before the first episode, pointing at the line.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import inspect
import string
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..envs.registration import lookup_env_id, resolve_env_id
from ..errors import UserError
from ..hints import closest

STUDY_KEYS = (
    "name",
    "seed",
    "participants",
    "repetitions",
    "agent",
    "on_road_exit",
    "on_collision",
    "reference",
    "tasks",
    "conditions",
    "metrics",
    "ray",
    "power",
    "bootstrap",
    "backend",
)
TASK_KEYS = ("env", "env_args", "metrics", "drt", "max_seconds")
CONDITION_KEYS = ("load", "agent", "env_args", "drt", "instructions")
POWER_KEYS = ("target", "alpha", "simulations", "max_n")
AGENT_FIELDS = ("participant", "load", "condition", "task")
DEFAULT_AGENT = "participant:{participant}:{load}"  # drivers/participant.py's spec
BACKENDS = ("auto", "native", "single")  # study.native.choose


class Located(dict):  # type: ignore[type-arg]
    """A YAML mapping that remembers the line of itself and of each key (1-based)."""

    line = 0
    lines: dict[str, int]


class _Loader(yaml.SafeLoader):
    pass


def _mapping(loader: _Loader, node: yaml.MappingNode) -> Located:
    out = Located(loader.construct_mapping(node, deep=True))
    out.line = node.start_mark.line + 1
    out.lines = {str(k.value): k.start_mark.line + 1 for k, _ in node.value}
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)


@dataclass(frozen=True)
class DrtSpec:
    """A Detection Response Task (`envs.drt.DetectionResponseTask`) around the env, with its options."""

    options: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class TaskSpec:
    name: str
    target: str  # what `resolve_env_id` takes: an env id, a short name or a task path
    env_id: str
    env_args: dict[str, Any]
    metrics: tuple[str, ...] | None  # None: every scalar metric of the episode
    drt: DrtSpec | None = None


@dataclass(frozen=True)
class ConditionSpec:
    name: str
    load: str | None
    agent: str | None
    env_args: dict[str, Any]
    drt: DrtSpec | None
    instructions: str


@dataclass(frozen=True)
class PowerSpec:
    target: float = 0.8
    alpha: float = 0.05
    simulations: int = 1000
    max_n: int = 500


@dataclass(frozen=True)
class Study:
    path: Path
    name: str
    seed: int
    participants: int
    repetitions: int
    agent: str
    on_road_exit: str | None
    on_collision: str | None
    reference: str
    tasks: tuple[TaskSpec, ...]
    conditions: tuple[ConditionSpec, ...]
    metrics: tuple[str, ...] | None
    ray: bool
    power: PowerSpec = field(default_factory=PowerSpec)
    bootstrap: int = 2000
    backend: str = "auto"  # auto | native | single: where the virtual trials run (study.native)

    def condition(self, name: str) -> ConditionSpec:
        return next(c for c in self.conditions if c.name == name)


class _Where:
    """Formats `FILE:LINE: key: problem` for one mapping of the file."""

    def __init__(self, path: Path, node: Any, prefix: str = "") -> None:
        self.path, self.node, self.prefix = path, node, prefix

    def line(self, key: str | None = None) -> int:
        if isinstance(self.node, Located):
            return self.node.lines.get(key, self.node.line) if key is not None else self.node.line
        return 1

    def error(self, key: str | None, problem: str) -> UserError:
        name = f"{self.prefix}{key}" if key is not None else self.prefix.rstrip(".") or "study"
        return UserError(f"{self.path}:{self.line(key)}: {name}: {problem}")

    def child(self, key: str) -> _Where:
        return _Where(self.path, self.node.get(key) if isinstance(self.node, dict) else None, f"{self.prefix}{key}.")

    def check_keys(self, allowed: tuple[str, ...]) -> None:
        for key in self.node:
            if key not in allowed:
                match = closest(str(key), allowed)
                hint = f"; did you mean {match}?" if match else ""
                raise self.error(str(key), f"unknown key{hint} (keys: {', '.join(allowed)})")

    def get(self, key: str, kind: type | tuple[type, ...], default: Any) -> Any:
        value = self.node.get(key, default)
        kinds = kind if isinstance(kind, tuple) else (kind,)
        if value is default and default is None:
            return None
        if isinstance(value, bool) and bool not in kinds:
            raise self.error(key, f"expected {_kind_names(kinds)}, not {value!r}")
        if not isinstance(value, kinds):
            raise self.error(key, f"expected {_kind_names(kinds)}, not {value!r}")
        return value


def _kind_names(kinds: tuple[type, ...]) -> str:
    names = {int: "a whole number", float: "a number", str: "text", dict: "a mapping", list: "a list", bool: "true or false"}
    return " or ".join(names.get(k, k.__name__) for k in kinds)


def load_study(path: str | Path, participants: int | None = None) -> Study:
    """Read and check STUDY.yaml (`participants` overrides the file's count)."""
    p = Path(path)
    if not p.exists():
        p = bundled_study(str(path)) or p
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        shipped = ", ".join(bundled_study_names())
        raise UserError(f"{p}: no such study file (shipped examples: {shipped})") from None
    except IsADirectoryError:
        raise UserError(f"{p}: is a folder; give the STUDY.yaml file") from None
    try:
        doc = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = mark.line + 1 if mark is not None else 1
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise UserError(f"{p}:{line}: invalid YAML: {problem}") from None
    if not isinstance(doc, dict):
        raise UserError(f"{p}:1: study: expected a mapping of keys (name, tasks, conditions, ...)")
    top = _Where(p, doc)
    top.check_keys(STUDY_KEYS)
    for key in ("tasks", "conditions"):
        if key not in doc:
            raise top.error(None, f"missing key '{key}'")
    n = top.get("participants", int, 20)
    if participants is not None:
        n = participants
    reps = top.get("repetitions", int, 1)
    if n < 1:
        raise top.error("participants", f"must be at least 1, not {n}")
    if reps < 1:
        raise top.error("repetitions", f"must be at least 1, not {reps}")
    backend = top.get("backend", str, "auto")
    if backend not in BACKENDS:
        raise top.error("backend", f"must be {', '.join(BACKENDS)}, not {backend!r}")
    on_road_exit = top.get("on_road_exit", str, "recover")
    if on_road_exit not in ("terminate", "recover", "continue"):
        raise top.error("on_road_exit", f"must be terminate, recover or continue, not {on_road_exit!r}")
    on_collision = top.get("on_collision", str, "recover")  # (opends_gym.envs.collision)
    if on_collision not in ("terminate", "recover", "continue"):
        raise top.error("on_collision", f"must be terminate, recover or continue, not {on_collision!r}")
    agent = top.get("agent", str, DEFAULT_AGENT)
    _check_agent(top, "agent", agent)
    metrics = _metric_list(top, "metrics")
    tasks = _tasks(top)
    conditions = _conditions(top, tasks, agent)
    _check_clones(top, n, agent, tasks, conditions)
    names = [c.name for c in conditions]
    reference = top.get("reference", str, names[0])
    if reference not in names:
        raise top.error("reference", f"no condition {reference!r}{_hint(reference, names)} (conditions: {', '.join(names)})")
    return Study(
        path=p,
        name=top.get("name", str, p.stem),
        seed=top.get("seed", int, 0),
        participants=n,
        repetitions=reps,
        agent=agent,
        on_road_exit=on_road_exit,
        on_collision=on_collision,
        reference=reference,
        tasks=tasks,
        conditions=conditions,
        metrics=metrics,
        ray=top.get("ray", bool, False),
        power=_power(top),
        bootstrap=_positive(top, "bootstrap", 2000),
        backend=backend,
    )


def bundled_study_names() -> list[str]:
    from ..resources import configs_dir

    return sorted(f.stem for f in (configs_dir() / "studies").glob("*.yaml"))


def bundled_study(name: str) -> Path | None:
    """A shipped example study by name (`lct_load`, `brake`, `drt`), or None."""
    from ..resources import configs_dir

    path = configs_dir() / "studies" / f"{Path(name).stem}.yaml"
    return path if Path(name).stem == name and path.is_file() else None


def _hint(name: str, choices: list[str]) -> str:
    match = closest(name, choices)
    return f"; did you mean {match}?" if match else ""


def _positive(where: _Where, key: str, default: int) -> int:
    value = where.get(key, int, default)
    if value < 1:
        raise where.error(key, f"must be at least 1, not {value}")
    return int(value)


def _metric_list(where: _Where, key: str) -> tuple[str, ...] | None:
    value = where.get(key, list, None)
    if value is None:
        return None
    if not value or not all(isinstance(m, str) for m in value):
        raise where.error(key, "expected a list of metric names")
    return tuple(value)


def _check_agent(where: _Where, key: str, spec: str) -> None:
    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(spec) if f is not None]
    except ValueError as e:
        raise where.error(key, f"bad agent template {spec!r}: {e}") from None
    for f in fields:
        if f not in AGENT_FIELDS:
            raise where.error(key, f"unknown placeholder {{{f}}} in {spec!r} (placeholders: {', '.join(AGENT_FIELDS)})")


def _entries(where: _Where, key: str) -> list[tuple[str, Any, _Where]]:
    node = where.node.get(key)
    if not isinstance(node, dict) or not node:
        raise where.error(key, "expected a mapping of names to settings")
    sub = where.child(key)
    out = []
    for name, value in node.items():
        if value is None:
            value = Located()
            value.line, value.lines = sub.line(str(name)), {}
        if not isinstance(value, dict):
            raise sub.error(str(name), f"expected a mapping of settings, not {value!r}")
        out.append((str(name), value, _Where(where.path, value, f"{key}.{name}.")))
    return out


def _tasks(top: _Where) -> tuple[TaskSpec, ...]:
    out = []
    for name, _, where in _entries(top, "tasks"):
        where.check_keys(TASK_KEYS)
        target = where.get("env", str, name)
        local = where.path.parent / target  # a task folder next to STUDY.yaml
        if lookup_env_id(target) is None and not Path(target).is_absolute() and local.exists():
            target = str(local)
        try:
            env_id, base = resolve_env_id(target)
        except Exception as e:  # a task that does not load
            raise where.error("env", str(e)) from None
        if base.get("task") is not None and not Path(target).exists() and not _bundled(target):
            raise where.error("env", f"'{target}' is neither an env id nor a task")
        args = {**base, **_env_args(where, env_id)}
        max_s = where.get("max_seconds", (int, float), None)
        if max_s is not None:
            if not max_s > 0:
                raise where.error("max_seconds", f"must be above 0, not {max_s}")
            args["max_episode_s"] = float(max_s)
        out.append(TaskSpec(name, target, env_id, args, _metric_list(where, "metrics"), _drt(where)))
    return tuple(out)


def _bundled(name: str) -> bool:
    from ..task.bundled import bundled_task_names

    return name.lower() in (n.lower() for n in bundled_task_names())


def _conditions(top: _Where, tasks: tuple[TaskSpec, ...], agent: str) -> tuple[ConditionSpec, ...]:
    out = []
    for name, _, where in _entries(top, "conditions"):
        where.check_keys(CONDITION_KEYS)
        cond_agent = where.get("agent", str, None)
        if cond_agent is not None:
            _check_agent(where, "agent", cond_agent)
        load = where.get("load", str, None)
        if "{load}" in (cond_agent or agent) and load is None:
            raise where.error(None, f"the agent {(cond_agent or agent)!r} needs a load: give 'load:' or an 'agent:' spec")
        args: dict[str, Any] = {}
        for task in tasks:  # condition options must be valid for every task's env
            args = _env_args(where, task.env_id)
        out.append(ConditionSpec(name, load, cond_agent, args, _drt(where), where.get("instructions", str, "")))
    return tuple(out)


def format_agent(template: str, participant: int, load: str | None, condition: str, task: str) -> str:
    """One trial's agent spec from the study's or condition's template."""
    return template.format(participant=participant, load=load or "", condition=condition, task=task).rstrip(":")


def _check_clones(top: _Where, participants: int, agent: str, tasks: tuple[TaskSpec, ...], conditions: tuple[ConditionSpec, ...]) -> None:
    """A `bc:` agent's trials run with its clone's observation options (`study.clones`): each
    must be an option of the task's env, and no task or condition may set it otherwise."""
    from .clones import clone_options, conflicting_option

    for cond in conditions:
        template = cond.agent or agent
        here = top.child("conditions").child(cond.name) if cond.agent else top
        for task in tasks:
            fields = env_fields(task.env_id)
            args = {**task.env_args, **cond.env_args}
            for spec in sorted({format_agent(template, p, cond.load, cond.name, task.name) for p in range(participants)}):
                for key, value in clone_options(spec).items():
                    if fields and key not in fields:
                        problem = f"{spec} was trained with {key}={value!r}, not an option of {task.env_id} (task {task.name})"
                        raise here.error("agent", problem)
                clash = conflicting_option(spec, args)
                if clash is not None:
                    key, value = clash
                    owner = top.child("conditions").child(cond.name) if key in cond.env_args else top.child("tasks").child(task.name)
                    problem = f"condition {cond.name}'s agent {spec} was trained with {key}={value!r} (drop the option or use such a clone)"
                    raise owner.child("env_args").error(key, problem)


def _env_args(where: _Where, env_id: str) -> dict[str, Any]:
    args = where.get("env_args", dict, None)
    if args is None:
        return {}
    fields = env_fields(env_id)
    sub = where.child("env_args")
    for key in args:
        if fields and key not in fields:
            raise sub.error(str(key), f"not an option of {env_id}{_hint(str(key), sorted(fields))}")
    return dict(args)


def _drt(where: _Where) -> DrtSpec | None:
    value = where.node.get("drt")
    if value is None or value is False:
        return None
    if value is True:
        return DrtSpec()
    if not isinstance(value, dict):
        raise where.error("drt", "expected true or a mapping of DetectionResponseTask options")
    from ..envs.drt import DetectionResponseTask

    accepted = [n for n in inspect.signature(DetectionResponseTask.__init__).parameters if n not in ("self", "env")]
    sub = where.child("drt")
    for key in value:
        if key not in accepted:
            raise sub.error(str(key), f"not an option of the DRT{_hint(str(key), accepted)} (options: {', '.join(accepted)})")
    return DrtSpec(tuple(sorted(value.items())))


def env_fields(env_id: str) -> set[str]:
    """The option names `gym.make(env_id, ...)` accepts, without building it: its config dataclass's
    fields, its constructor's named parameters and the registration's kwargs (empty: not known)."""
    import gymnasium as gym

    spec = gym.spec(env_id)
    entry = spec.entry_point
    if isinstance(entry, str):
        module, _, name = entry.partition(":")
        entry = getattr(importlib.import_module(module), name)
    cls = getattr(entry, "config_class", None)
    names = {f.name for f in dataclasses.fields(cls)} if cls is not None else set()
    params: list[inspect.Parameter] = []
    if callable(entry):
        with contextlib.suppress(TypeError, ValueError):  # a builtin without a signature
            params = list(inspect.signature(entry).parameters.values())
    named = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    names |= {p.name for p in params if p.kind in named and p.name != "self"}
    return names | set(spec.kwargs)


def _power(top: _Where) -> PowerSpec:
    node = top.node.get("power")
    if node is None:
        return PowerSpec()
    if not isinstance(node, dict):
        raise top.error("power", "expected a mapping (target, alpha, simulations, max_n)")
    where = top.child("power")
    where.check_keys(POWER_KEYS)
    target = float(where.get("target", (int, float), 0.8))
    alpha = float(where.get("alpha", (int, float), 0.05))
    for key, value in (("target", target), ("alpha", alpha)):
        if not 0.0 < value < 1.0:
            raise where.error(key, f"must be between 0 and 1, not {value}")
    return PowerSpec(target, alpha, _positive(where, "simulations", 1000), _positive(where, "max_n", 500))
