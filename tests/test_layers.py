"""The package's layers depend downwards only (README, "Layers"): no import cycle among ``taskcond`` modules,
imports inside functions counted (``TYPE_CHECKING`` blocks are not), and no layer importing one above it."""

from __future__ import annotations

import ast
from pathlib import Path

import taskcond

ROOT = Path(taskcond.__file__).parent

LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("vocabulary", ("conditions", "primitives", "relations", "examples", "instructions", "dmp")),
    ("llm", ("llm", "generator", "code_form", "grounding", "probe", "decompose")),
    ("core", ("execution",)),
    ("simulator", ("sim",)),
    ("environment", ("envs",)),
    ("tasks", ("tasks",)),
    ("world adapter", ("worlds",)),
    ("viewing", ("viz",)),
    ("application", ("application", "il", "evaluation", "results", "reproduce", "combinations")),
    ("cli", ("cli",)),
)
"""Layers from the bottom up, each with its top-level modules and packages of ``taskcond``. A layer may
import the layers below it, never one above; the simulator, the environment and the task suite never
import the executor core (``core`` sits below them only in this order)."""

APART = {("core", "simulator"), ("core", "environment"), ("core", "tasks"), ("llm", "core")}
"""Pairs (importer, imported) of layers that know nothing of each other although one sits above the other:
the executor core knows neither the simulator, the environment nor the task suite (only the world adapter
does), and ``core`` above ``llm`` does not make the LLM layer a dependency of the simulator's."""

FORBIDDEN_IN_CORE = ("pybullet",)
"""Third-party modules the executor core must not import."""

SHORT = ("execution", "application", "cli", "worlds")
"""Packages whose functions are at most :data:`LONGEST` lines, or say why on a ``# long:`` line above."""
LONGEST = 60
"""Most lines of a function, its signature and docstring included."""


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            inside.update(id(n) for n in ast.walk(node))
    return inside


def _imports(path: Path, name: str) -> set[str]:
    """Every module ``path`` (module ``name``) imports, at any depth, as absolute dotted names."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _type_checking_nodes(tree)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, *([base] if base else [])])
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def _parents(module: str, importer: str) -> set[str]:
    """The packages that importing ``module`` initializes (``a.b`` for ``a.b.c``), but those ``importer``
    lies in (a package's ``__init__`` importing its own modules is no cycle)."""
    parts = module.split(".")
    parents = {".".join(parts[:k]) for k in range(2, len(parts))}
    return {q for q in parents if not importer.startswith(q + ".")}


def _graph() -> dict[str, set[str]]:
    paths = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph = {}
    for n, p in paths.items():
        deps = _imports(p, n)
        deps |= {q for d in deps for q in _parents(d, n)}
        graph[n] = {d for d in deps if d in paths and d != n}
    return graph


def _layer(module: str) -> str | None:
    parts = module.split(".")
    if len(parts) < 2:
        return None
    for layer, members in LAYERS:
        if parts[1] in members:
            return layer
    return None


def test_every_module_has_a_layer():
    unplaced = sorted(m for m in _graph() if m != "taskcond" and _layer(m) is None)
    assert not unplaced, f"modules in no layer of LAYERS: {unplaced}"


def test_no_import_cycle():
    graph = _graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while (w := stack.pop()) != v:
                component.append(w)
            if component:
                cycles.append(sorted([v, *component]))

    for v in graph:
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_layers_import_downwards_only():
    order = {layer: k for k, (layer, _) in enumerate(LAYERS)}
    wrong = []
    for module, deps in _graph().items():
        mine = _layer(module)
        for dep in deps:
            theirs = _layer(dep)
            if mine is None or theirs is None or mine == theirs:
                continue
            if order[theirs] > order[mine] or (mine, theirs) in APART:
                wrong.append(f"{module} ({mine}) imports {dep} ({theirs})")
    assert not wrong, "\n".join(sorted(wrong))


def test_core_knows_no_simulator():
    core = [p for p in (ROOT / "execution").rglob("*.py")]
    wrong = [
        f"{p.name} imports {d}"
        for p in core
        for d in _imports(p, _module_name(p))
        if d.split(".")[0] in FORBIDDEN_IN_CORE
    ]
    assert not wrong, wrong


def test_functions_are_short_or_say_why():
    long = []
    for package in SHORT:
        for path in (ROOT / package).rglob("*.py"):
            lines = path.read_text(encoding="utf-8").splitlines()
            for node in ast.walk(ast.parse("\n".join(lines))):
                if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    continue
                first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
                if node.end_lineno - node.lineno + 1 > LONGEST and not lines[first - 2].strip().startswith(
                    "# long:"
                ):
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}")
    assert not long, f"functions over {LONGEST} lines without a '# long:' reason: {long}"
