"""all_finite: the check made at every right-hand side and step, against hand-picked arrays."""
import numpy as np
import pytest

from hybridsim.engine.finite import all_finite


@pytest.mark.parametrize("size", [3, 1000])
def test_all_finite_finds_any_nan_or_infinity(size):
    a = np.linspace(-1.0, 1.0, size)
    assert all_finite(a)
    for bad in (np.nan, np.inf, -np.inf):
        b = a.copy()
        b[size // 2] = bad
        assert not all_finite(b)


def test_finite_elements_whose_sum_overflows_are_finite():
    assert all_finite(np.array([1e308, 1e308, -1e308]))  # the sum overflows to inf on the way
    assert not all_finite(np.array([np.inf, -np.inf]))  # inf - inf: nan, still not finite
    assert all_finite(np.zeros(0))
