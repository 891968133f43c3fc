"""Radau's and BDF's linear algebra through LAPACK directly (solvers.direct_lu) gives scipy's own
numbers: the same getrf / getrs, without scipy.linalg's per-call checks."""
import numpy as np
import pytest
from scipy.integrate import BDF, Radau
from scipy.linalg import lu_factor, lu_solve

import hybridsim as hs
from hybridsim.engine.solvers import direct_lu


def _stiff(t, y):  # Robertson's reactions: a stiff 3-state problem that takes many Newton solves
    return np.array([-0.04 * y[0] + 1e4 * y[1] * y[2],
                     0.04 * y[0] - 1e4 * y[1] * y[2] - 3e7 * y[1] ** 2,
                     3e7 * y[1] ** 2])


@pytest.mark.parametrize("dtype", [float, complex])
def test_factor_and_solve_equal_scipy_linalg(dtype):
    rng = np.random.default_rng(3)
    a = rng.standard_normal((5, 5)).astype(dtype) + (1j * rng.standard_normal((5, 5)) if dtype is complex else 0)
    b = rng.standard_normal(5).astype(dtype)
    class Ode:  # what direct_lu touches of a scipy solver
        nlu = 0
    ode = Ode()
    direct_lu(ode)
    got = ode.solve_lu(ode.lu(a.copy()), b.copy())
    assert np.array_equal(got, lu_solve(lu_factor(a.copy()), b.copy()))
    assert np.allclose(a @ got, b, rtol=1e-12, atol=1e-12) and ode.nlu == 1


def test_a_matrix_not_finite_fails_as_lu_factor_does():
    class Ode:
        nlu = 0
    ode = Ode()
    direct_lu(ode)
    with pytest.raises(ValueError, match="infs or NaNs"):
        ode.lu(np.array([[1.0, np.nan], [0.0, 1.0]]))


@pytest.mark.parametrize("method", [Radau, BDF])
def test_a_stiff_integration_takes_the_same_steps(method):
    def run(patched):
        ode = method(_stiff, 0.0, np.array([1.0, 0.0, 0.0]), 40.0, rtol=1e-6, atol=1e-10)
        if patched:
            direct_lu(ode)
        ts = []
        while ode.status == "running":
            ode.step()
            ts.append((ode.t, *ode.y))
        return np.array(ts), ode.nlu

    (ref, nlu_ref), (got, nlu) = run(False), run(True)
    assert np.array_equal(got, ref) and nlu == nlu_ref and len(ref) > 50


@pytest.mark.parametrize("make, name", [
    (lambda: hs.ScipySolver(rtol=-1), "rtol"),      # failed at run time: complex '<' float
    (lambda: hs.ScipySolver(max_step=0), "max_step"),  # 'NoneType' object has no attribute 't'
    (lambda: hs.ScipySolver(atol="x"), "atol"),
    (lambda: hs.ScipySolver(atol=[1e-6, -1.0]), "atol"),
    (lambda: hs.CVode(rtol=-1), "rtol"),            # SUNDIALS: "One of the function inputs is invalid"
    (lambda: hs.CVode(max_step=0), "max_step"),
    (lambda: hs.RK4("x"), "step"),                  # '>' not supported between 'str' and 'int'
    (lambda: hs.Heun(None), "step"),
])
def test_a_solver_refuses_a_bad_setting_when_made(make, name):
    with pytest.raises(hs.ParameterError, match=f"parameter '{name}' must be a positive"):
        make()


def test_a_solver_takes_numpy_numbers_and_no_limit():
    assert hs.RK4(np.float64(1e-3)).step == 1e-3 and hs.CVode(max_step=np.inf).max_step == np.inf
    assert list(hs.ScipySolver(atol=np.array([1e-6, 1e-8])).atol) == [1e-6, 1e-8]
