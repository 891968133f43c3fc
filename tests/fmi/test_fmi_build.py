"""Building FMUs from C: the FMI 3.0 functions a model does not define are generated."""
import zipfile

import fmpy

from hybridsim.fmi.build import UNSUPPORTED_C, build_fmu, defined_functions, fmi3_functions, unsupported_source


def test_the_standard_declares_75_fmi3_functions():
    names = fmi3_functions()
    assert len(names) == 75  # FMI 3.0 fmi3Functions.h: every FMI3_Export declaration
    assert "fmi3InstantiateModelExchange" in names and "fmi3GetFloat64" in names


def test_definitions_are_told_from_calls_declarations_and_comments():
    text = """
    /* fmi3GetClock is not defined here */
    fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[],
                              size_t n, fmi3Float64 v[], size_t nv) {
        return fmi3DoStep(c);  // a call, not a definition
    }
    fmi3Status fmi3Reset(fmi3Instance c);
    static int helper(void) { return 0; }
    """
    assert defined_functions([text]) == {"fmi3GetFloat64"}


def test_a_model_with_only_some_functions_loads_in_fmpy(tmp_path):
    from pathlib import Path

    d = Path(__file__).parents[1] / "data" / "ball3"
    fmu = build_fmu(tmp_path / "ball3.fmu", "ball3", sorted(d.glob("*.c")),
                    (d / "modelDescription.xml").read_text(), {})
    with zipfile.ZipFile(fmu) as z:
        stubs = z.read(f"sources/{UNSUPPORTED_C}").decode()
    defined = defined_functions([p.read_text() for p in d.glob("*.c")])
    assert defined_functions([stubs]) == set(fmi3_functions()) - defined
    fmpy.dump(str(fmu))  # reads the model description
    res = fmpy.simulate_fmu(str(fmu), stop_time=0.1, fmi_type="ModelExchange")
    assert len(res) > 1


def test_the_generated_file_answers_fmi3_error():
    assert "int fmi3GetClock(void) { return 3; }" in unsupported_source(["fmi3GetClock"])
