"""One package under two names. Blender imports the Snell extension as bl_ext.<repository>.snell;
a Dask worker (and scheduler) has Snell installed as `snell`. Tasks and their replies travel
pickled by module name, so the cluster's processes answer imports of the extension's name with
their `snell`, and Blender answers imports of `snell` with the extension's package: a finder on
sys.meta_path hands out the same module objects under the other name, never a second copy.

This module imports nothing of Snell's, so that it can travel to the cluster by value
(cloudpickle) before the cluster can import the extension's name.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types

INSTALLED = "snell"      # the package's name where `pip install snell` put it


class Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports of `alias` and its submodules answered with `real`'s modules (the parents of
    `alias`, bl_ext and bl_ext.<repository>, as empty packages)."""

    def __init__(self, alias: str, real: str):
        self.alias, self.real = alias, real
        self.specs = {}

    def find_spec(self, name, path=None, target=None):
        if name == self.alias or name.startswith(self.alias + ".") \
                or self.alias.startswith(name + "."):
            return importlib.machinery.ModuleSpec(name, self, is_package=True)
        return None

    def create_module(self, spec):
        if self.alias.startswith(spec.name + "."):       # a parent: an empty package
            module = types.ModuleType(spec.name)
            module.__path__ = []
            return module
        module = importlib.import_module(self.real + spec.name[len(self.alias):])
        self.specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module):
        # The import system stamps the alias's spec on the module it is given: the real
        # module keeps its own.
        real = self.specs.pop(module.__spec__.name, None)
        if real is not None:
            module.__spec__ = real


def install(alias: str, real: str) -> None:
    """Answer imports of `alias` with `real`'s modules in this process, unless `alias` is
    already a package here (the process that has the real name needs no alias)."""
    if alias in sys.modules or any(isinstance(f, Alias) and f.alias == alias
                                   for f in sys.meta_path):
        return
    sys.meta_path.insert(0, Alias(alias, real))


def uninstall(alias: str) -> None:
    """Undo install(alias, ...) in this process: its finder, the names it gave the real
    modules, and the empty parent packages it made (a parent another importer made stays)."""
    sys.meta_path[:] = [f for f in sys.meta_path if not (isinstance(f, Alias) and f.alias == alias)]
    for name, module in list(sys.modules.items()):
        made = alias.startswith(name + ".") and list(getattr(module, "__path__", [None])) == []
        if name == alias or name.startswith(alias + ".") or made:
            del sys.modules[name]


def share(client, package: str) -> None:
    """Let a cluster's scheduler and workers (those that join later too) read this process's
    tasks, pickled under `package`'s name, and this process their replies, pickled under
    INSTALLED's: nothing to do when `package` is INSTALLED."""
    if package == INSTALLED:
        return
    import cloudpickle
    from distributed.diagnostics.plugin import WorkerPlugin

    class AliasPlugin(WorkerPlugin):
        """Installs the alias in every worker, when it starts or joins."""
        name = f"snell-alias-{package}"

        def setup(self, worker):
            install(package, INSTALLED)

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    install(INSTALLED, package)
    client.run_on_scheduler(install, package, INSTALLED)
    client.register_plugin(AliasPlugin())
