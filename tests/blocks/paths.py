"""Run a small diagram on the generic, fused and compiled paths and compare with a reference."""
import json
import os

import numpy as np
import pytest

import hybridsim as hs

#: the three paths; the compiled one compiles with numba (seconds), so it is a slow test
PATHS = [pytest.param("generic"), pytest.param("fused"), pytest.param("compiled", marks=pytest.mark.slow)]
_KW = {"generic": dict(fused=False), "fused": {}, "compiled": dict(compiled=True)}


def block(type_name, name, **params):
    """A library block by its registered type name."""
    return hs.registry.lookup(type_name)(name, **params)


def run(path, blocks, wires, t_end, log, step=1e-3, log_period=0.01, **sim):
    """The result of ``blocks`` wired by ``wires`` ((out, in) pairs), run to ``t_end`` on ``path``."""
    d = hs.Diagram("t")
    for b in blocks:
        d.add(b)
    for a, b in wires:
        d.connect(a, b)
    return hs.Simulator(d.build(), hs.RK4(step), log=log, log_period=log_period, **_KW[path], **sim).run(t_end)


def check(what, path, got, ref, tol):
    """Assert max |got - ref| <= tol; with HYBRIDSIM_ERRORS set, append the error to that JSON-lines file."""
    err = float(np.max(np.abs(np.asarray(got, float) - np.asarray(ref, float))))
    if os.environ.get("HYBRIDSIM_ERRORS"):
        with open(os.environ["HYBRIDSIM_ERRORS"], "a") as f:
            f.write(json.dumps({"block": what, "path": path, "err": err}) + "\n")
    assert err <= tol, (what, path, err)
    return err
