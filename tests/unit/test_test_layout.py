"""The tests' own layout: test modules sit in the four folders (tests/README.md), share code only
through tests/support/ (no test module imports another), and find it through tests/conftest.py
(no test module edits sys.path). Read with ast, like test_layering.py reads the package."""
from __future__ import annotations

import ast
import os

from support.paths import TESTS

FOLDERS = ("unit", "render", "blender", "validation")



def find_test_modules():
    """{module name: path} of every test_*.py under tests/."""
    found = {}
    for folder, dirs, files in os.walk(TESTS):
        dirs[:] = [d for d in dirs if d not in ("__pycache__", "references")]
        for name in files:
            if name.startswith("test_") and name.endswith(".py"):
                found[name[:-3]] = os.path.join(folder, name)
    return found


def parse(path):
    with open(path, encoding="utf-8") as f:
        return ast.parse(f.read(), path)


def imported(tree):
    """Every name an import in the tree could bind a module to (inside functions too): each part
    of a dotted module name, the names imported from a module, and the string arguments of
    importlib.import_module / __import__ (so `from render import test_caustics` and
    `importlib.import_module("test_caustics")` count as well as `import test_caustics`)."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                names |= set(a.name.split("."))
        elif isinstance(node, ast.ImportFrom):
            names |= set((node.module or "").split(".")) | {a.name for a in node.names}
        elif (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)
              and getattr(node.func, "attr", getattr(node.func, "id", None))
              in ("import_module", "__import__")):
            names |= set(node.args[0].value.split("."))
    return names - {""}


def test_every_test_module_is_in_one_of_the_folders():
    modules = find_test_modules()
    assert modules
    misplaced = {name: os.path.relpath(path, TESTS) for name, path in modules.items()
                 if os.path.relpath(os.path.dirname(path), TESTS) not in FOLDERS}
    assert not misplaced


def test_no_test_module_imports_another():
    """Shared code belongs in support/ (test_adaptive once imported the caustic room from
    test_caustics; it is support/caustic_scenes.py now)."""
    modules = find_test_modules()
    found = set()
    for name, path in modules.items():
        found |= {(name, other) for other in imported(parse(path)) & set(modules) if other != name}
    support = os.path.join(TESTS, "support")
    for file in os.listdir(support):
        if file.endswith(".py"):
            found |= {("support." + file[:-3], other)
                      for other in imported(parse(os.path.join(support, file))) & set(modules)}
    assert not found, sorted(found)


def test_no_test_module_edits_sys_path():
    """tests/conftest.py puts tests/ and scenes/ on the path once."""
    edits = []
    for name, path in find_test_modules().items():
        tree = parse(path)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr in ("insert", "append", "extend")
                    and isinstance(node.func.value, ast.Attribute) and node.func.value.attr == "path"
                    and isinstance(node.func.value.value, ast.Name) and node.func.value.value.id == "sys"):
                edits.append((name, node.lineno))
    assert not edits


def test_the_import_check_sees_every_form_of_import():
    """imported() finds a test module however it is imported."""
    forms = ["import test_caustics", "from test_caustics import caustic_room",
             "from render import test_caustics", "import render.test_caustics as t",
             "def f():\n    from test_caustics import BATCHES",
             "import importlib\nimportlib.import_module('test_caustics')"]
    for source in forms:
        assert "test_caustics" in imported(ast.parse(source)), source
    assert "test_caustics" not in imported(ast.parse("from support import caustic_scenes"))
