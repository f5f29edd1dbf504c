"""The package's modules import one way: no import cycles, the tracer below everything, and the
packages in layers (PACKAGE_IMPORTS).

Imports are read from the source with ast, including those inside functions (a lazy import is
still a dependency), so the test sees what `python -X importtime` would miss.
"""
from __future__ import annotations

import ast
import os
import tomllib

from support.paths import ROOT

PACKAGE = "snell"
# pyproject's packages, besides the root
SUBPACKAGES = ("addon", "farm", "pages", "stress", "tracer", "validation")


# The packages and what each may import, modules collapsed to their top-level package (the root's
# own modules cli and errors each on its own; "snell" is the root's __init__, the extension's
# register()): the tracer at the bottom, errors.py beside it, the Blender add-on above them, then
# the Cycles validator and `snell stress`, which make their pages with pages/ (above the tracer
# only, below both), and the command line on top. farm/ (Dask) sits between the tracer and the
# add-on, whose F12 renders on a cluster through it.
PACKAGE_IMPORTS = {
    "snell.tracer": set(),
    "snell.errors": set(),
    "snell.faults": set(),     # the commands' fatal-signal stacks, for cli.py's main()
    "snell.addon": {"snell.farm", "snell.tracer", "snell.errors"},   # farm: F12 on a cluster
    "snell.pages": {"snell.tracer"},
    "snell.validation": {"snell.addon", "snell.pages", "snell.tracer", "snell.errors"},
    "snell.stress": {"snell.addon", "snell.pages", "snell.tracer", "snell.errors"},
    # Distributed rendering on Dask: above the tracer (and errors.py), below the add-on.
    "snell.farm": {"snell.tracer", "snell.errors"},
    "snell.cli": {"snell.validation", "snell.stress", "snell.farm", "snell.addon",
                  "snell.pages", "snell.tracer", "snell.errors", "snell.faults"},
    "snell": {"snell.addon"},
}


def package_folders(root=ROOT) -> list:
    """The package's folders relative to root ("" for the root), subpackages of SUBPACKAGES too."""
    folders = [""]
    for sub in SUBPACKAGES:
        for folder, dirs, files in os.walk(os.path.join(root, sub)):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            if "__init__.py" in files:
                folders.append(os.path.relpath(folder, root).replace(os.sep, "/"))
    return folders


def package_modules(root=ROOT) -> dict:
    """{dotted module name: file path} of every module of the installed package."""
    modules = {}
    for sub in package_folders(root):
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


def package_of(module: str) -> str:
    """The top-level package a module belongs to: snell.validation for snell.validation.bench;
    the root's own modules (snell.cli, snell.errors) and the root package (snell) are their own."""
    parts = module.split(".")
    return ".".join(parts[:2])


def package_graph(graph) -> dict:
    """The module graph with modules collapsed to their top-level packages (no self edges)."""
    out = {}
    for module, deps in graph.items():
        here = package_of(module)
        out.setdefault(here, set()).update(package_of(d) for d in deps if package_of(d) != here)
    return out


def layering_violations(packages) -> list:
    """[(package, imported package)] for every import PACKAGE_IMPORTS does not allow."""
    return sorted((p, d) for p, deps in packages.items() for d in deps
                  if d not in PACKAGE_IMPORTS.get(p, ()))


def all_imports(root=ROOT) -> dict:
    modules = package_modules(root)
    return {m: imports_of(m, p, modules) for m, p in modules.items()}


def test_graph_sees_relative_and_function_level_imports():
    graph = import_graph()
    assert "snell.tracer.scene" in graph["snell.cli"]            # module level, from .x import y
    assert "snell.addon.export" in graph["snell.cli"]            # inside load_scene()
    assert "snell.validation.report" in graph["snell.validation.commands"]  # from . import report
    assert "snell.addon.registration" in graph["snell"]         # the root package, in register()


def test_find_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_subpackages_are_pyprojects_packages():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        listed = tomllib.load(f)["tool"]["setuptools"]["packages"]
    found = [".".join([PACKAGE] + (sub.split("/") if sub else [])) for sub in package_folders()]
    assert sorted(listed) == sorted(found)


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


def test_packages_import_in_layers():
    packages = package_graph(import_graph())
    assert set(packages) == set(PACKAGE_IMPORTS)       # every package has its place
    assert layering_violations(packages) == []
    assert find_cycle(packages) is None
    assert find_cycle(PACKAGE_IMPORTS) is None          # the layers themselves are one-way


def test_a_reverse_import_breaks_the_layers():
    # The check itself: an import against the layers is caught, by the cycle it closes too.
    graph = import_graph()
    before = set(layering_violations(package_graph(graph)))
    for module, imported in (("snell.tracer.scene", "snell.addon.export"),
                             ("snell.addon.final", "snell.validation.metrics"),
                             ("snell.pages.html_page", "snell.validation.report"),
                             ("snell.validation.metrics", "snell.cli"),
                             ("snell.addon.batch", "snell.pages.images")):
        changed = {m: set(deps) for m, deps in graph.items()}
        changed[module].add(imported)
        packages = package_graph(changed)
        added = set(layering_violations(packages)) - before
        assert added == {(package_of(module), package_of(imported))}
        if imported != "snell.pages.images":       # addon -> pages closes no cycle, still wrong
            assert find_cycle(packages) is not None


def test_pages_and_stress_never_import_bpy():
    # Only the exporter, the engine and the validator's renders need Blender.
    for module, deps in all_imports().items():
        if package_of(module) in ("snell.pages", "snell.stress"):
            blender = sorted(d for d in deps if d == "bpy" or d.startswith("bpy."))
            assert blender == [], f"{module} imports {blender}"


def test_export_datablock_modules_do_not_import_the_walk():
    # addon/export: the walk (depsgraph.py) calls the modules of the datablocks, never the reverse.
    walk = "snell.addon.export.depsgraph"
    importers = sorted(m for m, deps in import_graph().items()
                       if m.startswith("snell.addon.export.") and walk in deps)
    assert importers == []
