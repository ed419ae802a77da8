"""The import graph of geoalpha: one direction, no cycles, no private names.

Reads the source with :mod:`ast`, so imports inside functions (the lazy ones)
count as much as those at the top of a module. The layers below are the
architecture of ``docs/architecture.md``: a module may import only modules of
lower layers (or, within a layer, none of the others).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "geoalpha"
if not PACKAGE.is_dir():  # the installed package (CI tests the wheel)
    import geoalpha

    PACKAGE = Path(geoalpha.__file__).parent

#: Highest first. A module imports only modules in later (lower) entries.
LAYERS: list[tuple[str, ...]] = [
    ("__main__",),
    ("cli",),
    ("__init__",),
    ("accessor",),
    ("tools",),
    ("dask",),
    ("pipeline",),
    ("comparison",),
    ("optimal",),
    ("options",),
    ("io", "shapes", "search", "knn", "checks", "sphere"),
    ("postgis",),
    (
        "crs",
        "kernel",
        "budget",
        "schema",
        "registration",
        "datasets",
        "distortion",
        "redact",
        "progress",
    ),
    ("errors",),
    ("_kernel",),  # compiled (src/), typed by _kernel.pyi: imports nothing of ours
]
RANK = {name: rank for rank, names in enumerate(LAYERS) for name in names}
#: Numeric code: numpy/scipy only.
NUMERIC = ("search",)
#: Imported by ``geoalpha --help``: the standard library (and click) only.
LIGHT = ("__init__", "cli", "options", "errors", "datasets")
HEAVY = {"numpy", "scipy", "pandas", "shapely", "geopandas", "pyproj", "pyogrio"}


def _modules() -> dict[str, ast.Module]:
    files = [*sorted(PACKAGE.glob("*.py")), PACKAGE / "_kernel.pyi"]
    return {p.stem: ast.parse(p.read_text()) for p in files}


def _type_checking_nodes(tree: ast.Module) -> set[int]:
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
    return skip


def _imports(name: str, tree: ast.Module, modules) -> list[tuple[str, str, int]]:
    """(imported module, imported name or "", line) of every import in ``tree``."""
    skip = _type_checking_nodes(tree)
    found = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found += [(a.name, "", node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from . import x / from .x import y
                base = "geoalpha" + (f".{base}" if base else "")
            for alias in node.names:
                if base == "geoalpha" and alias.name in modules:
                    found.append((f"geoalpha.{alias.name}", "", node.lineno))
                else:
                    found.append((base, alias.name, node.lineno))
    if name == "__init__":  # public names loaded on first use
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Assign)
                and getattr(node.targets[0], "id", "") == "_LAZY"
            ):
                found += [(v.value, "", node.lineno) for v in node.value.values]
    return found


def _edges():
    modules = _modules()
    edges = []
    for name, tree in modules.items():
        for module, item, line in _imports(name, tree, modules):
            if module == "geoalpha":
                edges.append((name, "__init__", item, line))
            elif module.startswith("geoalpha."):
                edges.append((name, module.split(".")[1], item, line))
    return modules, edges


def test_every_module_has_a_layer():
    modules, _ = _edges()
    assert sorted(set(modules) - set(RANK)) == []


def test_imports_point_down_the_layers():
    _, edges = _edges()
    upward = [
        f"geoalpha/{a}.py:{line} imports {b}"
        for a, b, _, line in edges
        if a != b and RANK[a] >= RANK[b] and not (a == "__main__" and b == "cli")
    ]
    assert upward == []


def test_no_import_cycle():
    _, edges = _edges()
    graph: dict[str, set[str]] = {}
    for a, b, _, _ in edges:
        if a != b:
            graph.setdefault(a, set()).add(b)
    state: dict[str, int] = {}
    cycles = []

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join([*path[path.index(nxt) :], nxt]))
            elif nxt not in state:
                visit(nxt, [*path, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert cycles == []


def test_no_private_name_crosses_modules():
    modules, edges = _edges()
    private = [
        f"geoalpha/{a}.py:{line} imports {b}.{item}"
        for a, b, item, line in edges
        if item.startswith("_") and not item.startswith("__")
    ]
    # module._name on an imported geoalpha module
    for name, tree in modules.items():
        aliases = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module == "geoalpha":
                aliases.update({a.asname or a.name: a.name for a in node.names})
            elif isinstance(node, ast.Import):
                aliases.update(
                    {
                        a.asname or a.name: a.name.split(".")[-1]
                        for a in node.names
                        if a.name.startswith("geoalpha.")
                    }
                )
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id in aliases
                and aliases[node.value.id] in modules
                and node.attr.startswith("_")
                and not node.attr.startswith("__")
            ):
                private.append(
                    f"geoalpha/{name}.py:{node.lineno} uses "
                    f"{aliases[node.value.id]}.{node.attr}"
                )
    assert private == []


@pytest.mark.parametrize(
    ("group", "forbidden"),
    [(NUMERIC, {"pandas", "geopandas", "shapely"}), (LIGHT, HEAVY)],
    ids=["numeric code: no pandas, no shapely", "--help path: no heavy import"],
)
def test_modules_stay_light(group, forbidden):
    modules = _modules()
    found = [
        f"geoalpha/{name}.py:{line} imports {module}"
        for name in group
        for module, _, line in _imports(name, modules[name], modules)
        if module.split(".")[0] in forbidden
        and not (group == LIGHT and _inside_function(modules[name], line))
    ]
    assert found == []


def _inside_function(tree: ast.Module, line: int) -> bool:
    """Whether ``line`` is in a function body (an import deferred to the call)."""
    return any(
        isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.lineno < line <= (node.end_lineno or node.lineno)
        for node in ast.walk(tree)
    )


def test_the_graph_sees_a_cycle_hidden_in_a_function():
    """The checks above can fail: a lazy import back up is an upward edge."""
    tree = ast.parse("def f():\n    from geoalpha import tools\n")
    found = _imports("kernel", tree, {"tools": None})
    assert found == [("geoalpha.tools", "", 2)]
    assert RANK["kernel"] > RANK["tools"]


def test_geoalpha_help_and_version_import_nothing_heavy():
    """``geoalpha --help`` and ``--version`` stay fast: no numpy, pandas, pyproj."""
    import os
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from click.testing import CliRunner\n"
        "from geoalpha.cli import main\n"
        "for args in (['--help'], ['--version'], ['hull', '--help']):\n"
        "    assert CliRunner().invoke(main, args).exit_code == 0, args\n"
        f"heavy = {sorted(HEAVY)!r}\n"
        "loaded = [m for m in heavy if m in sys.modules]\n"
        "assert not loaded, loaded\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
