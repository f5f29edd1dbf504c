"""docs/architecture.md names every module of the package in its folder's paragraph, so the page
cannot silently fall behind the tree."""
import os
import re

import pytest

from support.paths import ROOT

FOLDERS = ("tracer", "tracer/lights", "tracer/shader", "addon", "addon/export",
           "addon/export/shader", "validation", "stress", "pages", "farm")


def _paragraphs() -> dict:
    """The page's folder paragraphs ("**`folder/`: ..."), by folder."""
    with open(os.path.join(ROOT, "docs", "architecture.md"), encoding="utf-8") as f:
        page = f.read()
    paragraphs = {}
    for block in page.split("\n\n"):
        m = re.match(r"\*\*`([a-z/_]+)/`", block)
        if m:
            paragraphs[m.group(1)] = block
    return paragraphs


@pytest.mark.parametrize("folder", FOLDERS)
def test_every_module_is_named_in_its_folders_paragraph(folder):
    paragraph = _paragraphs().get(folder)
    assert paragraph is not None, f"docs/architecture.md has no paragraph for {folder}/"
    modules = sorted(name for name in os.listdir(os.path.join(ROOT, folder))
                     if name.endswith(".py") and name != "__init__.py")
    missing = [name for name in modules if f"`{name}`" not in paragraph]
    assert not missing, f"docs/architecture.md's {folder}/ paragraph does not name {missing}"


def test_the_roots_modules_are_named():
    with open(os.path.join(ROOT, "docs", "architecture.md"), encoding="utf-8") as f:
        page = f.read()
    for name in ("cli.py", "errors.py"):
        assert f"`{name}`" in page
