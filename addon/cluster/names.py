"""One package under two names: ``bo2_lighting`` (pip, the workers' and the scheduler's) and
``bl_ext.<repository>.bo2_lighting`` (the extension installed in Blender, the UI's).

Dask pickles functions and classes by the name of their module, and the scheduler and the
workers import it to unpickle them: a task sent from the extension names modules that a worker
of the pip package does not have, and a result sent back names modules that Blender does not
have. ``install`` makes each name import this process's package (the same module objects: no
second copy). Standard library only: a client sends it to the scheduler by value
(``cloudpickle.register_pickle_by_value``) before anything of its own; the workers' preload
(``tasks.dask_setup``) and the client install it themselves.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import re
import sys
import types

NAMES = re.compile(r"^(?P<root>bo2_lighting|bl_ext\.[^.]+\.bo2_lighting)(?P<rest>(\.[^.]+)*)$")
PARENTS = re.compile(r"^bl_ext(\.[^.]+)?$")


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """The other names of the package ``root`` (``NAMES``) as its modules; with ``parents``,
    the packages above an extension's name (``bl_ext``, ``bl_ext.<repository>``), empty, where
    nothing else provides them."""

    bo2_alias = True  # (the class itself differs in each copy sent by value)

    def __init__(self, root: str, parents: bool = False):
        self.root, self.parents = root, parents

    def find_spec(self, fullname, path=None, target=None):
        if self.parents:
            if PARENTS.match(fullname):
                return importlib.machinery.ModuleSpec(fullname, self, is_package=True)
            return None
        m = NAMES.match(fullname)
        if m is None or m["root"] == self.root:
            return None
        return importlib.machinery.ModuleSpec(fullname, self,
                                              is_package=True)  # (its real one may be a module)

    def create_module(self, spec):
        if self.parents:
            module = types.ModuleType(spec.name)
            module.__path__ = []
            return module
        return importlib.import_module(self.root + NAMES.match(spec.name)["rest"])

    def exec_module(self, module):
        pass


def install(root: str | None = None) -> str:
    """Import the package's other names as ``root`` (this package's name by default) from now
    on, in this process; returns ``root``. Installed once."""
    if root is None:
        root = __name__.rpartition(".addon.")[0]
    if not any(getattr(f, "bo2_alias", False) for f in sys.meta_path):
        sys.meta_path.insert(0, _Alias(root))  # before a pip copy of the package
        sys.meta_path.append(_Alias(root, parents=True))  # after Blender's own bl_ext
    found = sys.modules.get("bl_ext")
    if found is not None and not hasattr(found, "__path__"):
        found.__path__ = []  # (the bpy module's, with no extension repository: a package)
    return root
