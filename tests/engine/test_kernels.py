"""A block written as kernels (docs/extending.md's example) runs on all three paths."""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel, marked


class SpringDamper(Block):
    def __init__(self, name="sd", k=1e3, b=1.0, m=1.0, x0=0.0):
        super().__init__(name)
        self.params = (float(k), float(b), float(m))
        self.x0 = x0
        self.declare_input("F", 1)
        self.declare_output("x", 1, depends_on=())
        self.declare_continuous_state(2, atol=(1e-9, 1e-9))

    def initial_state(self, u=None):
        return np.array([self.x0, 0.0])


@kernel
def spring_damper_output(p, t, x, u):
    return ((x[0],),)


@kernel
def spring_damper_derivatives(p, t, x, u):
    k, b, m = p
    return (x[1], (u[0][0] - k * x[0] - b * x[1]) / m)


SpringDamper.kernels = Kernels(output=spring_damper_output, derivatives=spring_damper_derivatives)


def system():
    d = hs.Diagram("free_decay")
    d.add(hs.registry.lookup("constant")("F", value=0.0))
    d.add(SpringDamper("sd", k=1e3, b=2.0, m=1.0, x0=0.01))
    d.add(hs.registry.lookup("zoh")("sample", rate=100))  # a discrete block on the compiled path
    d.connect("F.y", "sd.F")
    d.connect("sd.x", "sample.u")
    return d.build()


def test_marked_functions_are_unchanged_and_listed():
    assert spring_damper_output in marked()
    assert spring_damper_derivatives((1e3, 2.0, 1.0), 0.0, (0.01, 0.0), ((5.0,),)) == (0.0, -5.0)


@pytest.mark.slow
def test_kernel_block_on_generic_fused_and_compiled_paths():
    # free decay x(t) = x0 e^(-zeta wn t) (cos wd t + zeta wn / wd sin wd t), wn = sqrt(1000), zeta wn = 1
    wn, a = math.sqrt(1e3), 1.0
    wd = math.sqrt(wn * wn - a * a)
    exact = lambda t: 0.01 * math.exp(-a * t) * (math.cos(wd * t) + a / wd * math.sin(wd * t))  # noqa: E731
    runs = {name: hs.Simulator(system(), hs.RK4(1e-4), log=["sd.x", "sample.y"], log_period=0.01, **kw).run(0.5)
            for name, kw in (("generic", dict(fused=False)), ("fused", {}), ("compiled", dict(compiled=True)))}
    ref = runs["generic"]
    assert ref["sd.x"][-1, 0] == pytest.approx(exact(0.5), abs=1e-9)
    # by hand: 0.01 e^-0.5 (cos 15.80 + sin 15.80 / 31.6) = 0.01 * 0.6065 * (-0.9954 - 0.0030)
    assert exact(0.5) == pytest.approx(-6.056e-3, rel=1e-3)
    for name in ("fused", "compiled"):
        assert np.array_equal(runs[name].table(), ref.table()), name
    assert runs["compiled"].meta["hits"] == {"sample": 50}
