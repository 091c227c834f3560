"""The package's shape: layers that hold, no import cycles, small modules and functions.

Every ``import`` statement under ``quadsim/`` counts, those inside functions
too (a lazy import still ties the two modules together); only imports under
``if TYPE_CHECKING:`` are left out.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "quadsim"

#: Layers from the bottom: a module may import its own layer and those below.
LAYERS = [
    ("quadsim.frames", "quadsim.errors", "quadsim._optional", "quadsim._kernel_cache",
     "quadsim._version"),
    ("quadsim.kinematics.rotations", "quadsim.kinematics.chains", "quadsim.kinematics"),
    ("quadsim.skeleton", "quadsim.commands"),
    ("quadsim.controller", "quadsim.kinematics.ik", "quadsim.kinematics.legs", "quadsim.mesh"),
    ("quadsim.locomotion", "quadsim.horse"),
    ("quadsim.analysis", "quadsim.io", "quadsim.robots"),
    ("quadsim.config",),
    ("quadsim.api",),
    ("quadsim.clipset", "quadsim.dataset"),
    ("quadsim.viz",),
    ("quadsim.cli", "quadsim.cli_rig", "quadsim.cli_clips", "quadsim.cli_retarget",
     "quadsim.cli_sweep", "quadsim.cli_clips_from", "quadsim.__main__", "quadsim"),
]

#: Pairs of the same layer that must not import each other (either way).
APART = [("quadsim.locomotion", "quadsim.horse")]

MAX_LINES = 600
MAX_PARAMETERS = 15


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The quadsim modules ``name`` imports (resolved to modules that exist)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_pkg = path.name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    out: set[str] = set()

    def visit(node):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for sub in child.orelse:
                    visit(sub)
                continue
            if isinstance(child, ast.Import):
                for a in child.names:
                    if a.name.split(".")[0] == "quadsim":
                        out.add(_existing(a.name, known))
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    up = base[: len(base) - (child.level - 1)]
                    mod = ".".join(up + ([child.module] if child.module else []))
                else:
                    mod = child.module or ""
                if mod.split(".")[0] != "quadsim":
                    continue
                for a in child.names:
                    sub = f"{mod}.{a.name}"
                    out.add(sub if sub in known else _existing(mod, known))
            visit(child)

    visit(tree)
    out.discard(name)
    return out


def _existing(mod: str, known: set[str]) -> str:
    while mod not in known and "." in mod:
        mod = mod.rsplit(".", 1)[0]
    return mod


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    mods = _modules()
    known = set(mods)
    return {name: _imports(name, path, known) for name, path in mods.items()}


def _layer(mod: str) -> tuple[int, str]:
    """(layer index, the layer entry that matched) of a module: its longest matching prefix."""
    best = (-1, "")
    for i, names in enumerate(LAYERS):
        for n in names:
            if (mod == n or mod.startswith(n + ".")) and len(n) > len(best[1]):
                best = (i, n)
    return best


def test_every_module_has_a_layer(graph):
    assert [m for m in graph if _layer(m)[0] < 0] == []


def test_no_module_imports_a_layer_above_its_own(graph):
    bad = []
    for mod, deps in graph.items():
        mine = _layer(mod)[0]
        for d in deps:
            if _layer(d)[0] > mine:
                bad.append(f"{mod} -> {d}")
    assert bad == []


def test_the_two_engines_do_not_import_each_other(graph):
    bad = []
    for a, b in APART:
        for mod, deps in graph.items():
            for x, y in ((a, b), (b, a)):
                if mod == x or mod.startswith(x + "."):
                    bad += [f"{mod} -> {d}" for d in deps if d == y or d.startswith(y + ".")]
    assert bad == []


def test_no_import_cycles(graph):
    """Tarjan's strongly connected components: every one must be a single module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in graph:
                continue
            if w not in index:
                strong(w)
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
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            strong(v)
    assert cycles == []


def test_no_module_over_600_lines():
    long = {str(p.relative_to(PACKAGE.parent)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}


def test_no_function_over_15_parameters():
    bad = []
    for p in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
                if a.args and a.args[0].arg in ("self", "cls"):
                    n -= 1
                if n > MAX_PARAMETERS:
                    bad.append(f"{p.relative_to(PACKAGE.parent)}:{node.lineno} "
                               f"{node.name} ({n})")
    assert bad == []


def test_the_checker_sees_a_cycle_and_a_layer_violation(tmp_path):
    """The import walk itself: a planted cycle and an upward import are found."""
    known = {"quadsim.frames", "quadsim.horse.x", "quadsim.cli"}
    f = tmp_path / "x.py"
    f.write_text("def f():\n    from quadsim.cli import main\nfrom ..frames import X\n")
    deps = _imports("quadsim.horse.x", f, known)
    assert deps == {"quadsim.cli", "quadsim.frames"}
    assert _layer("quadsim.cli")[0] > _layer("quadsim.horse.x")[0]
