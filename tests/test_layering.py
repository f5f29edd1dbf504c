"""The package's modules import one way: no import cycles, the tracer below everything.

Imports are read from the source with ast, including those inside functions (a lazy import is
still a dependency), so the test sees what `python -X importtime` would miss.
"""
from __future__ import annotations

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = "snell"
# pyproject's packages, besides the root, as folders (a nested package is "parent/child").
SUBPACKAGES = ("addon", "addon/export", "compare", "tracer")


def package_modules(root=ROOT) -> dict:
    """{dotted module name: file path} of every module of the installed package."""
    modules = {}
    for sub in ("",) + SUBPACKAGES:
        folder = os.path.join(root, sub)
        for name in sorted(os.listdir(folder)):
            if not name.endswith(".py"):
                continue
            parts = [PACKAGE] + (sub.split("/") if sub else [])
            if name != "__init__.py":
                parts.append(name[:-3])
            modules[".".join(parts)] = os.path.join(folder, name)
    return modules


def imports_of(module: str, path: str, known) -> set:
    """Every module (of the package or outside it) that `module` imports anywhere in its source."""
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    is_package = os.path.basename(path) == "__init__.py"
    here = module.split(".") if is_package else module.split(".")[:-1]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[:len(here) - (node.level - 1)] + (node.module.split(".") if node.module else [])
                base = ".".join(base)
            else:
                base = node.module
            for alias in node.names:
                # `from . import report` imports a module; `from .scene import load` a name.
                candidate = f"{base}.{alias.name}"
                found.add(candidate if candidate in known else base)
    return found


def import_graph(root=ROOT) -> dict:
    """{module: set of package modules it imports}."""
    modules = package_modules(root)
    graph = {}
    for module, path in modules.items():
        deps = imports_of(module, path, modules)
        graph[module] = {d for d in deps if d in modules and d != module}
    return graph


def find_cycle(graph):
    """One import cycle as a list of modules (first repeated at the end), or None."""
    state = {}

    def visit(node, stack):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt, stack)
                if found:
                    return found
        stack.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node, [])
            if found:
                return found
    return None


def all_imports(root=ROOT) -> dict:
    modules = package_modules(root)
    return {m: imports_of(m, p, modules) for m, p in modules.items()}


def test_graph_sees_relative_and_function_level_imports():
    graph = import_graph()
    assert "snell.tracer.scene" in graph["snell.cli"]            # module level, from .x import y
    assert "snell.addon.export" in graph["snell.cli"]            # inside load_scene()
    assert "snell.compare.report" in graph["snell.compare.commands"]  # from . import report
    assert "snell.addon.registration" in graph["snell"]         # the root package, in register()


def test_find_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_no_import_cycles():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_nothing_imports_the_command_line():
    # cli.py is the top: it dispatches to the commands, which take their shared helpers from
    # snell.errors rather than from it.
    importers = sorted(m for m, deps in import_graph().items() if "snell.cli" in deps)
    assert importers == []


def test_errors_module_is_below_every_command():
    assert import_graph()["snell.errors"] == set()


def test_tracer_imports_only_the_tracer_and_never_bpy():
    for module, deps in all_imports().items():
        if not module.startswith("snell.tracer"):
            continue
        above = sorted(d for d in deps if d.startswith(PACKAGE) and not d.startswith("snell.tracer"))
        assert above == [], f"{module} imports {above}"
        blender = sorted(d for d in deps if d == "bpy" or d.startswith("bpy."))
        assert blender == [], f"{module} imports {blender}"


def test_subpackages_are_pyproject_packages():
    # A package missing from pyproject's list is left out of the installed snell.
    import tomllib
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        packages = tomllib.load(f)["tool"]["setuptools"]["packages"]
    listed = [PACKAGE] + [f"{PACKAGE}.{sub.replace('/', '.')}" for sub in SUBPACKAGES]
    assert sorted(packages) == sorted(listed)


def test_export_datablock_modules_do_not_import_the_walk():
    # addon/export: the walk (depsgraph.py) calls the modules of the datablocks, never the reverse.
    walk = "snell.addon.export.depsgraph"
    importers = sorted(m for m, deps in import_graph().items()
                       if m.startswith("snell.addon.export.") and walk in deps)
    assert importers == []
