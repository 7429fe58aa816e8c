"""The package's layering: no import circles between modules and no import from a lower layer
into a higher one, counting every import in a file (also those under TYPE_CHECKING or inside
functions), so that each layer can be read, tested and replaced on its own."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "opends_gym"

# lower first; a package may import only from packages before it in this list
LAYERS = [
    "version",
    "jsonsafe",
    "errors",
    "hints",
    "extras",
    "resources",
    "jit_child",
    "jit",
    "task",
    "sim",
    "control",
    "metrics",
    "render",
    "envs",
    "drivers",
    "record",
    "vector",
]
LAYERS += ["training", "human", "study", "data", "cli", "__init__"]


def _modules() -> dict[str, tuple[Path, bool]]:
    out = {}
    for f in PACKAGE.rglob("*.py"):
        parts = list(f.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (f, is_pkg)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    graph: dict[str, set[str]] = {}
    for name, (path, is_pkg) in mods.items():
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = name.split(".") if is_pkg else name.split(".")[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                subs = [f"{target}.{a.name}" for a in node.names]
                targets = subs if all(s in mods for s in subs) else [target, *(s for s in subs if s in mods)]
            else:
                continue
            deps.update(t for t in targets if t in mods and t != name)
        graph[name] = deps
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_import_circles() -> None:
    assert _cycles(_graph()) == []


def test_no_upward_imports_between_layers() -> None:
    upward = []
    for name, deps in _graph().items():
        src = name.split(".")[1] if "." in name else "__init__"
        for dep in deps:
            dst = dep.split(".")[1] if "." in dep else "__init__"
            if src != dst:
                assert src in LAYERS and dst in LAYERS, f"{name} or {dep} is in no layer of {LAYERS}"
                if LAYERS.index(dst) > LAYERS.index(src):
                    upward.append(f"{name} -> {dep}")
    assert upward == []


def test_the_checks_see_a_circle_and_an_upward_import() -> None:
    graph = {"opends_gym.sim.a": {"opends_gym.sim.b"}, "opends_gym.sim.b": {"opends_gym.sim.a"}, "opends_gym.sim.c": set()}
    assert _cycles(graph) == [["opends_gym.sim.a", "opends_gym.sim.b"]]
    assert LAYERS.index("envs") > LAYERS.index("sim")
