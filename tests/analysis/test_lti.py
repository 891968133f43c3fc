"""Closed-loop models: their pole tables, hand-checked."""
import numpy as np
import pytest


def test_poles_at_z_1_have_no_damping_ratio():
    """s = ln(z)/T = 0 at z = 1: a pole there within rounding (1 +- 1e-12) read damping -1 or +1 by the
    sign of the rounding (a helper saw both in one table); it has none."""
    from hybridsim.analysis.lti import DiscreteModel

    model = DiscreteModel(np.diag([1.0 + 1e-12, 1.0 - 1e-12, 0.5]), 0.01, ["a", "b", "c"], 0.0)
    rows = model.pole_table()
    assert [r["damping"] for r in rows[:2]] == [None, None] and [r["freq_hz"] for r in rows[:2]] == [0.0, 0.0]
    assert rows[2]["damping"] == 1.0 and rows[2]["freq_hz"] == pytest.approx(np.log(2) / 0.01 / (2 * np.pi))
