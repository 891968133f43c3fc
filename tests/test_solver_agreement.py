"""The answer must not depend on the integrator.

On a run with no discontinuity (friction off, damping that keeps contact) a
stiff implicit method at tight tolerance and RK4 at a small step agree to
micro-newtons; with friction on (stick-slip switches stepped over by RK4),
halving the step changes the Fig 7 metrics by far less than they resolve.
"""
import numpy as np
import pytest

import hybridsim as hs

from conftest import ROOT

SMOOTH = ROOT / "tests" / "data" / "smooth_contact.yaml"


@pytest.fixture(scope="module")
def reference():
    return hs.simulate(SMOOTH, solver="radau", rtol=1e-9, atol=1e-12)


def test_contact_is_kept_and_force_settles(reference):
    assert reference["surface.contact[0]"].min() == 1.0
    assert reference["ft.CF[0]"][0] == pytest.approx(10.0, abs=1e-9)  # starts in balance
    assert reference["ft.CF[0]"][-1] == pytest.approx(15.0, abs=0.3)  # settling towards 15 N


def test_radau_and_fine_rk4_agree(reference):
    rk4 = hs.simulate(SMOOTH, solver="rk4", step=2.5e-5)
    assert np.array_equal(rk4.t, reference.t)
    # measured: 1.4e-6 N and 8.9e-13 m
    assert np.max(np.abs(rk4["ft.CF[0]"] - reference["ft.CF[0]"])) < 1e-5
    assert np.max(np.abs(rk4["fk.X[1]"] - reference["fk.X[1]"])) < 1e-11


def test_default_rk4_step_is_accurate(reference):
    rk4 = hs.simulate(SMOOTH, solver="rk4")  # step 1e-4 s: measured 1.5e-5 N, 1.1e-11 m
    assert np.max(np.abs(rk4["ft.CF[0]"] - reference["ft.CF[0]"])) < 1e-4
    assert np.max(np.abs(rk4["fk.X[1]"] - reference["fk.X[1]"])) < 1e-10
