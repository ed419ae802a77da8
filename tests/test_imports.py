"""The import rules of geoalpha: four layers, a base and a wing.

Reads the source with :mod:`ast`, so imports inside functions (the lazy ones)
count as much as those at the top of a module. The layers are those of
``docs/architecture.md``: data flows down from the faces to the kernel, and
each rule below says which layer never imports which.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from compat import requires_dask

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "geoalpha"
if not PACKAGE.is_dir():  # the installed package (CI tests the wheel)
    import geoalpha

    PACKAGE = Path(geoalpha.__file__).parent

#: The layer of every module outside the packages named after their layer
#: (``geoalpha/_frame/``, ``geoalpha/_arrays/``, ``geoalpha/_io/``).
LAYER_OF = {
    "__init__": "faces",
    "__main__": "faces",
    "_cli": "faces",
    "_hulls": "faces",
    "_accessor": "faces",
    "_registration": "faces",
    "dask": "faces",
    "plot": "faces",
    "_core": "kernel",
    "_kernel": "kernel",
    "_options": "base",
    "errors": "base",
    "_crs_parsing": "base",
    "datasets": "io",
}
PACKAGES = {"_frame": "frame", "_arrays": "arrays", "_io": "io"}
LAYERS = ("faces", "frame", "arrays", "kernel", "base", "io")

#: (layer, layers it never imports, why). Data flows down: faces -> frame ->
#: arrays -> kernel, all on the base; the I/O wing serves the faces.
RULES = [
    ("kernel", {"faces", "frame", "arrays", "io"}, "the kernel never imports above"),
    ("arrays", {"faces", "frame", "io"}, "the array API never imports the frame"),
    ("frame", {"faces", "io"}, "the frame never imports the faces or the I/O wing"),
    ("io", {"faces", "frame", "arrays", "kernel"}, "the I/O wing uses the base only"),
    (
        "base",
        {"faces", "frame", "arrays", "kernel", "io"},
        "the base imports nothing of ours but the base",
    ),
]
#: Inside the base: ``errors`` imports nothing of ours, ``crs_parsing`` only
#: ``errors``; ``_kernel`` (compiled) imports nothing of ours.
BOTTOM = {"errors": set(), "_crs_parsing": {"errors"}, "_kernel": set()}
#: Numeric code: numpy/scipy only.
NUMERIC = ("_arrays.search",)
#: Imported by ``geoalpha --help``: the standard library (and click) only.
LIGHT = ("__init__", "_cli", "_options", "errors", "_io", "datasets")
HEAVY = {"numpy", "scipy", "pandas", "shapely", "geopandas", "pyproj", "pyogrio"}


def _name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts.pop()
    return ".".join(parts)


def layer(name: str) -> str:
    """Return the layer of the module ``name`` (``"_frame.crs"``, ``"_cli"``)."""
    return PACKAGES.get(name.split(".")[0]) or LAYER_OF[name]


def _files() -> list[Path]:
    return [*sorted(PACKAGE.rglob("*.py")), PACKAGE / "_kernel.pyi"]


def _modules() -> dict[str, ast.Module]:
    return {_name(p): ast.parse(p.read_text()) for p in _files()}


def _type_checking_nodes(tree: ast.Module) -> set[int]:
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
    return skip


def _imports(name: str, tree: ast.Module, modules) -> list[tuple[str, str, int]]:
    """(imported module, imported name or "", line) of every import in ``tree``."""
    skip = _type_checking_nodes(tree)
    package = "geoalpha" + (f".{name}" if name in PACKAGES else "")
    if "." in name:
        package = "geoalpha." + name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found += [(a.name, "", node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from . import x / from .x import y
                base = package + (f".{base}" if base else "")
            for alias in node.names:
                sub = f"{base}.{alias.name}".removeprefix("geoalpha.")
                if base.startswith("geoalpha") and sub in modules:
                    found.append((f"geoalpha.{sub}", "", node.lineno))
                else:
                    found.append((base, alias.name, node.lineno))
    for node in ast.walk(tree):  # modules loaded on first use (geoalpha, geoalpha._io)
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Dict):
            found += [
                (v.value, "", node.lineno)
                for v in node.value.values
                if isinstance(v, ast.Constant)
                and str(v.value).startswith("geoalpha.")
                and str(v.value).removeprefix("geoalpha.") in modules
            ]
        if isinstance(node, ast.Call) and ast.unparse(node.func).endswith(
            "import_module"
        ):
            arg = node.args[0] if node.args else None
            if isinstance(arg, ast.Constant) and str(arg.value).startswith("geoalpha."):
                found.append((arg.value, "", node.lineno))
    return found


def _edges():
    """(importer, imported, imported name, line) between modules of geoalpha."""
    modules = _modules()
    edges = []
    for name, tree in modules.items():
        for module, item, line in _imports(name, tree, modules):
            if module == "geoalpha":
                edges.append((name, "__init__", item, line))
            elif module.startswith("geoalpha."):
                target = module.removeprefix("geoalpha.")
                while target not in modules:  # geoalpha.x.y where y is a name
                    target = target.rsplit(".", 1)[0]
                edges.append((name, target, item, line))
    return modules, edges


def _path(name: str) -> str:
    if name == "_kernel":
        return "geoalpha/_kernel.pyi"
    if name in PACKAGES:
        return f"geoalpha/{name}/__init__.py"
    return "geoalpha/" + name.replace(".", "/") + ".py"


def test_every_module_has_a_layer():
    modules, _ = _edges()
    missing = []
    for name in modules:
        try:
            layer(name)
        except KeyError:
            missing.append(_path(name))
    assert missing == []


@pytest.mark.parametrize(("importer", "never", "why"), RULES, ids=[r[2] for r in RULES])
def test_layer_rules(importer, never, why):
    _, edges = _edges()
    broken = [
        f"{_path(a)}:{line} imports {b} ({layer(b)})"
        for a, b, _, line in edges
        if layer(a) == importer and layer(b) in never
    ]
    assert broken == [], why


def test_the_bottom_of_the_base():
    _, edges = _edges()
    broken = [
        f"{_path(a)}:{line} imports {b}"
        for a, b, _, line in edges
        if a in BOTTOM and b != a and b not in BOTTOM[a]
    ]
    assert broken == []


def test_no_import_cycle():
    _, edges = _edges()
    graph: dict[str, set[str]] = {}
    for a, b, _, _ in edges:
        if a != b and not (a == "__main__" and b == "_cli"):
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
        f"{_path(a)}:{line} imports {b}.{item}"
        for a, b, item, line in edges
        if item.startswith("_") and not item.startswith("__")
    ]
    # module._name on an imported geoalpha module
    for name, tree in modules.items():
        aliases = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                "geoalpha"
            ):
                for a in node.names:
                    sub = f"{node.module}.{a.name}".removeprefix("geoalpha.")
                    aliases[a.asname or a.name] = sub
            elif isinstance(node, ast.Import):
                aliases.update(
                    {
                        a.asname or a.name: a.name.removeprefix("geoalpha.")
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
                    f"{_path(name)}:{node.lineno} uses "
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
        f"{_path(name)}:{line} imports {module}"
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


def test_the_rules_see_an_import_hidden_in_a_function():
    """The checks above can fail: a lazy import of the frame breaks a rule."""
    modules = _modules()
    tree = ast.parse("def f():\n    from geoalpha._frame import pipeline\n")
    found = _imports("_core", tree, modules)
    assert found == [("geoalpha._frame.pipeline", "", 2)]
    assert layer("_frame.pipeline") in RULES[0][1]


def _table_modules() -> list[str]:
    """The module paths in the module table of ``docs/architecture.md``."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    return re.findall(r"^\| [^|]* \| `(geoalpha/[\w/.]+)` \|", text, flags=re.M)


@pytest.mark.skipif(
    not (ROOT / "docs").is_dir(), reason="the docs are in the source checkout"
)
def test_the_architecture_page_lists_every_module():
    """docs/architecture.md's module table: every module, each in its layer."""
    rows = _table_modules()
    files = {str(p.relative_to(PACKAGE.parent)) for p in _files()}
    assert sorted(set(rows) - files) == [], "rows for files that do not exist"
    assert sorted(files - set(rows)) == [], "modules missing from the table"
    assert len(rows) == len(set(rows))
    text = (ROOT / "docs" / "architecture.md").read_text()
    for row_layer, path in re.findall(
        r"^\| ([^|]*) \| `(geoalpha/[\w/.]+)` \|", text, flags=re.M
    ):
        name = _name(PACKAGE.parent / path) if path.endswith(".py") else "_kernel"
        assert row_layer.strip() in ("", layer(name)), path


def test_geoalpha_help_and_version_import_nothing_heavy():
    """``geoalpha --help`` and ``--version`` stay fast: no numpy, pandas, pyproj."""
    import os
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from click.testing import CliRunner\n"
        "from geoalpha._cli import main\n"
        "for args in (['--help'], ['--version'], ['hull', '--help']):\n"
        "    assert CliRunner().invoke(main, args).exit_code == 0, args\n"
        f"heavy = {sorted(HEAVY)!r}\n"
        "loaded = [m for m in heavy if m in sys.modules]\n"
        "assert not loaded, loaded\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr


#: The public modules: every other module's name starts with an underscore.
PUBLIC_MODULES = {"__init__", "__main__", "dask", "datasets", "errors", "plot"}


def test_the_public_surface_is_small_and_resolves():
    """``geoalpha.__all__``: what users call, about 40 names at most, each loaded."""
    import geoalpha
    from geoalpha import datasets

    assert len(geoalpha.__all__) <= 40
    assert len(set(geoalpha.__all__)) == len(geoalpha.__all__)
    assert geoalpha.__all__[:4] == ["hull", "explain", "curve", "outlier_rows"]
    for name in geoalpha.__all__:
        value = getattr(geoalpha, name)
        assert name == "__version__" or value.__doc__, name
    assert callable(geoalpha.read_points) and callable(geoalpha.write_hulls)
    assert callable(geoalpha.read_postgis) and callable(geoalpha.write_postgis)
    assert geoalpha.datasets is datasets and callable(datasets.load)
    for gone in ("hulls", "kernel", "options", "frame", "arrays", "io"):
        assert gone not in geoalpha.__all__


def test_internal_modules_are_private():
    """Every module outside :data:`PUBLIC_MODULES` has a name with an underscore."""
    public = {
        name
        for name in _modules()
        if not any(part.startswith("_") for part in name.split("."))
    }
    assert public == PUBLIC_MODULES - {"__init__", "__main__"}


@pytest.mark.skipif(
    not (ROOT / "docs").is_dir(), reason="the docs are in the source checkout"
)
def test_the_api_reference_lists_the_public_names():
    """docs/api/index.rst documents ``__all__`` and geoalpha.dask, nothing internal."""
    import geoalpha

    text = (ROOT / "docs" / "api" / "index.rst").read_text()
    listed = re.findall(r"^   ([\w.]+)$", text, flags=re.M)
    assert not [name for name in listed if "._" in name or name.startswith("_")]
    top = {name for name in listed if "." not in name}
    assert top == set(geoalpha.__all__) - {"__version__", "datasets"}
    assert {name for name in listed if "." in name} <= {
        "dask.hull",
        "dask.DaskAlphaAccessor",
        "dask.explain",
        "dask.curve",
        "datasets.load",
        "datasets.path",
        "datasets.DATASETS",
    }


@requires_dask
def test_public_dask_path_keeps_working():
    """``geoalpha.dask`` (the ``dask`` extra) imports, as documented."""
    import geoalpha
    import geoalpha.dask

    assert callable(geoalpha.dask.hull)


@pytest.mark.skipif(sys.platform != "linux", reason="glibc's static TLS block")
def test_the_kernel_loads_when_static_tls_is_used_up(tmp_path):
    # A library built for static TLS takes a share of a small block that glibc
    # reserves when the process starts; once other libraries have used it up,
    # importing one more fails ("cannot allocate memory in static TLS block").
    # Twenty copies of the kernel, with glibc's reserve at its smallest: a
    # kernel that needs static TLS fails at the sixth.
    from geoalpha import _kernel

    script = (
        "import ctypes, shutil, sys\n"
        "for i in range(20):\n"
        f"    path = shutil.copy(sys.argv[1], {str(tmp_path)!r} + f'/k{{i}}.so')\n"
        "    ctypes.CDLL(path)\n"
        "print('loaded 20')\n"
    )
    env = dict(os.environ, GLIBC_TUNABLES="glibc.rtld.optional_static_tls=0")
    done = subprocess.run(
        [sys.executable, "-c", script, _kernel.__file__],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    assert done.stderr == "" and done.stdout == "loaded 20\n", done.stderr
