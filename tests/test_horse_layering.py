"""The data-driven horse engine's layering and size rules, read from its source.

``quadsim/horse`` sits beside the procedural engine and below the file
formats, the measurements, the viewers and the front door: it imports none of
them, not even inside a function. Its modules stay under 600 lines and its
functions (kernels included) under 16 parameters.
"""

import ast
from pathlib import Path

import pytest

HORSE = Path(__file__).resolve().parents[1] / "quadsim" / "horse"
MODULES = sorted(HORSE.glob("*.py"))
FORBIDDEN = ("quadsim.locomotion", "quadsim.analysis", "quadsim.io", "quadsim.viz",
             "quadsim.config", "quadsim.cli")


def _imports(path: Path) -> list[tuple[int, str]]:
    """Every module ``path`` imports, anywhere in it, as absolute dotted names."""
    package = "quadsim.horse"
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                name = f"{base}.{node.module}" if node.module else base
            else:
                name = node.module
            out.append((node.lineno, name))
            # ``from quadsim import io`` imports quadsim.io
            out += [(node.lineno, f"{name}.{a.name}") for a in node.names]
    return out


def test_the_walk_sees_relative_and_function_level_imports(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("def f():\n    from ..io.bvh import read_bvh\n    from . import turning\n",
                     encoding="utf-8")
    found = _imports(probe)
    assert (2, "quadsim.io.bvh") in found
    assert (3, "quadsim.horse") in found


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_the_engine_imports_no_layer_above_it(path):
    bad = [(line, name) for line, name in _imports(path)
           if any(name == f or name.startswith(f + ".") for f in FORBIDDEN)]
    assert not bad, f"{path.name} imports {bad}"


@pytest.mark.parametrize("path", [p for p in MODULES if p.name != "__init__.py"],
                         ids=lambda p: p.name)
def test_no_module_of_the_engine_imports_its_own_package(path):
    """``from . import x`` in a submodule imports ``quadsim.horse`` (whose ``__init__``
    imports the submodules): an import cycle."""
    assert all(name != "quadsim.horse" for _, name in _imports(path))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_modules_stay_under_600_lines(path):
    assert len(path.read_text(encoding="utf-8").splitlines()) <= 600


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_no_function_takes_more_than_15_parameters(path):
    long = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg) \
                + bool(a.kwarg)
            if n > 15:
                long.append((node.name, n))
    assert not long, f"{path.name}: {long}"


def _cycle(graph: dict) -> list | None:
    """An import cycle of ``graph`` (module -> imported modules), or None."""
    state: dict = {}

    def visit(node, path):
        state[node] = "open"
        for nxt in graph.get(node, ()):
            if state.get(nxt) == "open":
                return path[path.index(nxt):] + [nxt] if nxt in path else [node, nxt]
            if nxt not in state:
                found = visit(nxt, path + [nxt])
                if found:
                    return found
        state[node] = "done"
        return None

    for node in graph:
        if node not in state:
            found = visit(node, [node])
            if found:
                return found
    return None


def test_the_cycle_check_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a"}}) is None


def test_the_engine_modules_import_each_other_without_a_cycle():
    names = {f"quadsim.horse.{p.stem}" for p in MODULES if p.name != "__init__.py"}
    graph = {f"quadsim.horse.{p.stem}": {n for _, n in _imports(p) if n in names}
             for p in MODULES if p.name != "__init__.py"}
    assert {"quadsim.horse.playback", "quadsim.horse.placement"} <= graph["quadsim.horse.controller"]
    assert _cycle(graph) is None
