"""The bound FMI calls of a Model Exchange FMU block (hybridsim.fmi.calls): the same numbers as
fmpy's own wrappers and the closed forms, failures named, unchanged inputs not written again.

Oracles: the Van der Pol oscillator's right-hand side (x' = v, v' = mu (1 - x^2) v - x), the
closed-form outputs of tests/data/types3 (one output of every FMI 3.0 numeric type), and fmpy's
getters and getEventIndicators on the same instance.
"""
import ctypes
import re
import shutil

import numpy as np
import pytest

from hybridsim.errors import FMUError
from hybridsim.fmi.calls import BoundCalls
from hybridsim.fmi.fmu_block import FMUBlock, build_fmu
from hybridsim.fmus.build import build_plant_fmu

from conftest import ROOT

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")


def _test_fmu(tmp_path_factory, name):
    d = ROOT / "tests" / "data" / name
    return build_fmu(tmp_path_factory.mktemp(name) / f"{name}.fmu", name, sorted(d.glob("*.c")),
                     (d / "modelDescription.xml").read_text(), {})


@pytest.fixture(scope="module", params=["vdp", "vdp3"], ids=["fmi2", "fmi3"])
def vdp(request, tmp_path_factory):
    return _test_fmu(tmp_path_factory, request.param)


@pytest.fixture(scope="module")
def types3(tmp_path_factory):
    return _test_fmu(tmp_path_factory, "types3")


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def plant(request, tmp_path_factory):
    return build_plant_fmu(tmp_path_factory.mktemp("plant") / "plant.fmu", fmi=request.param)


def test_derivatives_and_outputs_are_the_van_der_pol_closed_form(vdp):
    block = FMUBlock("vdp", path=str(vdp), mode="me", parameters={"mu": 3.0})
    try:
        assert list(block.initial_state()) == [2.0, 0.0]
        for x, v in ((2.0, 0.5), (-0.5, 1.25), (0.0, -2.0)):
            got = block.derivatives(0.1, np.array([x, v]), [])
            assert list(got) == [v, 3.0 * (1 - x * x) * v - x]  # (0.5, -6.5) at the first
            assert block.output(0.1, np.array([x, v]), [])[0][0] == x  # y = x
    finally:
        block.close()


TYPES3_AT_075 = {"f64": 2.25, "f32": 1.0, "i8": -93, "u8": 207, "i16": -29250, "u16": 60750,
                 "i32": -1999250000, "u32": 4000750000, "i64": -(2 ** 40) - 750000,
                 "u64": 2 ** 40 + 750000, "on": 1, "mode": 2}


def test_every_numeric_output_type_reads_its_closed_form_and_fmpys_value(types3):
    block = FMUBlock("t", path=str(types3), mode="me")
    try:
        block.initial_state()
        names = [p.name for p in block.outputs]
        got = dict(zip(names, (float(v[0]) for v in block.output(0.0, np.array([0.75]), []))))
        assert got == {k: float(v) for k, v in TYPES3_AT_075.items()}
        low = dict(zip(names, (float(v[0]) for v in block.output(0.0, np.array([0.25]), []))))
        assert (low["on"], low["mode"], low["i8"], low["u64"]) == (0.0, 1.0, -98.0, 2.0 ** 40 + 250000)
        fmu = block._fmu  # fmpy's own getters on the same instance agree
        for typ, (positions, vrs, _) in block.out_types.items():
            getter = getattr(fmu, "getInt64" if typ == "Enumeration" else "get" + typ)
            assert [float(v) for v in getter(vrs)] == [low[names[p]] for p in positions]
    finally:
        block.close()


def test_event_indicators_and_derivatives_are_fmpys(plant):
    block = FMUBlock("plant", path=str(plant), mode="me", parameters={"balance": 1, "preload": 10.0})
    try:
        x0 = block.initial_state()
        u = [np.array([8.0, 20.0]), np.array([0.5]), np.array([0.0])]
        rng = np.random.default_rng(1)
        fmu = block._fmu
        for _ in range(5):
            x = x0 + 1e-4 * rng.standard_normal(x0.size)
            z, dx = block.zero_crossings(0.2, x, u), block.derivatives(0.2, x, u)
            ref_z, ref_dx = np.zeros(block.nz), np.zeros(block.nx)
            ptr = ctypes.POINTER(ctypes.c_double)
            fmu.getEventIndicators(ref_z.ctypes.data_as(ptr), block.nz)
            (fmu.getContinuousStateDerivatives if block.fmi3 else fmu.getDerivatives)(
                ref_dx.ctypes.data_as(ptr), block.nx)
            assert np.array_equal(z, ref_z) and np.array_equal(dx, ref_dx)
    finally:
        block.close()


def test_a_failing_call_names_the_function_the_status_the_block_and_its_file(vdp):
    block = FMUBlock("vdp", path=str(vdp), mode="me")
    try:
        block.initial_state()
        fmi3 = block.fmi3
        wrong = BoundCalls(block._fmu, fmi3, 3, 0, block.out_types)  # the FMU has 2 states
        assert wrong.set_state(0.0, np.zeros(3)) == ("fmi3SetContinuousStates" if fmi3 else
                                                     "fmi2SetContinuousStates", 3)
        assert wrong.get_dx() == 3
        assert str(wrong.failure("get_dx", 3)).endswith("failed with status 3 (error).")
        block._calls, block._sent_state = wrong, None
        said = (r"FMU block 'vdp' \(" + re.escape(str(vdp)) + r"\): setContinuousStates at t=0.5 failed: "
                r"fmi[23]SetContinuousStates failed with status 3")
        with pytest.raises(FMUError, match=said):
            block.derivatives(0.5, np.zeros(3), [])
    finally:
        block.close()


def test_unchanged_inputs_are_not_written_again(plant):
    block = FMUBlock("plant", path=str(plant), mode="me")
    try:
        x = block.initial_state()
        writes = []
        fmu = block._fmu
        name = "setFloat64" if block.fmi3 else "setReal"
        setter = getattr(fmu, name)
        setattr(fmu, name, lambda vrs, values, *rest: writes.append(list(values)) or setter(vrs, values, *rest))
        u = [np.array([8.0, 20.0]), np.array([0.6]), np.array([0.0])]
        first = block.derivatives(0.0, x, u)
        assert writes == [[8.0, 20.0, 0.6]]  # v_surface keeps its start value 0: not written
        for t in (0.001, 0.002):
            block.derivatives(t, x, u)
        assert len(writes) == 1
        u[0][1] = 21.0  # a wire buffer changed in place: written, and the derivatives see it
        second = block.derivatives(0.003, x, u)
        assert writes[-1] == [21.0] and not np.array_equal(first, second)
    finally:
        block.close()
