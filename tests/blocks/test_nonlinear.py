"""Static nonlinearities and math blocks against hand-checked numbers."""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.blocks.math.nonlinear import (FUNCTIONS, DeadZone, Lookup1D, Lookup2D, MathFunction, Product, Quantizer,
                              Saturation, Switch)


def out(block, *inputs):
    return block.output(0.0, (), [np.atleast_1d(np.asarray(u, float)) for u in inputs])[0]


def test_saturation_and_dead_zone():
    assert list(out(Saturation(lower=-1, upper=2, width=3), [3.0, -5.0, 0.5])) == [2.0, -1.0, 0.5]
    assert list(out(DeadZone(lower=-1, upper=1, width=3), [3.0, -5.0, 0.5])) == [2.0, -4.0, 0.0]
    with pytest.raises(hs.ParameterError, match="lower"):
        Saturation(lower=2, upper=1)


def test_switch_product_quantizer():
    assert list(out(Switch(threshold=0.5, width=2), [1.0, 2.0], [0.5, 0.4], [9.0, 8.0])) == [1.0, 8.0]
    assert out(Product(ops="**/"), 3.0, 4.0, 2.0)[0] == 6.0
    assert out(Product(ops="/"), 4.0)[0] == 0.25
    assert out(Quantizer(q=0.1), 0.26)[0] == pytest.approx(0.3, abs=1e-15)
    assert out(Quantizer(q=0.5), 0.25)[0] == 0.0  # halves to even


@pytest.mark.parametrize("name", FUNCTIONS)
def test_every_math_function(name):
    ref = {"square": lambda v: v * v, "reciprocal": lambda v: 1 / v, "abs": abs,
           "sign": lambda v: math.copysign(1.0, v), "round": lambda v: float(round(v))}
    f = ref.get(name) or getattr(math, name)
    v = 0.4
    assert out(MathFunction(function=name), v)[0] == f(v)


def test_math_function_outside_its_domain_gives_nan_not_an_exception():
    assert math.isnan(out(MathFunction(function="sqrt"), -1.0)[0])
    assert out(MathFunction(function="log"), 0.0)[0] == -math.inf
    with pytest.raises(hs.ParameterError, match="must be one of"):
        MathFunction(function="eval")
    # finite up to the largest arguments math takes (exp of 709.5 was inf, sinh of 710 too)
    for name, v in [("exp", 709.7), ("sinh", 710.4), ("sinh", -710.4), ("cosh", 710.4)]:
        assert out(MathFunction(function=name), v)[0] == getattr(math, name)(v)
    assert out(MathFunction(function="exp"), 709.8)[0] == math.inf


def test_lookup_tables():
    lut = Lookup1D(x=[0, 1, 2], y=[0, 10, 0])
    assert out(lut, 0.5)[0] == 5.0 and out(lut, 3.0)[0] == 0.0 and out(lut, -1.0)[0] == 0.0
    lut2 = Lookup2D(x1=[0, 2], x2=[0, 1], table=[[0, 1], [2, 4]])
    # bilinear at (1, 0.5): (0 + 1 + 2 + 4) / 4
    assert out(lut2, 1.0, 0.5)[0] == pytest.approx(1.75)
    assert out(lut2, 5.0, -1.0)[0] == 2.0  # held at the corner (2, 0)
    with pytest.raises(hs.ParameterError, match="increasing"):
        Lookup1D(x=[0, 0], y=[1, 2])
    with pytest.raises(hs.ParameterError, match="2x2"):
        Lookup2D(x1=[0, 1], x2=[0, 1], table=[[1, 2, 3]])


def test_quantizer_rounds_halves_to_even_or_away_from_zero():
    assert list(Quantizer(q=1.0).output(0, (), [np.array([2.5, -2.5, 3.5])])[0]) == [2.0, -2.0, 4.0]
    assert list(Quantizer(q=1.0, rounding="away").output(0, (), [np.array([2.5, -2.5, 3.5])])[0]) == [3.0, -3.0, 4.0]
    assert Quantizer(q=0.1, rounding="away").output(0, (), [np.array([0.26])])[0][0] == pytest.approx(0.3)
    # below a half by one ulp, and 2^52 + 1: floor(abs(v) + 0.5) rounded them up
    near = np.array([0.49999999999999994, -0.49999999999999994, 4503599627370497.0])
    assert list(Quantizer(q=1.0, rounding="away").output(0, (), [near])[0]) == [0.0, 0.0, 4503599627370497.0]
    with pytest.raises(hs.ParameterError, match="rounding"):
        Quantizer(rounding="up")


def test_a_gain_of_a_fractional_width_is_a_parameter_error():
    # the width reached numpy through K's matrix first: "'float' object cannot be interpreted as an integer"
    from hybridsim.blocks.math.signals import Gain

    with pytest.raises(hs.ParameterError, match="'width' must be a whole number, got 2.5"):
        Gain(K=3.0, width=2.5)


@pytest.mark.parametrize("path", ["generic", "fused"])
def test_a_gain_matrix_of_m_rows_and_n_columns_takes_n_elements_to_m(path):
    """Simulink's Matrix(K*u): a 3 x 2 K was refused ("must be 1x1"); a list is the diagonal at its
    own length (it needed width)."""
    from paths import block, run

    blocks = [block("constant", "c", value=[1.0, 1.0]), block("gain", "g", K=[[1, 2], [3, 4], [5, 6]]),
              block("gain", "d", K=[1, 2, 3])]
    res = run(path, blocks, [("c.y", "g.u"), ("g.y", "d.u")], 0.01, ["g.y", "d.y"])
    assert list(res["g.y"][0]) == [3.0, 7.0, 11.0] and list(res["d.y"][0]) == [3.0, 14.0, 33.0]
    with pytest.raises(hs.ParameterError, match="K"):
        block("gain", "g", K=[[1, 2], [3, 4], [5, 6]], width=3)


@pytest.mark.parametrize("path", ["generic", "fused", pytest.param("compiled", marks=pytest.mark.slow)])
def test_floor_ceil_and_round_of_huge_values_are_the_values(path):
    """At 1e20 the compiled path gave -9.22e18 (numba's floor passes an int64); a sawtooth 1e20 cycles
    on gave 5e19."""
    from paths import block, run

    blocks = [block("constant", "c", value=[1e20, -3e19, 2.5]), block("sawtooth", "w", phase=1e20)]
    for f in ("floor", "ceil", "round"):
        blocks.append(block("math_function", f, function=f, width=3))
    res = run(path, blocks, [("c.y", f"{f}.u") for f in ("floor", "ceil", "round")], 0.01,
              ["floor.y", "ceil.y", "round.y", "w.y"])
    assert list(res["floor.y"][0]) == [1e20, -3e19, 2.0] and list(res["ceil.y"][0]) == [1e20, -3e19, 3.0]
    assert list(res["round.y"][0]) == [1e20, -3e19, 2.0]
    assert res["w.y[0]"][0] == block("sawtooth", "v").output(0.0, None, [])[0][0]  # phase 0
