import numpy as np
import pytest

from hybridsim.blocks.paper.surface import Surface


def u(x, v=0.0):
    return [np.array([x, 0.0]), np.array([v, 0.0])]


def test_eq9_spring_in_contact():
    s = Surface(Kr=9e5, position=0.5)
    fx, c = s.output(0, None, u(0.5 + 1e-5))
    assert fx[0] == pytest.approx(9.0) and c[0] == 1.0


def test_unilateral_never_pulls():
    s = Surface(Kr=9e5, br=1000.0, position=0.5)
    assert s.output(0, None, u(0.49))[0][0] == 0.0
    # in contact but separating fast: damping would pull, the surface cannot
    assert s.output(0, None, u(0.5 + 1e-6, -1.0))[0][0] == 0.0


def test_bilateral_pulls():
    s = Surface(Kr=9e5, position=0.5, unilateral=False)
    assert s.output(0, None, u(0.5 - 1e-5))[0][0] == pytest.approx(-9.0)


def test_moving_surface_from_inputs():
    s = Surface(Kr=1e6, moving=True)
    fx, _ = s.output(0, None, u(0.6) + [np.array([0.6 - 2e-6]), np.array([0.0])])
    assert fx[0] == pytest.approx(2.0)
    assert s.zero_crossings(0, None, u(0.6) + [np.array([0.7]), np.array([0.0])])[0] == pytest.approx(-0.1)
