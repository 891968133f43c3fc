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


@pytest.mark.slow
def test_a_time_given_twice_is_a_jump_located_on_every_solver(tmp_path):
    import hybridsim as hs
    from hybridsim.errors import ParameterError

    t = Table(times=[0, 1, 1, 2], values=[0, 0, 5, 5])
    assert t.output(0.999, None, [])[0] == pytest.approx(0.0) and t.output(1.0, None, [])[0] == pytest.approx(5.0)
    assert t.output(2.0, None, [])[0] == pytest.approx(5.0) and t.output(1.5, None, [])[1] == pytest.approx(0.0)
    with pytest.raises(ParameterError, match="three times"):
        Table(times=[0, 1, 1, 1], values=[0, 1, 2, 3])
    with pytest.raises(ParameterError, match="must not decrease"):
        Table(times=[0, 2, 1], values=[0, 1, 2])
    path = tmp_path / "jump.yaml"
    path.write_text("blocks:\n"
                    "  src: {type: table, times: [0, 0.3, 0.3, 0.7, 0.7], values: [0, 0, 5, 5, -1]}\n"
                    "  i: {type: integrator}\n"
                    "wires: [src.y -> i.u]\n"
                    "simulation: {t_end: 1.0, locate_switches: true, step: 0.01}\nlog: [i.y]\n")
    for solver in ("rk4", "rk45", "radau"):  # integral: 5 (0.7 - 0.3) - 1 (1 - 0.7) = 1.7
        res = hs.simulate(path, **{"simulation.solver": solver, "simulation.rtol": 1e-10})
        assert res["i.y"][-1, 0] == pytest.approx(1.7, abs=1e-8), solver


def test_constant_width_from_value():
    c = Constant(value=[1.0, 2.0])
    assert c.outputs[0].width == 2


def test_inconsistent_widths_rejected():
    with pytest.raises(ValueError):
        Step(initial=[1, 2], final=[1, 2, 3])
