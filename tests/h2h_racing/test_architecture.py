"""The parts of ``h2h_racing/`` and the imports allowed between them (docs/architecture.md).

Read from the sources with ``ast`` (every import counts: top-level, inside functions and under
``TYPE_CHECKING``), so a rule broken by a lazy import fails too. What an import of the env
leaves in ``sys.modules`` is checked by tests/h2h_racing/test_packaging.py.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / "h2h_racing"

# The folders installed into the h2h_racing namespace (pyproject's package-dir).
OUTSIDE = {"policies": "policies", "training": "training", "league": "league"}

BELOW_ENV = {"common", "config", "track", "sim", "sensors", "deepracer", "viz.render"}
# Part -> the parts it may import (itself always). Third-party rules are separate tests.
ALLOWED: dict[str, set[str]] = {
    "common": set(),
    "config": {"common"},
    "track": {"common"},
    "sim": {"common", "config", "track"},
    "sensors": {"common", "config", "track", "sim"},
    "deepracer": {"common", "config", "track", "sim"},
    # The spectator frames, which the env's render mode draws, sit below the env.
    "viz.render": {"common", "config", "track", "sim"},
    "envs": BELOW_ENV,
    "viz": BELOW_ENV | {"envs"},
    "policies": BELOW_ENV | {"envs"},
    "match": BELOW_ENV | {"envs", "viz", "policies"},
    "training": BELOW_ENV | {"envs", "viz", "policies", "match", "cli.help"},
    "league": BELOW_ENV | {"envs", "viz", "policies", "match", "training", "cli.help"},
    "cli.help": set(),
    "cli": BELOW_ENV | {"envs", "viz", "policies", "match", "training", "league", "root",
                        "cli.help"},
    "root": BELOW_ENV | {"envs"},
}
# Imports up the layers that are allowed, each for a reason (module -> imported module).
EXCEPTIONS: dict[tuple[str, str], str] = {
    ("h2h_racing.envs.single_agent", "h2h_racing.policies"):
        "the Gymnasium view drives its opponents by name (make_driver, imported when used)",
    ("h2h_racing.policies.trained", "h2h_racing.training.limits"):
        "a policy file's network sizes are checked against the limits training writes with",
}
NEVER_BELOW_TRAINING = {"torch", "rerun", "matplotlib", "rsl_rl", "ray"}
"""Optional dependencies the env and its core never import, not even lazily."""


def module_name(path: Path) -> str:
    rel = path.relative_to(REPO).with_suffix("")
    parts = list(rel.parts)
    if parts[0] in OUTSIDE:
        parts[0] = "h2h_racing." + parts[0]
    name = ".".join(parts)
    return name.removesuffix(".__init__")


def is_shim(path: Path) -> bool:
    """A deprecated old module path: its docstring says so, and it defines nothing."""
    tree = ast.parse(path.read_text())
    doc = ast.get_docstring(tree) or ""
    defines = [n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))]
    return doc.startswith("Deprecated:") and (not defines or path.stem == "env")


def sources() -> dict[str, Path]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")) + [
            p for folder in OUTSIDE for p in sorted((REPO / folder).rglob("*.py"))]:
        if "trained" in path.parts or (path.parent == PACKAGE and is_shim(path)):
            continue
        found[module_name(path)] = path
    return found


SOURCES = sources()


def part_of(module: str) -> str | None:
    """The part a module of the h2h_racing namespace belongs to (None: not ours)."""
    parts = module.split(".")
    if parts[0] != "h2h_racing":
        return None
    if len(parts) == 1 or parts[1] == "__init__":
        return "root"
    if parts[1] == "viz" and parts[2:3] == ["render"]:
        return "viz.render"
    if parts[1] == "cli" and parts[2:3] == ["help"]:
        return "cli.help"
    return parts[1] if parts[1] in ALLOWED else None


def imports(path: Path, lazy: bool = True) -> list[tuple[str, int]]:
    """Every module a source imports (``from a import b`` gives ``a.b`` when that is a module).

    ``lazy=False`` leaves out the imports inside functions (they run when called, after every
    module has loaded: the way to use a module that imports this one).
    """
    found = []
    tree = ast.parse(path.read_text())
    skip = set()
    if not lazy:
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                skip |= {id(n) for n in ast.walk(node)}
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                full = f"{node.module}.{a.name}"
                found.append((full if full in SOURCES else node.module, node.lineno))
    return found


def test_every_module_belongs_to_a_part() -> None:
    flat = [p.name for p in PACKAGE.glob("*.py")
            if p.stem not in ("__init__", "match") and not is_shim(p)]
    assert flat == [], (f"h2h_racing/ holds {flat} beside its parts: move each into the part "
                        "it belongs to (docs/architecture.md), or add a part here and there")
    homeless = [m for m in SOURCES if part_of(m) is None]
    assert homeless == [], f"modules of no known part: {homeless}; see docs/architecture.md"


def test_parts_import_only_the_parts_below_them() -> None:
    broken = []
    for module, path in SOURCES.items():
        part = part_of(module)
        if part is None:  # test_every_module_belongs_to_a_part names it
            continue
        for target, line in imports(path):
            other = part_of(target)
            if other is None or other == part or other in ALLOWED[part]:
                continue
            if (module, target) in EXCEPTIONS:
                continue
            broken.append(f"{path.relative_to(REPO)}:{line}: {part} imports {target} ({other})")
    assert broken == [], "imports across the parts' rules (docs/architecture.md):\n" + "\n".join(
        broken)


@pytest.mark.parametrize("library, allowed", [
    ("pymunk", ["h2h_racing/sim/physics.py"]),
    ("pettingzoo", ["h2h_racing/envs/parallel.py"]),
])
def test_one_module_imports_each_engine(library: str, allowed: list[str]) -> None:
    importers = sorted(str(path.relative_to(REPO)) for path in SOURCES.values()
                       if part_of(module_name(path)) not in ("training", "league", "cli")
                       and any(t.split(".")[0] == library for t, _ in imports(path)))
    assert importers == allowed


def test_env_and_core_never_import_training_or_viewer_libraries() -> None:
    broken = [f"{path.relative_to(REPO)}:{line}: {target}"
              for module, path in SOURCES.items() if part_of(module) in BELOW_ENV | {"envs"}
              for target, line in imports(path) if target.split(".")[0] in NEVER_BELOW_TRAINING]
    assert broken == []


def test_no_import_circle() -> None:
    """No two modules of h2h_racing/ import each other, directly or round a loop
    (``TYPE_CHECKING`` imports count: a type checker follows them; imports inside functions do
    not). policies/ is not held to it yet: registry -> scripted (types) -> planner -> registry."""
    own = {m: p for m, p in SOURCES.items() if p.is_relative_to(PACKAGE)}
    graph = {m: {t for t, _ in imports(p, lazy=False) if t in own and t != m}
             for m, p in own.items()}
    # Depth-first search for a back edge, reporting the circle it closes.
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for t in sorted(graph[m]):
            if state.get(t) == 1:
                return stack[stack.index(t):] + [t]
            if t not in state and (circle := visit(t)):
                return circle
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (circle := visit(m)):
            pytest.fail("import circle: " + " -> ".join(circle))
