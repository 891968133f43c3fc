from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DIAGRAMS = ROOT / "diagrams"


@pytest.fixture
def diagrams():
    return DIAGRAMS


def integrator_without_kernels():
    """A diagram (constant -> integrator) whose integrator has methods, no kernels."""
    import hybridsim as hs
    from hybridsim.engine.block import Block

    class Integrator(Block):
        def __init__(self, name):
            super().__init__(name)
            self.declare_input("u", 1)
            self.declare_output("y", 1, depends_on=())
            self.declare_continuous_state(1)

        def output(self, t, x, u):
            return (x,)

        def derivatives(self, t, x, u):
            return u[0]

    d = hs.Diagram("integrate")
    d.add(hs.registry.lookup("constant")("c", value=1.0))
    d.add(Integrator("f"))
    d.connect("c.y", "f.u")
    return d


def write(tmp_path, text, name="d.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def pytest_collection_modifyitems(config, items):
    """Every test of the compiled path is slow (the quick loop, ``-m "not slow"``, compiles
    nothing): numba compiles the stepping core once per worker and method, then each diagram's
    glue. A test runs the compiled path when its id names it (``[compiled]``, ``rk4-compiled``)."""
    for item in items:
        if "compiled" in item.name.lower() and "slow" not in item.keywords:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(autouse=True, scope="session")
def _compiled_cache(tmp_path_factory):
    """Compiled-path modules go to a fresh folder: the suite compiles what it runs, once for all its
    workers (pytest-xdist's workers share the parent of their temporary folders)."""
    import os

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    os.environ["HYBRIDSIM_CACHE"] = str(root / "hybridsim_cache")


#: a small valid diagram (step -> gain -> zoh) that tests mutate one line at a time
GOOD = """\
params:
  k: 2.0
blocks:
  src:  {type: step, initial: 0.0, final: 1.0, time: 0.1}
  g:    {type: gain, K: $k}
  zoh:  {type: zoh, rate: 100}
wires:
  - src.y -> g.u
  - g.y -> zoh.u
simulation: {t_end: 0.2, log_period: 1.0e-2}
log: [zoh.y]
"""
