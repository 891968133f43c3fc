"""Parameters that name one of a few choices: a wrong value of any type is a ParameterError naming
the parameter and the choices (a list used to leak Python's "unhashable type: 'list'")."""
import pytest

import hybridsim as hs
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import lookup


@pytest.mark.parametrize("block, param, choices", [
    ("hit_crossing", "direction", "rising, falling or either"),
    ("minmax", "function", "min or max"),
    ("quantizer", "rounding", "even or away"),
    ("chirp", "method", "linear or logarithmic"),
    ("manipulator", "friction_model", "karnopp, stribeck or lugre"),
])
@pytest.mark.parametrize("value", [["rising", "falling"], 3, None, "sideways"])
def test_a_choice_given_anything_else_names_the_parameter_and_its_choices(block, param, choices, value):
    with pytest.raises(ParameterError, match=f"must be {choices}, got") as err:
        lookup(block)(**{param: value})
    assert err.value.param == param


def test_a_list_for_a_choice_in_a_file_is_bad_input_on_its_line(tmp_path):
    path = tmp_path / "d.yaml"
    path.write_text("blocks:\n  s: {type: sine}\n  hc:\n    type: hit_crossing\n    direction: [rising, falling]\n"
                    "wires: [s.y -> hc.u]\n")
    with pytest.raises(hs.errors.DiagramError, match=r"d\.yaml:5: .*'direction' must be rising, falling or either"):
        hs.build(path)


@pytest.mark.parametrize("text, hint", [("inf", "infinity as .inf"), ("-inf", "infinity as -.inf"),
                                        ("Infinity", "infinity as .inf"), ("nan", "not-a-number as .nan")])
@pytest.mark.parametrize("block, param, extra", [("force_pi", "limit", {"rate": 100}), ("integrator", "upper", {}),
                                                 ("gain", "K", {})])
def test_infinity_spelled_as_a_word_is_told_yaml_spelling(block, param, extra, text, hint):
    # YAML reads `inf` as a string (``.inf`` is the number): the error says how to write it
    with pytest.raises(ParameterError, match=f"got '{text}' \\(YAML writes {hint}\\)"):
        lookup(block)(**{param: text}, **extra)


@pytest.mark.parametrize("value", [["inf", "inf"], [1.0, "2"], [[1.0, 0.0], [0.0, "inf"]]])
def test_a_word_inside_a_list_of_numbers_is_refused_too(value):
    # numpy read ['inf', 'inf'] as infinities and ['1', '2'] as numbers: a number written as text
    with pytest.raises(ParameterError, match="must be a number"):
        lookup("force_pi")(limit=value[:2] if isinstance(value[0], list) else value, rate=100,
                           Kp=value if isinstance(value[0], list) else 0.4)


@pytest.mark.parametrize("block, kw", [
    ("state_space", {"A": [["inf"]], "B": [[1.0]], "C": [[1.0]], "D": [[0.0]]}),
    ("lookup_nd", {"breakpoints": [[0.0, 1.0]], "table": [0.0, "1"]}),
    ("lookup_2d", {"table": [[0.0, 0.0], [0.0, "nan"]]}),
])
def test_every_numeric_table_refuses_numbers_written_as_words(block, kw):
    with pytest.raises(ParameterError, match="must be a (matrix|nested list) of numbers"):
        lookup(block)(**kw)
