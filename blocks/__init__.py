"""The hybridsim block library, one subpackage per family.

``math`` (routing, nonlinear, logic, lookup, friction), ``sources``,
``continuous``, ``discrete``, ``sinks``, ``robot`` (any arm from a URDF) and
``paper`` (the blocks of the paper's Fig 6 and its plant). Importing this
package registers every block type with :mod:`hybridsim.engine.registry`;
diagrams refer to them by these names. Every module whose name does not start
with ``_`` is imported: a new block module needs no list to be edited.
"""
import importlib
import pkgutil

for _module in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
    if not _module.name.rpartition(".")[2].startswith("_"):
        importlib.import_module(_module.name)
