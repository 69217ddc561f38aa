"""The import graph of warp_cut against the dependency rules of docs/architecture.md.

The graph is built from the sources with ``ast`` (absolute and relative imports), without
importing the package. Checked: no import cycle between modules; each part (a subpackage, or a
top-level module) imports only the parts the rules table in docs/architecture.md allows, and
that table is the one this file holds (``RULES``); no import inside a function except the
documented optional dependencies (``LAZY_IMPORTS``). The checker itself is run on a small
synthetic package holding one violation of each kind, so a check that could not fail would
fail here.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

SOURCES = {"warp_cut": REPO / "warp_cut", "warp_cut.kernels": REPO / "kernels",
           "warp_cut.scenes": REPO / "scenes"}
"""Package name -> source directory (kernels/ and scenes/ install inside warp_cut)."""

RULES = {
    "errors": set(),
    "kernels": set(),
    "scenes": set(),
    "mesh": {"errors"},
    "sim": {"errors", "kernels", "mesh"},
    "solvers": {"errors", "kernels", "sim"},
    "cut": {"errors", "kernels", "mesh", "sim"},
    "io": {"errors", "mesh", "sim", "cut"},
    "simulator": {"errors", "kernels", "mesh", "sim", "solvers", "cut"},
    "scene": {"errors", "mesh", "sim", "solvers", "cut"},
    "ticks": set(),
    "runner": {"errors", "mesh", "sim", "solvers", "cut", "io", "simulator", "scene", "ticks"},
    "experiments": {"errors", "mesh", "sim", "solvers", "cut", "io", "simulator", "scene", "runner"},
    "batch": {"errors", "sim", "io", "scene", "runner"},
    "cli": {"errors", "mesh", "sim", "solvers", "cut", "io", "simulator", "scene", "runner",
            "experiments", "batch", "live"},
    "verify": {"errors", "mesh", "sim", "cut"},
    "live": {"errors", "mesh", "sim", "cut", "io", "scene", "runner", "simulator", "ticks"},
    "__init__": {"errors", "sim", "solvers", "cut", "simulator"},
}
"""Part -> the parts it may import (module-level imports; a part may always import itself)."""

LAZY_IMPORTS = {("warp_cut.batch.pool", "distributed"), ("warp_cut.live.server", "viser"),
                ("warp_cut.live.app", "warp_cut.live.viewer"), ("warp_cut.live.app", "warp_cut.live.player")}
"""(module, imported module) pairs allowed inside a function: optional dependencies only."""


@dataclass
class ImportGraph:
    """Imports between the modules of a package tree.

    Attributes:
        modules: Module name -> source file.
        edges: Module -> the package modules it imports at module level.
        lazy: (module, imported module, line) of every import inside a function (any target).
    """

    modules: dict[str, Path]
    edges: dict[str, set[str]] = field(default_factory=dict)
    lazy: list[tuple[str, str, int]] = field(default_factory=list)


def _module_names(sources: dict[str, Path]) -> dict[str, Path]:
    """Module name -> file of every .py file under the source directories."""
    modules = {}
    for package, root in sources.items():
        for path in sorted(root.rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join([package, *parts])] = path
    return modules


def _imports(node: ast.AST, in_function: bool = False):
    """(import statement, whether it sits inside a function) for every import below ``node``."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.Import, ast.ImportFrom)):
            yield child, in_function
        nested = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        yield from _imports(child, nested)


def _targets(statement, module: str, modules: dict[str, Path]) -> list[str]:
    """The modules an import statement names (``from a import b`` is ``a.b`` if that is a module)."""
    if isinstance(statement, ast.Import):
        return [alias.name for alias in statement.names]
    base = statement.module or ""
    if statement.level:
        package = module if modules[module].name == "__init__.py" else module.rpartition(".")[0]
        parts = package.split(".")[: len(package.split(".")) - (statement.level - 1)]
        base = ".".join(parts + ([statement.module] if statement.module else []))
    return [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in statement.names]


def build_graph(sources: dict[str, Path], root: str = "warp_cut") -> ImportGraph:
    """The import graph of the modules under ``sources``; edges keep only ``root``'s modules."""
    graph = ImportGraph(_module_names(sources))
    for module, path in graph.modules.items():
        edges = graph.edges.setdefault(module, set())
        for statement, in_function in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            for target in _targets(statement, module, graph.modules):
                if in_function:
                    graph.lazy.append((module, target, statement.lineno))
                elif target == root or target.startswith(root + "."):
                    edges.add(target)
    return graph


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as [m0, m1, ..., m0], or None (depth-first search)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        path.pop()
        state[node] = 2
        return None

    for start in sorted(edges):
        if start not in state and (found := visit(start)):
            return found
    return None


def part_of(module: str) -> str:
    """The part a module belongs to: its subpackage or top-level module (``__init__`` for the root)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def rule_violations(graph: ImportGraph, rules: dict[str, set[str]]) -> list[str]:
    """Every module-level import from one part into a part the rules do not allow."""
    problems = []
    for module, targets in sorted(graph.edges.items()):
        source = part_of(module)
        if source not in rules:
            problems.append(f"{module}: part {source!r} has no dependency rule")
            continue
        for target in sorted(targets):
            if part_of(target) != source and part_of(target) not in rules[source]:
                problems.append(f"{module} imports {target}: {source} may not depend on {part_of(target)}")
    return problems


def lazy_violations(graph: ImportGraph, allowed: set[tuple[str, str]]) -> list[str]:
    """Every import inside a function that is not in the allow-list."""
    return [f"{module}:{line} imports {target} inside a function"
            for module, target, line in graph.lazy if (module, target) not in allowed]


def documented_rules(text: str) -> dict[str, set[str]]:
    """The rules table of docs/architecture.md: rows ``| `part` | `a`, `b` |`` (``nothing`` for none)."""
    section = text.split("## Dependency rules", 1)[1].split("\n## ", 1)[0]
    rules = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 2 and re.fullmatch(r"`[\w.]+`", cells[0]):
            rules[cells[0].strip("`").removeprefix("warp_cut.")] = set(re.findall(r"`([\w.]+)`", cells[1]))
    return rules


# --------------------------------------------------------------------------- the package
GRAPH = build_graph(SOURCES)


def test_every_module_is_found():
    assert "warp_cut.sim.model" in GRAPH.modules and "warp_cut.kernels.springs" in GRAPH.modules
    assert len(GRAPH.modules) > 50


def test_no_import_cycle_between_modules():
    assert find_cycle(GRAPH.edges) is None, " -> ".join(find_cycle(GRAPH.edges))


def test_parts_import_only_what_the_rules_allow():
    assert rule_violations(GRAPH, RULES) == []


def test_every_part_has_a_rule():
    assert {part_of(m) for m in GRAPH.modules} == set(RULES)


def test_nothing_in_the_library_imports_the_command_line():
    importers = {m for m, targets in GRAPH.edges.items() if "warp_cut.cli" in targets}
    assert importers == set()
    assert all("cli" not in allowed for allowed in RULES.values())


def test_no_import_inside_a_function_but_optional_dependencies():
    assert lazy_violations(GRAPH, LAZY_IMPORTS) == []


def test_the_documented_rules_are_the_checked_rules():
    text = (REPO / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert documented_rules(text) == RULES


# --------------------------------------------------------------------------- the checker
def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_the_checker_finds_each_kind_of_violation(tmp_path):
    # a sim module reaching into cut, a cycle mesh.a -> mesh.b -> mesh.a, a lazy import
    _write(tmp_path / "pkg", {
        "__init__.py": "from .sim import model\n",
        "sim/__init__.py": "",
        "sim/model.py": "import numpy\nfrom ..cut.cutter import Cutter\n",
        "cut/__init__.py": "",
        "cut/cutter.py": "from ..sim import model\nfrom . import classes\n",
        "cut/classes.py": "",
        "mesh/__init__.py": "",
        "mesh/a.py": "from .b import f\n",
        "mesh/b.py": "from pkg.mesh import a\n\ndef f():\n    import json\n    return json\n",
    })
    graph = build_graph({"pkg": tmp_path / "pkg"}, root="pkg")
    assert graph.edges["pkg.cut.cutter"] == {"pkg.sim.model", "pkg.cut.classes"}
    assert graph.edges["pkg.sim.model"] == {"pkg.cut.cutter"}  # numpy is not ours
    cycle = find_cycle(graph.edges)
    assert cycle is not None and cycle[0] == cycle[-1] and len(cycle) == 3
    assert set(cycle) in ({"pkg.mesh.a", "pkg.mesh.b"}, {"pkg.sim.model", "pkg.cut.cutter"})
    rules = {"__init__": {"sim"}, "sim": set(), "cut": {"sim"}, "mesh": set()}
    assert rule_violations(graph, rules) == [
        "pkg.sim.model imports pkg.cut.cutter: sim may not depend on cut"]
    assert lazy_violations(graph, set()) == ["pkg.mesh.b:4 imports json inside a function"]
    assert lazy_violations(graph, {("pkg.mesh.b", "json")}) == []
    del rules["mesh"]
    assert "pkg.mesh.a: part 'mesh' has no dependency rule" in rule_violations(graph, rules)


def test_documented_rules_are_read_from_the_table():
    text = ("# x\n\n## Dependency rules\n\n| part | may import |\n|---|---|\n"
            "| `mesh` | `errors` |\n| `sim` | `errors`, `mesh` |\n| `errors` | nothing |\n\n## Next\n"
            "| `cut` | `sim` |\n")
    assert documented_rules(text) == {"mesh": {"errors"}, "sim": {"errors", "mesh"}, "errors": set()}


# --------------------------------------------------------------------------- the module table
def documented_modules(text: str) -> set[str]:
    """Module files docs/architecture.md names: the top-level modules of its tree block
    (``  simulator.py  ...``) and every module of its ``| module | owns |`` table, as paths
    relative to the package (``cut/cutter.py``); a bare name in a cell (``bezier.py``) is in the
    folder of the last one with a folder (``cut/curve/incision.py``, ``bezier.py``)."""
    tree = text.split("## The tree", 1)[1].split("```", 2)[1]
    names = {m.group(1) for m in re.finditer(r"^  (\w+\.py)\s", tree, re.MULTILINE)}
    table = text.split("| module | owns |", 1)[1].split("\n\n", 1)[0]
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        folder = ""
        for name in re.findall(r"`([\w/]+\.py)`", cells[0]):
            if "/" in name:
                folder = name.rsplit("/", 1)[0] + "/"
                names.add(name)
            else:
                names.add(folder + name)
    return names


def module_files(graph: ImportGraph) -> set[str]:
    """Every module file of the package but the ``__init__`` of subpackages, relative to the
    package (``kernels/`` for warp_cut.kernels), the package's own ``__init__.py`` included."""
    files = set()
    for name, path in graph.modules.items():
        if path.name == "__init__.py" and name != "warp_cut":
            continue
        parts = name.split(".")[1:]
        files.add("/".join(parts) + ".py" if parts else "__init__.py")
    return files


def test_the_documented_modules_are_the_modules():
    text = (REPO / "docs" / "architecture.md").read_text(encoding="utf-8")
    documented = documented_modules(text)
    actual = module_files(GRAPH)
    assert sorted(actual - documented) == [], "modules docs/architecture.md does not name"
    assert sorted(documented - actual) == [], "docs/architecture.md names modules that do not exist"


def test_documented_modules_are_read_from_the_tree_and_the_table():
    text = ("## The tree\n\n```\nkernels/  x\nwarp_cut/\n  __init__.py  api\n  cli.py    top\n  mesh/  m\n```\n\n"
            "| module | owns |\n|---|---|\n| `cut/a.py`, `b.py` | x |\n| `sim/c.py` | y |\n\n## Next\n"
            "| `io/d.py` | z |\n")
    assert documented_modules(text) == {"__init__.py", "cli.py", "cut/a.py", "cut/b.py", "sim/c.py"}
