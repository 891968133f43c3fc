import numpy as np
import pytest

from hybridsim.blocks.sources.basic import Constant, Cosine, Ramp, Step, Table


def test_eq17b_cosine():
    c = Cosine(offset=0.30, amplitude=-0.30, frequency=0.375)
    assert c.output(0.0, None, [])[0] == pytest.approx(0.0)
    assert c.output(4 / 3, None, [])[0] == pytest.approx(0.60)
    # dy = 0.30 * 0.75 pi sin(0.75 pi t); at t = 2/3 s sin = 1
    assert c.output(2 / 3, None, [])[1] == pytest.approx(0.30 * 0.75 * np.pi)


def test_eq17a_step():
    s = Step(initial=10.0, final=20.0, time=1.0)
    assert s.output(0.999, None, [])[0] == pytest.approx((10.0,))
    assert s.output(1.0, None, [])[0] == pytest.approx((20.0,))


def test_ramp_holds_after_stop():
    r = Ramp(initial=0.5, slope=0.0065, start=1.0, stop=4.0)
    assert r.output(0.5, None, [])[0] == pytest.approx(0.5)
    assert r.output(2.0, None, [])[0] == pytest.approx(0.5065)
    assert r.output(5.0, None, []) == (pytest.approx(0.5 + 3 * 0.0065), pytest.approx(0.0))


def test_table_interpolates():
    t = Table(times=[0, 1, 2], values=[0, 10, 10])
    assert t.output(0.25, None, [])[0] == pytest.approx(2.5)
    assert t.output(0.25, None, [])[1] == pytest.approx(10.0)
    assert t.output(3.0, None, [])[0] == pytest.approx(10.0)


def test_constant_width_from_value():
    c = Constant(value=[1.0, 2.0])
    assert c.outputs[0].width == 2


def test_inconsistent_widths_rejected():
    with pytest.raises(ValueError):
        Step(initial=[1, 2], final=[1, 2, 3])
