"""The hybridsim block library: the blocks of the paper's Fig 6 and friends.

Importing this package registers every block type with
:mod:`hybridsim.registry`; diagrams refer to them by these names. Every module
of this folder whose name does not start with ``_`` is imported: a new block
module needs no list to be edited.
"""
import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")
