import re

import pytest

import hybridsim as hs
from hybridsim.errors import DiagramError, InputError, LoaderError
from hybridsim.format import DiagramFile

from conftest import GOOD, write


def test_good_file_builds_and_substitutes(tmp_path):
    f = DiagramFile(write(tmp_path, GOOD))
    d, settings = f.build()
    assert d.blocks["g"].params[0][0, 0] == 2.0  # K
    assert settings["simulation"]["log_period"] == 0.01  # 1.0e-2 read as a number
    d.build()


def test_yaml_syntax_error_names_file_and_line(tmp_path):
    p = write(tmp_path, GOOD.replace("  g:    {type: gain, K: $k}", "  g:    {type: gain, K: [1, 2}"))
    with pytest.raises(LoaderError, match=r"d\.yaml:5: YAML syntax error"):
        DiagramFile(p)


def test_unknown_block_type_with_line_and_suggestion(tmp_path):
    p = write(tmp_path, GOOD.replace("type: gain", "type: gian"))
    with pytest.raises(DiagramError) as exc:
        DiagramFile(p).build()
    (msg,) = [m for m in exc.value.problems if "unknown block type" in m]
    assert "d.yaml:5" in msg and "did you mean 'gain'" in msg


def test_unknown_parameter_closest_name(tmp_path):
    p = write(tmp_path, GOOD.replace("K: $k", "KK: $k"))
    with pytest.raises(DiagramError) as exc:
        DiagramFile(p).build()
    assert any("no parameter 'KK'" in m and "did you mean 'K'" in m and "d.yaml:5" in m
               for m in exc.value.problems)


def test_undefined_reference_and_missing_type(tmp_path):
    p = write(tmp_path, GOOD.replace("$k", "$kk").replace("{type: zoh, rate: 100}", "{rate: 100}"))
    with pytest.raises(DiagramError) as exc:
        DiagramFile(p).build()
    msgs = "\n".join(exc.value.problems)
    assert "undefined parameter reference '$kk' (did you mean 'k'?)" in msgs
    assert "block 'zoh' has no 'type'" in msgs


@pytest.mark.parametrize("word", ["on", "off", "yes", "No", "true", "null", "~"])
def test_a_key_yaml_reads_as_a_boolean_or_null_is_refused_at_its_line(tmp_path, word):
    # `params: {on: 0.25}` made the key True: '$on' was undefined, and its suggestion crashed
    p = write(tmp_path, f"params:\n  {word}: 0.25\nblocks:\n  c: {{type: constant, value: 1.0}}\n")
    with pytest.raises(LoaderError, match=rf"d\.yaml:2: the key '{re.escape(word)}' reads as (True|False|None) in YAML.*"
                                          rf"quote it \('{re.escape(word)}'\)"):
        DiagramFile(p)
    quoted = write(tmp_path, f"params:\n  '{word}': 0.25\nblocks:\n  c: {{type: constant, value: ${word}}}\n")
    diagram, _ = DiagramFile(quoted).build()
    assert diagram.blocks["c"].params[0][0] == 0.25


def test_a_suggestion_among_names_that_are_not_text_does_not_crash():
    from hybridsim.engine.registry import closest

    assert closest("on", [True, 5, "one"]) == " (did you mean 'one'?)"


def test_wrong_type_of_value(tmp_path):
    p = write(tmp_path, GOOD.replace("K: $k", "K: fast"))
    with pytest.raises(DiagramError, match="block 'g' \\(gain\\)"):
        DiagramFile(p).build()


def test_missing_blocks_and_unknown_section(tmp_path):
    with pytest.raises(LoaderError, match="missing required section 'blocks'"):
        DiagramFile(write(tmp_path, "params: {}\n"))
    with pytest.raises(LoaderError, match=r"d\.yaml:1: unknown section 'paramz' \(did you mean 'params'"):
        DiagramFile(write(tmp_path, "paramz: {}\nblocks: {}\n"))
    # blocks: {} passed check and run wrote an empty figure, exit 0
    with pytest.raises(LoaderError, match=r"d\.yaml:2: section 'blocks' is empty; it holds \{name: "):
        DiagramFile(write(tmp_path, "name: j\nblocks: {}\n"))


def test_bad_solver_and_t_end(tmp_path):
    with pytest.raises(LoaderError, match="unknown solver 'radua'"):
        DiagramFile(write(tmp_path, GOOD.replace("t_end: 0.2", "t_end: 0.2, solver: radua"))).build()
    with pytest.raises(LoaderError, match="'t_end' must be a positive, finite number"):
        DiagramFile(write(tmp_path, GOOD.replace("t_end: 0.2", "t_end: -1"))).build()


def test_bad_rate_is_its_own_message(tmp_path):
    with pytest.raises(DiagramError, match="bad rate: rate must be positive"):
        DiagramFile(write(tmp_path, GOOD.replace("rate: 100", "rate: -100"))).build()


def test_extends_merges_blocks_and_params(tmp_path):
    write(tmp_path, GOOD, "base.yaml")
    child = write(tmp_path, "extends: base.yaml\nparams: {k: 5.0}\nblocks:\n  src: {final: 3.0}\n", "child.yaml")
    d, _ = DiagramFile(child).build()
    assert d.blocks["g"].params[0][0, 0] == 5.0 and d.blocks["src"].params[1] == (3.0,)  # K, final
    assert len(d.wires) == 2


def test_removing_a_block_the_base_has_not_is_named(tmp_path):
    # 'gg: null' said "block 'gg' must be a mapping with a 'type'"
    write(tmp_path, GOOD, "base.yaml")
    child = write(tmp_path, "extends: base.yaml\nblocks:\n  gg: null\n", "child.yaml")
    with pytest.raises(LoaderError, match=r"child\.yaml:3: block 'gg': null removes a block of 'base.yaml', which "
                                          r"has none of that name \(did you mean 'g'\?\)"):
        DiagramFile(child)


@pytest.mark.parametrize("base_text, line, says", [
    ("blocks:\n  c: {type: constant}\nsimulation:\n  t_end: 1\n  solvr: rk4\n", 5, "unknown simulation setting 'solvr'"),
    ("blocks:\n  c: {type: constant}\nmetrics: {step_tme: 1}\n", 3, "unknown metrics setting 'step_tme'"),
    ("blocks:\n  c: {type: constant}\nsimulaton:\n  t_end: 1\n", 3, "unknown section 'simulaton'"),
    ("blocks:\n  c: {type: constant}\nsimulation: 5\n", 3, "section 'simulation' must be a mapping"),
    ("params: {a: 1, b: $a}\nblocks:\n  c: {type: constant}\n", 1, "parameter 'b' refers to $a"),
    ("params: {r: 1}\nblocks:\n  c: {type: constant}\nvariants: {r: 5}\n", 4, "variant 'r' must be a non-empty list"),
    ("blocks:\n  c: {type: constant}\nsignals: {forse: c.y}\n", 3, "unknown signal role 'forse'"),
])
def test_a_mistake_in_an_extended_file_is_named_in_that_file(tmp_path, base_text, line, says):
    # named with the extending file's path and the base file's line
    base = write(tmp_path, base_text, "base.yaml")
    child = write(tmp_path, "extends: base.yaml\nblocks:\n  c: {value: 2}\n", "child.yaml")
    with pytest.raises(LoaderError) as err:
        f = DiagramFile(child)
        f.build()
        f.variants()
    assert str(err.value).startswith(f"{base.resolve()}:{line}: {says}")


def test_overrides_and_variants(tmp_path):
    p = write(tmp_path, GOOD + "variants: {k: [1.0, 3.0]}\n")
    f = DiagramFile(p, {"g.K": 4.0, "simulation.t_end": 0.5})
    assert [v for _, v in f.variants()] == [{"k": 1.0}, {"k": 3.0}]
    d, s = f.build()
    assert d.blocks["g"].params[0][0, 0] == 4.0 and s["simulation"]["t_end"] == 0.5
    with pytest.raises(LoaderError, match="no parameter 'kk'"):
        DiagramFile(p, {"kk": 1})


def test_a_variant_of_a_block_parameter_says_how_to_vary_it_through_a_parameter(tmp_path):
    p = write(tmp_path, GOOD + "variants: {zoh.rate: [50, 100]}\n")
    with pytest.raises(LoaderError, match=r"d\.yaml:\d+: variant 'zoh.rate' .*'rate: \$rate' in 'zoh'"):
        DiagramFile(p).variants()


def test_a_metrics_setting_is_set_like_a_simulation_setting(tmp_path):
    # it said "no block 'metrics'": every section with a settings table takes SECTION.KEY
    import hybridsim.forcecontrol.settings  # noqa: F401 (the metrics settings' table rows)

    p = write(tmp_path, GOOD)
    f = DiagramFile(p, {"metrics.step_time": 0.15, "simulation.t_end": 0.3})
    settings = f.build()[1]
    assert settings["metrics"]["step_time"] == 0.15 and settings["simulation"]["t_end"] == 0.3
    with pytest.raises(LoaderError, match=r"override metrics.stepp_time: unknown metrics setting 'stepp_time' "
                                          r"\(did you mean 'step_time'\?\)"):
        DiagramFile(p, {"metrics.stepp_time": 1.0})
    with pytest.raises(LoaderError, match="'metrics.step_time' is a setting of 'metrics': not a run-time parameter"):
        DiagramFile(p).runtime_params({"metrics.step_time": 1.0})


def test_an_unknown_plot_setting_is_an_error_at_its_line(tmp_path):
    # a misspelt label used to be ignored and the figure silently kept its default
    f = DiagramFile(write(tmp_path, GOOD + "plot:\n  title: mine\n  force_lable: C-Z force\n"))
    with pytest.raises(LoaderError, match=r"d.yaml:\d+.*unknown plot setting 'force_lable' \(did you mean 'force_label'\?\)"):
        f.build()
    ok = DiagramFile(write(tmp_path, GOOD + "plot: {title: mine, force_label: C-Z force}\n"))
    assert ok.build()[1]["plot"] == {"title": "mine", "force_label": "C-Z force"}


def test_a_sweep_or_tune_file_given_as_a_diagram_says_which_command_runs_it(tmp_path):
    # it said "unknown section 'diagram' (did you mean 'params'?)"
    sweep = write(tmp_path, "diagram: d.yaml\ngrid: {k: [1, 2]}\n", "s.yaml")
    with pytest.raises(LoaderError, match=r"s\.yaml:1: this is a sweep file, not a diagram file; run it with "
                                          r"'hybridsim sweep'"):
        DiagramFile(sweep)
    tune = write(tmp_path, "diagram: d.yaml\nparameters: {k: [1, 2]}\n", "t.yaml")
    with pytest.raises(LoaderError, match="this is a tune file, not a diagram file; run it with 'hybridsim tune'"):
        DiagramFile(tune)
    from hybridsim.runs.sweep import Sweep
    from hybridsim.tune.spec import TuneSpec

    with pytest.raises(LoaderError, match=r"d\.yaml:1: this is a diagram file, not a sweep file; run it with 'hybridsim run'"):
        Sweep(write(tmp_path, GOOD))
    with pytest.raises(LoaderError, match="this is a sweep file, not a tune file; run it with 'hybridsim sweep'"):
        TuneSpec(sweep)


def test_a_parameter_set_with_every_value_that_uses_it_is_refused(tmp_path):
    # k = 3 with g.K = 1 ran with K = 1: the k the user gave was silently lost
    p = write(tmp_path, GOOD)
    with pytest.raises(LoaderError, match=r"override k: changes nothing: every value that uses \$k is set too \(g\.K\)"):
        DiagramFile(p, {"k": 3.0, "g.K": 1.0})
    both = write(tmp_path, GOOD.replace("  zoh:  {type: zoh, rate: 100}", "  zoh:  {type: zoh, rate: 100}\n"
                                        "  h:    {type: gain, K: $k}").replace("  - g.y -> zoh.u", "  - g.y -> zoh.u\n  - src.y -> h.u"), "two.yaml")
    diagram, _ = DiagramFile(both, {"k": 3.0, "g.K": 1.0}).build()  # h still takes k
    assert diagram.blocks["h"].params[0][0][0] == 3.0 and diagram.blocks["g"].params[0][0][0] == 1.0


def test_a_value_left_empty_and_a_path_into_a_plain_block_say_so(tmp_path):
    # they said "must be finite, got [nan]" and "no block 'g' (did you mean 'g'?)"
    p = write(tmp_path, GOOD)
    with pytest.raises(DiagramError) as exc:
        DiagramFile(p, {"g.K": None}).build()
    assert "got None (null: a value left empty in YAML)" in "\n".join(exc.value.problems)
    with pytest.raises(LoaderError, match=r"override g\.x\.K: block 'g' is not a subsystem; its parameters are set as g\."):
        DiagramFile(p, {"g.x.K": 3.0})


def test_atol_of_the_wrong_length_names_its_line(tmp_path):
    from hybridsim.format.build import build

    p = write(tmp_path, GOOD.replace("simulation: {t_end: 0.2, log_period: 1.0e-2}",
                                     "blocks_end: 0\nsimulation:\n  solver: radau\n  atol: [1.0e-6, 1.0e-6, 1.0e-6, 1.0e-6, 1.0e-6, 1.0e-6, 1.0e-6]")
              .replace("blocks_end: 0\n", "").replace("  zoh:  {type: zoh, rate: 100}",
                                                          "  zoh:  {type: zoh, rate: 100}\n  i: {type: integrator}")
              .replace("  - g.y -> zoh.u", "  - g.y -> zoh.u\n  - g.y -> i.u"))
    with pytest.raises(InputError, match=r"d\.yaml:14: simulation setting 'atol' has 7 value\(s\); one per "
                                          r"continuous state needs \d"):
        build(p)


@pytest.mark.parametrize("name", ["a.b", "", "x y", "k$"])
def test_a_parameter_name_that_neither_dollar_nor_set_can_reach_is_refused(tmp_path, name):
    p = write(tmp_path, f"params:\n  {name!r}: 1.0\nblocks:\n  c: {{type: constant, value: 1.0}}\n")
    with pytest.raises(LoaderError, match=r"d\.yaml:2: parameter name .* may not be empty or contain"):
        DiagramFile(p)


def test_a_parameter_that_refers_to_another_is_refused_at_its_line(tmp_path):
    # params {kp: $kq, kq: 20}: the error named the block using $kp ("got '$kq'"), not the cause
    p = write(tmp_path, "params:\n  kq: 20.0\n  kp: $kq\nblocks:\n  g: {type: gain, K: $kp}\n")
    with pytest.raises(LoaderError, match=r"d\.yaml:3: parameter 'kp' refers to \$kq"):
        DiagramFile(p)


@pytest.mark.parametrize("solver", ["rk4", "radau", "cvode"])
def test_scan_is_a_simulation_setting_every_solver_takes(tmp_path, solver):
    # the event functions were checked every 1 ms on every solver, whatever the step: a limited
    # integrator over 1025 s took 20-40 s, and nothing in a diagram could change it
    from hybridsim.format.build import build

    p = write(tmp_path, "blocks:\n  c: {type: constant, value: 1.0}\n  i: {type: integrator, K: 1.0e-4, upper: 1.0}\n"
                        "wires: [c.y -> i.u]\nsimulation: {t_end: 1025, step: 1.0, log_period: 1.0, scan: 10}\n"
                        "log: [i.y]\n")
    _, sim, settings = build(p, solver=solver)
    assert sim.solver.scan == 10.0 and sim.session(sim._context(None)[0]).lim.scan == 10.0
    assert abs(sim.run(1025.0)["i.y"][-1, 0] - 0.1025) < 1e-9


def test_a_keyword_that_is_a_parameter_and_a_setting_is_the_parameter_as_with_set(tmp_path):
    # hs.simulate(path, step=2.0) changed simulation.step where the diagram has a param 'step' (the
    # CLI's --set step=2.0 sets the param): the API now reads it as the CLI does
    import hybridsim as hs

    p = tmp_path / "clash.yaml"
    p.write_text("params: {step: 1.0}\nblocks:\n  c: {type: constant, value: $step}\n  i: {type: integrator}\n"
                 "wires: [c.y -> i.u]\nlog: [i.y]\nsimulation: {t_end: 1.0, solver: rk4, step: 1.0e-3}\n")
    assert hs.simulate(p, step=2.0)["i.y"][-1] == pytest.approx(2.0, abs=1e-12)
    assert hs.simulate(hs.load(p), step=3.0)["i.y"][-1] == pytest.approx(3.0, abs=1e-12)
    r = hs.simulate(p, **{"simulation.step": 0.25, "t_end": 0.5})
    assert r.t[-1] == 0.5 and r["i.y"][-1] == pytest.approx(0.5, abs=1e-12)


def test_a_bare_setting_name_is_the_setting_in_set_sweeps_and_the_api_alike(tmp_path):
    # `--set t_end=2` was refused ("no parameter 't_end'") where hs.simulate(p, t_end=2) and a
    # sweep's `set: {t_end: 2}` took it: the rule is now DiagramFile.apply's, for every origin
    from hybridsim.app.cli import main

    p = tmp_path / "bare.yaml"
    p.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  i: {type: integrator}\n"
                 "wires: [c.y -> i.u]\nlog: [i.y]\nsimulation: {t_end: 1.0, solver: rk4, step: 1.0e-3}\n")
    assert main(["run", str(p), "--set", "t_end=2", "-o", str(tmp_path / "out"), "-q"]) == 0
    rows = (tmp_path / "out" / "bare.csv").read_text().strip().splitlines()
    assert rows[-1].split(",")[0] == "2" or float(rows[-1].split(",")[0]) == 2.0


def test_incommensurate_rates_name_the_file_and_each_blocks_line(tmp_path):
    import hybridsim as hs

    p = tmp_path / "rates.yaml"
    p.write_text("blocks:\n  a: {type: constant}\n  z: {type: zoh, rate: 10}\n  z2: {type: zoh, period: 0.1234567}\n"
                 "wires: [a.y -> z.u, a.y -> z2.u]\n")
    with pytest.raises(InputError, match=rf"^{re.escape(str(p))}: sample rates are not commensurate .*"
                                         rf"\(blocks: z at {re.escape(str(p))}:3, z2 at {re.escape(str(p))}:4\)"):
        hs.check(p)


@pytest.mark.parametrize("name, text, says", [
    ("arm.urdf", '<?xml version="1.0"?>\n<robot name="a"/>\n', "URDF robot description"),
    ("plant.fmu", "PK\x03\x04", "is a zip archive (an FMU?)"),
    ("page.yaml", "\n  <html><body>a: b</body></html>\n", "XML or HTML"),
    ("arm_as.yaml", '<?xml version="1.0"?>\n<robot name="a"/>\n', "URDF robot description"),  # by content
])
def test_a_file_of_another_kind_says_what_it_is_not_a_yaml_syntax_error(tmp_path, name, text, says):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(LoaderError) as err:
        DiagramFile(path)
    assert says in str(err.value) and "YAML syntax" not in str(err.value) and name in str(err.value)


def test_a_notebook_and_a_simulink_model_are_named_as_such(tmp_path):
    # a notebook said "unknown section 'cells'", an .slx "is a zip archive (an FMU?)"
    import zipfile

    nb = tmp_path / "nb.ipynb"
    nb.write_text('{"cells": [], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}\n')
    with pytest.raises(LoaderError, match="is a Jupyter notebook"):
        DiagramFile(nb)
    with zipfile.ZipFile(tmp_path / "m.slx", "w") as z:
        z.writestr("simulink/blockdiagram.xml", "<x/>")
    with pytest.raises(LoaderError, match=r"is a Simulink model \(.slx\)"):
        DiagramFile(tmp_path / "m.slx")


@pytest.mark.parametrize("name, text, says", [
    ("model.py", 'import numpy as np\nx = {"a": 1}\n', "model.py looks like Python source, not YAML"),
    ("notes.md", "# Title\n\nSome *text*: here\n- a\n", "notes.md looks like Markdown, not YAML"),
    ("pyproject.toml", '[tool]\nname = "x"\n', "pyproject.toml looks like TOML, not YAML"),
    ("readme.txt", "just words\n", "a diagram file must be a mapping"),  # reads as a YAML string
    # by content, whatever the name
    ("py.yaml", 'import numpy as np\nx = {"a": 1}\n', "py.yaml looks like Python source, not YAML"),
    ("conf.yaml", '[tool]\nname = "x"\n', "conf.yaml looks like TOML, not YAML"),
    ("model", 'Model {\n  Name "x"\n}\n', "model looks like a Simulink model, not YAML"),
])
def test_a_text_file_of_another_kind_is_named_beside_the_yaml_error(tmp_path, name, text, says):
    # a Python, Markdown or TOML file given as a diagram said only "YAML syntax error"
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(LoaderError) as err:
        DiagramFile(path)
    assert says in str(err.value) and "not YAML" in str(err.value)


def test_an_entry_of_an_fmu_blocks_parameters_is_set_by_its_path(tmp_path):
    # --set plant.parameters.unilateral=true said "block 'plant' is not a subsystem", and
    # plant.unilateral "no parameter"; only the whole mapping could be given
    p = write(tmp_path, "blocks:\n  plant: {type: fmu, path: p.fmu, parameters: {friction: false}}\n")
    f = DiagramFile(p, {"plant.parameters.unilateral": True})
    assert f.data["blocks"]["plant"]["parameters"] == {"friction": False, "unilateral": True}
    f = DiagramFile(write(tmp_path, "blocks:\n  plant: {type: fmu, path: p.fmu}\n", "e.yaml"),
                    {"plant.parameters.b": [1.0, 2.0]})
    assert f.data["blocks"]["plant"]["parameters"] == {"b": [1.0, 2.0]}
    f = DiagramFile(p, {"plant.parameters.b[1]": 5.0})  # an FMU's element variable: was "not a subsystem"
    assert f.data["blocks"]["plant"]["parameters"] == {"friction": False, "b[1]": 5.0}
    with pytest.raises(DiagramError) as exc:
        DiagramFile(p, {"plant.unilateral": True}).build()
    assert any("is set as plant.parameters.unilateral" in m for m in exc.value.problems)


def test_an_input_port_given_as_a_parameter_gets_its_wire_written_out(tmp_path):
    # 'reset' is an integrator's input port: it said only "has no parameter 'reset'"; a wire-like name
    # (input) got '- block.output -> g.input', a port the gain does not have
    p = write(tmp_path, "blocks:\n  c: {type: constant}\n  I: {type: integrator, reset: c.y}\n"
                        "  g: {type: gain, input: c.y}\n")
    with pytest.raises(DiagramError) as exc:
        DiagramFile(p).build()
    got = "\n".join(exc.value.problems)
    assert "'reset' is an input port" in got and "'- c.y -> I.reset'" in got
    assert "'- c.y -> g.u'; its inputs: u" in got


def test_a_zip_archive_named_yaml_is_named_as_one(tmp_path):
    import zipfile

    path = tmp_path / "plant_as.yaml"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
    with pytest.raises(LoaderError, match="is a zip archive \\(an FMU\\?\\)"):
        DiagramFile(path)


def test_a_yaml_diagram_is_read_whatever_its_files_name_ends_in(tmp_path):
    # the other kinds are known by their content: a diagram named d.xml was refused as XML
    f = DiagramFile(write(tmp_path, GOOD, "d.xml"))
    assert "zoh" in f.data["blocks"]


def test_an_override_of_the_python_api_is_not_called_a_command_line_option(tmp_path, capsys):
    # hs.simulate(path, nosuch=3) said "--set nosuch: no parameter"; the command line still says --set
    import hybridsim as hs
    from hybridsim.app.cli import main

    p = write(tmp_path, GOOD)
    with pytest.raises(LoaderError, match=r"override nosuch: no parameter 'nosuch'") as exc:
        hs.simulate(p, nosuch=3.0)
    assert "--set" not in str(exc.value)
    assert main(["check", str(p), "--set", "nosuch=3"]) == 2
    assert "--set nosuch: no parameter 'nosuch'" in capsys.readouterr().err


def test_an_unknown_key_inside_a_section_is_named_where_it_is_written(tmp_path):
    # 'solvr:' with a block below it was named at its first child's line (6, not 5); a misspelled
    # key of analysis.step at the line of 'step:'
    from hybridsim.format.build import check

    p = write(tmp_path, GOOD.replace("simulation: {t_end: 0.2, log_period: 1.0e-2}",
                                     "simulation:\n  t_end: 0.2\n  solvr:\n    name: rk4"))
    assert "  solvr:" in p.read_text().splitlines()[12 - 1]
    with pytest.raises(LoaderError, match=r"d\.yaml:12: unknown simulation setting 'solvr'"):
        check(p)
    p = write(tmp_path, GOOD + "analysis:\n  step:\n    input: src.y\n    output: zoh.y\n    sizee: 2\n", "e.yaml")
    with pytest.raises(LoaderError, match=r"e\.yaml:16: analysis setting 'step': unknown analysis.step setting 'sizee'"):
        check(p)


@pytest.mark.parametrize("text, says", [
    ("blocks:\n  c: {type: constant}\nsimulation: {solver: [rk4]}\n",
     "e.yaml:3: simulation setting 'solver' must be one of rk4"),  # said "unknown solver ['rk4'] (did you mean 'rk4'?)"
    ("blocks:\n  c: {type: null}\n", "e.yaml:2: block 'c': 'type' is a block type name"),  # "unknown block type None"
    ("blocks:\n  s: {type: subsystem, file: [sub.yaml]}\n", "e.yaml:2: subsystem 's': 'file' is one file name"),
    ("extends: dir.yaml\n", "e.yaml:1: 'extends' 'dir.yaml': a folder"),  # was named at the folder, no line
])
def test_a_value_of_the_wrong_shape_is_named_as_such(tmp_path, text, says):
    (tmp_path / "dir.yaml").mkdir()
    p = write(tmp_path, text, "e.yaml")
    with pytest.raises(InputError) as err:
        hs.check(p)
    assert says in str(err.value), str(err.value)


def test_a_parameter_no_value_uses_is_named_at_check(tmp_path, caplog):
    # 'params: {ratee: 5}' passed check and a run; setting it changed nothing
    write(tmp_path, GOOD, "base.yaml")
    p = write(tmp_path, "extends: base.yaml\nparams: {kk: 5}\n", "child.yaml")
    with caplog.at_level("WARNING", logger="hybridsim"):
        summary = hs.check_file(p)
    assert summary["unused_params"] == ["kk"]
    assert "parameter 'kk' is used by no value of the file (no $kk): setting it changes nothing (did you mean 'k'?)" \
        in caplog.text
    assert hs.check_file(tmp_path / "base.yaml")["unused_params"] == []
    # the file uses $k; an override that replaces that use does not make k unused (it was warned of)
    assert hs.check_file(tmp_path / "base.yaml", **{"g.K": 3.0})["unused_params"] == []


@pytest.mark.parametrize("text, kind", [
    ("Diagram: m.yaml\ngrid: {pid.Kp: [1, 2]}\n", "sweep"),  # was read as a diagram: "unknown section 'Diagram'"
    ("diagarm: m.yaml\nsett: {a: 1}\ngird: {k: [1, 2]}\n", "sweep"),
    ("Diagram: m.yaml\nparamters: {k: {low: 1, high: 2}}\nobjectivs: []\n", "tune"),
    ("diagram: m.yaml\nParameters: {k: {low: 1, high: 2}}\n", "tune"),
    ("blokcs: {}\n", "diagram"),
    ("name: x\n", None),
])
def test_a_file_is_known_by_its_keys_also_misspelled(text, kind):
    import yaml

    from hybridsim.format.filekinds import file_kind
    from hybridsim.format.yamlio import plain

    assert file_kind(plain(yaml.safe_load(text))) == kind


def test_a_bad_rate_names_where_its_parameter_got_the_value(tmp_path):
    # the base's use of $rate was named, not the extending file's value of it
    write(tmp_path, "params: {rate: 10}\nblocks:\n  c: {type: constant}\n  z: {type: zoh, rate: $rate}\n"
                    "wires: [c.y -> z.u]\n", "base.yaml")
    child = write(tmp_path, "extends: base.yaml\nparams: {rate: fast}\n", "child.yaml")
    with pytest.raises(DiagramError) as err:
        DiagramFile(child).build()
    assert any("bad rate" in m and "(the value of $rate, from " in m and "child.yaml:2)" in m for m in err.value.problems)
