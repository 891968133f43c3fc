"""Every public function, class and method has a docstring (as python-control checks its own).

A kernel (``@kernel`` function in ``Kernels(...)``) is documented by the block class that
uses it: that class's docstring gives the equation the kernel computes. Methods that
override a documented base method inherit its docstring (``inspect.getdoc``).
"""
import importlib
import inspect
import pkgutil

import hybridsim
import hybridsim.blocks
import hybridsim.fmus
from hybridsim.engine.block import Block


def _modules():
    for pkg in (hybridsim, hybridsim.blocks, hybridsim.fmus):
        for m in pkgutil.iter_modules(pkg.__path__):
            if not m.name.startswith("_") and m.name not in ("blocks", "fmus", "diagrams"):
                yield importlib.import_module(f"{pkg.__name__}.{m.name}")


def _kernels_of_documented_blocks():
    out = set()
    for mod in _modules():
        for obj in vars(mod).values():
            if inspect.isclass(obj) and issubclass(obj, Block) and inspect.getdoc(obj):
                out |= {id(f) for f in (getattr(obj, "kernels", None) or ()) if f is not None}
    return out


def test_every_public_name_has_a_docstring():
    served = _kernels_of_documented_blocks()
    missing = []
    for mod in _modules():
        for name, obj in vars(mod).items():
            if name.startswith("_") or not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            if obj.__module__ != mod.__name__ or id(obj) in served:
                continue
            if not inspect.getdoc(obj):
                missing.append(f"{mod.__name__}.{name}")
            if inspect.isclass(obj):
                for mname, meth in vars(obj).items():
                    if inspect.isfunction(meth) and not mname.startswith("_") and not inspect.getdoc(getattr(obj, mname)):
                        missing.append(f"{mod.__name__}.{name}.{mname}")
    assert not missing, f"{len(missing)} public names without a docstring: {', '.join(missing)}"
