from fractions import Fraction

import pytest

from hybridsim.engine.block import rate_to_period, to_period
from hybridsim.errors import RateError
from hybridsim.engine.schedule import Schedule


def test_base_tick_is_gcd_of_periods():
    s = Schedule([(rate_to_period(60), 0), (rate_to_period(80), 0), (rate_to_period(120), 0)])
    assert s.base == Fraction(1, 240)
    assert s.ticks == [(4, 0), (3, 0), (2, 0)]


def test_due_and_hits():
    s = Schedule([(rate_to_period(60), 0), (rate_to_period(80), 0)])
    assert s.due(0) == [0, 1]
    n, due = s.hits(12)
    assert n.tolist() == [0, 3, 4, 6, 8, 9, 12]  # of 240 Hz: 60 Hz every 4 ticks, 80 Hz every 3
    assert due[1].tolist() == [False, True]      # tick 3: 80 Hz only
    assert due[-1].tolist() == [True, True] and s.due(12) == [0, 1]


def test_offset():
    s = Schedule([(Fraction(1, 10), Fraction(1, 20))])
    assert s.ticks == [(2, 1)]
    assert s.due(0) == []
    n, due = s.hits(5)
    assert n.tolist() == [0, 1, 3, 5]  # tick 0 always: the first pass of a run
    assert due[:, 0].tolist() == [False, True, True, True]


def test_time_is_exact_on_grid():
    s = Schedule([(rate_to_period(60), 0)])
    assert s.time(60 * 1000) == 1000.0
    assert s.last_tick_before(1000.0) == 59999


def test_incommensurate_rates_rejected():
    with pytest.raises(RateError, match="not commensurate"):
        Schedule([(rate_to_period(60), 0), (rate_to_period("60.001"), 0)])


def test_bad_periods():
    with pytest.raises(RateError, match="positive"):
        rate_to_period(-5)
    with pytest.raises(RateError, match="not a number"):
        rate_to_period("fast")
    with pytest.raises(RateError, match="ratio of small integers"):
        to_period(0.0123456789123)
    assert to_period(1 / 60) == Fraction(1, 60)


def test_float_end_time_on_a_tick_ends_before_it():
    s = Schedule([(rate_to_period(100), 0)])
    assert s.last_tick_before(0.01) == 0  # 0.01 is a hair above 1/100 in binary
    assert s.last_tick_before(0.3) == 29
    assert s.last_tick_before(0.305) == 30


@pytest.mark.parametrize("text", ["zoh, period: 1e300", "zoh, rate: 1e-300"])
def test_a_period_far_beyond_the_end_is_due_once(tmp_path, text):
    """A period of 1e300 s next to the 0.5 ms log grid: ticks beyond int64, due at t = 0 only."""
    import numpy as np

    import hybridsim as hs

    p = tmp_path / "d.yaml"
    p.write_text("blocks:\n  a: {type: step, time: 0.1}\n  d: {type: %s}\n"
                 "wires: [a.y -> d.u]\nsimulation: {t_end: 0.3}\nlog: [d.y]\n" % text)
    r = hs.simulate(p)
    assert len(r.t) == 601 and np.all(r["d.y"] == 0.0)  # held from t = 0, before the step


def test_a_log_period_far_beyond_the_end_logs_the_start_and_the_end():
    s = Schedule([(to_period(1e300), 0)])
    n_last = s.last_tick_before(0.3)  # 0.3 s is not "within 1e-9 of" tick 0 because the tick is huge
    assert n_last == 0
    n, due = s.hits(n_last)
    assert n.tolist() == [0] and s.time(n).tolist() == [0.0]


def test_a_period_under_a_microsecond_is_its_exact_ratio():
    # 1e-8 s was "not a ratio of small integers" (denominators stopped at 1e7)
    from fractions import Fraction

    assert to_period(1e-8) == Fraction(1, 10**8) and to_period(1e-10) == Fraction(1, 10**10)
    assert to_period(1 / 60) == Fraction(1, 60) and to_period(0.0005) == Fraction(1, 2000)


def test_a_rate_computed_as_a_ratio_is_that_ratio():
    """rate: 333.3333333333333 (1000/3 as a float) was the decimal, incommensurate with a 1 kHz log;
    a decimal rate stays as written."""
    assert rate_to_period(1000 / 3) == Fraction(3, 1000)
    assert rate_to_period(48.0005) == Fraction(2000, 96001) and rate_to_period("60") == Fraction(1, 60)
    assert rate_to_period(123.4567891) == Fraction(10**7, 1234567891)
    assert Schedule([(rate_to_period(1000 / 3), 0), (rate_to_period(1000), 0)]).base == Fraction(1, 1000)
