"""One table per section drives validation, the schema, the API's defaults, --help and the docs page."""
import re
from pathlib import Path

import pytest

from hybridsim import api
from hybridsim.app.cli import build_parser, main
from hybridsim.format import tables
from hybridsim.format.paths import ParamPath
from hybridsim.format.schema import diagram_schema, sweep_schema

from conftest import DIAGRAMS, write
from conftest import GOOD

ROOT = Path(__file__).resolve().parents[2]
HC = DIAGRAMS / "hybrid_controller.yaml"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, err


# -- the analysis section: each bad value is exit 2 at its file:line, from the table -----------------

ANALYSIS_CASES = [
    ("scales: [1, x]", "'scales': item 1: must be a positive, finite number"),
    ("set: [1, 2]", "'set' must be a mapping"),
    ("points: 5", "'points' must be a mapping"),
    ("hand_mode_hz: fast", "'hand_mode_hz' must be a positive, finite number"),
    ("points: {force: 'ctrl.dF.y[7]'}", "index 7 is out of range"),
    ("points: {force: 'ctrl.nope.y[0]'}", "no block 'ctrl.nope'"),
    ("compare: yes-please", "'compare' must be a mapping"),
    ("step: {input: 'force_cmd.y[0]'}", "needs 'output'"),
    ("step: {input: 'force_cmd.y[0]', output: 'ctrl.ft.CF[0]', ticks: 0.5}", "'ticks' must be a whole number"),
    ("atol: [1, 2]", "unknown analysis setting 'atol' (did you mean 'at'?)"),
    ("at: -1", "'at' must be a time in seconds >= 0"),
    ("rates: []", "'rates' must be a list of at least 1"),
    ("gains: {K: nope.K}", "'nope.K' is not a block parameter"),
    ("set: {nope: 1}", "no parameter 'nope' in 'params'"),
    ("cases: {a: {simulation.stepp: 1}}", "unknown simulation setting 'stepp'"),
    ("rate_param: rte", "'rte' is not a name in 'params' (did you mean 'rate'?)"),
    ("gains: {K: 'a b'}", "is not a parameter path"),
]


@pytest.mark.parametrize("line, message", ANALYSIS_CASES)
def test_a_bad_analysis_value_is_exit_2_at_its_line(tmp_path, capsys, line, message):
    p = write(tmp_path, f"extends: {HC}\nanalysis:\n  {line}\n")
    code, err = run(capsys, "check", p)
    assert code == 2, err
    assert "d.yaml:3" in err and message in err, err


def test_analyze_and_report_read_the_checked_section(tmp_path, capsys):
    p = write(tmp_path, f"extends: {HC}\nanalysis:\n  hand_mode_hz: fast\n")
    for cmd in ("analyze", "report"):
        code, err = run(capsys, cmd, p, "-o", tmp_path / cmd)
        assert code == 2 and "d.yaml:3" in err and "hand_mode_hz" in err
        assert not (tmp_path / cmd).exists()


@pytest.mark.parametrize("section, line, message", [
    ("simulation", "atol: [1.0e-9, x]", "'atol' must be a positive, finite number or a list"),
    ("simulation", "solver: radua", "unknown solver 'radua' (did you mean 'radau'?)"),
    ("simulation", "solver: ode15s", "unknown solver 'ode15s' (here: cvode or bdf"),  # MATLAB's names
    ("simulation", "fused: yes-please", "'fused' must be true or false"),
    ("simulation", "max_step: -.inf", "'max_step' must be a positive"),
    ("metrics", "error_window: [2, 1]", "'error_window' must be a list of 2"),
    ("metrics", "ss_windw: 1", "unknown metrics setting 'ss_windw' (did you mean 'ss_window'?)"),
    ("plot", "title: [1]", "'title' must be a text"),
])
def test_every_section_is_checked_from_its_table(tmp_path, capsys, section, line, message):
    text = GOOD.replace("simulation: {t_end: 0.2, log_period: 1.0e-2}\n", "") + f"{section}:\n  {line}\n"
    code, err = run(capsys, "check", write(tmp_path, text))
    assert code == 2 and message in err and re.search(r"d\.yaml:\d+", err), err


def test_atol_one_per_state_is_used_and_a_wrong_count_is_exit_2(tmp_path, capsys):
    base = GOOD.replace("simulation: {t_end: 0.2, log_period: 1.0e-2}", "simulation: {t_end: 0.2, log_period: 1.0e-2, "
                        "solver: radau, atol: [1.0e-9, 2.0e-9]}")
    base = base.replace("  zoh:  {type: zoh, rate: 100}", "  zoh:  {type: zoh, rate: 100}\n  lp: {type: lowpass, cutoff: 5.0}")
    base = base.replace("  - g.y -> zoh.u\n", "  - g.y -> zoh.u\n  - g.y -> lp.u\n")
    system, sim, _ = api.build(write(tmp_path, base))
    assert system.n_x == 2 and list(sim.solver.atol) == [1e-9, 2e-9]  # the lowpass's two states
    code, err = run(capsys, "check", write(tmp_path, base.replace("atol: [1.0e-9, 2.0e-9]", "atol: [1.0e-9, 1.0e-9, 1.0e-9]"), "e.yaml"))
    assert code == 2 and "'atol' has 3 value(s)" in err


def test_a_given_atol_tightens_the_states_whose_block_declares_a_looser_one(tmp_path):
    # a block's own tolerances (the lowpass's 1e-9, robot_arm's 1e-8 on q') stood against the user's
    # atol: 1e-12 on panda under bdf left an error of 6e-7 rad where the setting asked for far less
    base = GOOD.replace("simulation: {t_end: 0.2, log_period: 1.0e-2}", "simulation: {t_end: 0.2, log_period: 1.0e-2, "
                        "solver: radau}")
    base = base.replace("  zoh:  {type: zoh, rate: 100}", "  zoh:  {type: zoh, rate: 100}\n  lp: {type: lowpass, cutoff: 5.0}")
    base = base.replace("  - g.y -> zoh.u\n", "  - g.y -> zoh.u\n  - g.y -> lp.u\n")
    p = write(tmp_path, base)
    for atol, expected in ((None, [1e-9, 1e-9]), (1e-12, [1e-12, 1e-12]), (1e-6, [1e-9, 1e-9])):
        _, sim, _ = api.build(p, **({} if atol is None else {"simulation.atol": atol}))
        assert list(sim.solver.atol) == expected


def test_the_docs_page_is_current():
    page = (ROOT / "docs" / "settings.md").read_text()
    assert page == tables.markdown(), "run: python3 -c \"from hybridsim.format.tables import markdown; " \
                                      "open('docs/settings.md','w').write(markdown())\""
    for table in tables.SECTIONS.values():
        for s in table:
            assert f"`{s.key}`" in page


def test_the_schema_and_the_api_defaults_come_from_the_tables():
    schema = diagram_schema()
    sim = schema["properties"]["simulation"]
    assert set(sim["properties"]) == set(tables.keys(tables.SIMULATION))
    assert sim["properties"]["solver"]["anyOf"][0] == {"enum": tables.SOLVERS}
    assert set(schema["properties"]["analysis"]["properties"]) == set(tables.keys(tables.ANALYSIS))
    assert schema["properties"]["analysis"]["properties"]["step"]["anyOf"][0]["required"] == ["input", "output"]
    assert set(sweep_schema()["properties"]) == set(tables.keys(tables.SWEEP))
    from hybridsim.format import build

    assert build._SIM == tables.defaults(tables.SIMULATION)
    from hybridsim.analysis.stability import DEFAULTS

    assert DEFAULTS["scales"] == tables.defaults(tables.ANALYSIS)["scales"]


def test_help_lists_the_simulation_settings_and_exit_codes():
    text = build_parser().format_help()
    assert tables.help_text(tables.SIMULATION) in text
    assert "5 the" in text and "6 a plugin" in text


@pytest.mark.slow
def test_the_schema_refuses_what_the_table_refuses():
    import jsonschema

    schema = diagram_schema()
    good = {"blocks": {}, "analysis": {"scales": [1, 2], "step": {"input": "a.y[0]", "output": "b.y"}}}
    jsonschema.validate(good, schema)
    for bad in ({"blocks": {}, "analysis": {"scales": ["x"]}}, {"blocks": {}, "analysis": {"step": {"input": "a.y"}}},
                {"blocks": {}, "simulation": {"fused": "yes"}}, {"blocks": {}, "metrics": {"nope": 1}}):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(bad, schema)


# -- one parsed type for a parameter path ---------------------------------------------------------

@pytest.mark.parametrize("text, kind, key", [
    ("k", "param", "k"), ("params.k", "param", "k"), ("g.K", "block", "g.K"), ("blocks.g.K", "block", "g.K"),
    ("ctrl.pid.Kp[2]", "block", "ctrl.pid.Kp[2]"), ("simulation.t_end", "simulation", "simulation.t_end"),
    (" k ", "param", "k"),
])
def test_param_path_spellings_have_one_key(text, kind, key):
    p = ParamPath.parse(text)
    assert (p.kind, p.key) == (kind, key)


@pytest.mark.parametrize("text", ["", "a..b", "a b", "g.K[x]", "params.a.b", "simulation.a.b", "blocks.g", "a=b"])
def test_a_bad_param_path_is_refused(text):
    with pytest.raises(ValueError):
        ParamPath.parse(text)


def test_set_one_element_of_a_vector_parameter(tmp_path, capsys):
    p = write(tmp_path, GOOD.replace("K: $k", "K: [[1.0]]").replace("rate: 100", "rate: 100, initial: [0.0]"))
    f = api.load(p, **{"zoh.initial[0]": 3.0})
    assert f.data["blocks"]["zoh"]["initial"] == [3.0]
    code, err = run(capsys, "check", p, "--set", "zoh.initial[4]=1")
    assert code == 2 and "index 4 is out of range" in err
    arm = DIAGRAMS / "fig9_force_and_position.yaml"
    f = api.load(arm, **{"ctrl.fpi.Ki[1]": 7.0})
    assert f.param_value("ctrl.fpi.Ki").tolist()[1] == 7.0


def test_a_sweep_naming_one_parameter_twice_is_refused(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{k: [1, 2], params.k: [3, 4]}}\n", "s.yaml")
    code, err = run(capsys, "sweep", s, "-q", "-o", tmp_path / "o")
    assert code == 2 and "s.yaml:2" in err and "are the same parameter (k)" in err
    assert not (tmp_path / "o").exists()
    s.write_text(f"diagram: {d}\nset: {{g.K: 2}}\nscale: {{blocks.g.K: [1, 2]}}\n")
    code, err = run(capsys, "sweep", s, "-q", "-o", tmp_path / "o")
    assert code == 2 and "same parameter (g.K)" in err


@pytest.mark.parametrize("text, message", [
    ("diagram: d.yaml\ngrid: {k: 5}\n", "'grid': 'k': must be a list"),
    ("diagram: d.yaml\ntraces: maybe\n", "'traces' must be true or false"),
    ("diagram: d.yaml\nrandom: {n: 0, ranges: {k: [1, 2]}}\n", "'n' must be a whole number from 1"),
    ("diagram: d.yaml\nrandom: {n: 3}\n", "needs 'ranges'"),
    ("diagram: d.yaml\ngrd: {k: [1]}\n", "unknown sweep setting 'grd' (did you mean 'grid'?)"),
    ("grid: {k: [1]}\n", "sweep needs 'diagram'"),
])
def test_a_bad_sweep_file_is_exit_2_from_its_table(tmp_path, capsys, text, message):
    write(tmp_path, GOOD)
    s = write(tmp_path, text, "s.yaml")
    code, err = run(capsys, "sweep", s, "-q", "-o", tmp_path / "o")
    assert code == 2 and message in err, err


@pytest.mark.parametrize("spec, message", [
    ("{type: fmu, path: 5}", "parameter 'path' must be a non-empty text"),
    ("{type: fmu, path: p.fmu, mode: xx}", "parameter 'mode' must be one of cs, me"),
    ("{type: fmu, path: p.fmu, rate: -1}", "parameter 'rate' must be a positive"),
    ("{type: robot_arm, robot: fig3_arm, friction: yes-please}", "parameter 'friction' must be true or false"),
    ("{type: robot_arm, robot: fig3_arm, gravity: [1, 2]}", "parameter 'gravity' must be a list of 3"),
    ("{type: robot_kinematics, urdf: 7}", "parameter 'urdf' must be a non-empty text"),
])
def test_fmu_and_robot_parameters_are_checked_from_their_tables(tmp_path, capsys, spec, message):
    code, err = run(capsys, "check", write(tmp_path, f"blocks:\n  b: {spec}\n"))
    assert code == 2 and "d.yaml:2" in err and message in err, err
    schema = diagram_schema()
    fmu = next(b for b in schema["properties"]["blocks"]["additionalProperties"]["anyOf"] if b.get("title") == "fmu")
    assert fmu["properties"]["mode"]["anyOf"][0] == {"enum": ["cs", "me"]}


def test_the_metrics_defaults_come_from_the_table(tmp_path):
    _, settings = api.load(write(tmp_path, GOOD)).build()
    assert settings["metrics"] == {k: v for k, v in tables.defaults(tables.METRICS).items() if v is not None}
    _, settings = api.load(write(tmp_path, GOOD + "metrics: {ss_window: 0.1}\n", "e.yaml")).build()
    assert settings["metrics"]["ss_window"] == 0.1 and settings["metrics"]["filter_cutoff"] == 12.0


def test_check_refuses_an_analysis_gain_that_names_no_parameter_with_its_line(tmp_path, capsys):
    from hybridsim.app.cli import main

    p = tmp_path / "g.yaml"
    p.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  g: {type: gain, K: 2.0}\nwires: [c.y -> g.u]\n"
                 "simulation: {t_end: 0.01}\nanalysis:\n  gains: {k: g.Kq}\n")
    assert main(["check", str(p)]) == 2
    err = capsys.readouterr().err
    assert f"{p}:7: analysis gain 'k' 'g.Kq': block 'g' has no parameter 'Kq' (did you mean 'K'?)" in err, err


def test_check_refuses_an_analysis_gain_that_is_not_a_number_with_its_line(tmp_path, capsys):
    from hybridsim.app.cli import main

    p = tmp_path / "g.yaml"
    p.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  pid: {type: discrete_pid, rate: 100}\n"
                 "wires: [c.y -> pid.r, c.y -> pid.y]\nsimulation: {t_end: 0.01}\nanalysis:\n  gains: {aw: pid.anti_windup}\n")
    assert main(["check", str(p)]) == 2  # analyze ended in a ValueError (exit 70)
    err = capsys.readouterr().err
    assert f"{p}:7: analysis gain 'aw' 'pid.anti_windup': 'pid.anti_windup' is 'clamping', not a number" in err, err


@pytest.mark.parametrize("section, message", [
    ("{set: {g.K: abc}}", "analysis set ({'g.K': 'abc'})"),
    ("{cases: {big: {g.K: [1, 2]}}}", "analysis cases big"),
    ("{set: {simulation.solver: foo}}", "unknown solver 'foo'"),
    ("{step: {input: c.y, output: g.y, set: {c.nosuch: 1}}}", "analysis step"),
    ("{compare: {big: {g.Kx: 2}}}", "analysis compare big"),
])
def test_check_builds_the_analysis_branches_as_analyze_does(tmp_path, capsys, section, message):
    from hybridsim.app.cli import main

    p = tmp_path / "g.yaml"
    p.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  g: {type: gain, K: 2.0}\nwires: [c.y -> g.u]\n"
                 f"simulation: {{t_end: 0.01}}\nanalysis: {section}\n")
    command = ["report", str(p), "-o", str(tmp_path / "rep")] if "compare" in section else ["analyze", str(p)]
    for argv in (["check", str(p)], command):  # analyze and report named a '--set' the user never gave
        assert main(argv) == 2  # check said OK; analyze then refused it
        err = capsys.readouterr().err
        assert f"{p}:6: " in err and message in err and "--set" not in err, (argv, err)


@pytest.mark.parametrize("values", ["[1, 1]", "[0.1, 0.10000000000000001]"])
def test_a_variant_value_listed_twice_is_refused_at_its_line(tmp_path, capsys, values):
    from hybridsim.app.cli import main

    p = tmp_path / "v.yaml"
    p.write_text("params: {k: 1.0}\nblocks:\n  c: {type: constant, value: $k}\nsimulation: {t_end: 0.01}\n"
                 f"variants:\n  k: {values}\n")
    assert main(["check", str(p)]) == 2  # ran twice into one CSV
    assert f"{p}:6: variant 'k' lists" in capsys.readouterr().err


def test_a_bad_value_given_with_set_is_named_as_such(tmp_path, capsys):
    # a 400-digit integer said "int too large to convert to float" at the block's line; an
    # infinite value reached through $k named only the block's line
    d = write(tmp_path, "params: {k: 1.0}\nblocks:\n  c: {type: constant, value: $k}\n"
                        "simulation: {t_end: 0.01}\nlog: [c.y]\n")
    code, err = run(capsys, "check", str(d), "--set", "k=" + "9" * 400)
    assert code == 2 and "--set k" in err and "(400 digits) is beyond the largest float64" in err, err
    code, err = run(capsys, "check", str(d), "--set", "k=1e400")
    assert code == 2 and ":3: block 'c'" in err and "(the value of $k, from --set k)" in err, err
    (tmp_path / "big.yaml").write_text("blocks:\n  c: {type: constant, value: " + "9" * 5000 + "}\n")
    code, err = run(capsys, "check", str(tmp_path / "big.yaml"))
    assert code == 2 and "big.yaml:2" in err and "(5000 digits)" in err, err


def test_check_builds_the_extremes_of_the_analysis_sweeps(tmp_path, capsys):
    # analysis rates of 1e300 Hz passed check and failed only in analyze; a gain scaled past
    # what the block takes too
    base = ("params: {rate: 100}\nblocks:\n  c: {type: constant, value: 1.0}\n  z: {type: zoh, rate: $rate}\n"
            "  i: {type: integrator}\n  p: {type: pulse, period: 0.1, duty: 0.4}\n"
            "wires: [c.y -> z.u, z.y -> i.u]\nsimulation: {t_end: 0.1}\nlog: [i.y]\n")
    d = write(tmp_path, base + "analysis:\n  rates: [50, 1e300]\n")
    code, err = run(capsys, "check", str(d))
    assert code == 2 and "d.yaml:11: analysis rates ({'rate': 1e+300})" in err and "sample hits" in err, err
    d = write(tmp_path, base + "analysis:\n  gains: {duty: p.duty}\n  scales: [0.5, 4.0]\n")
    code, err = run(capsys, "check", str(d))
    assert code == 2 and "analysis scales duty" in err and "duty" in err, err
    d = write(tmp_path, base + "analysis:\n  rates: [50, 200]\n  gains: {duty: p.duty}\n  scales: [0.5, 2.0]\n")
    assert run(capsys, "check", str(d))[0] == 0


def test_a_bad_swept_value_is_named_as_the_sweeps_not_as_set(tmp_path, capsys):
    # the sweep's values reach the diagram as overrides: their messages said "--set c.value"
    d = write(tmp_path, "params: {k: 1.0}\nblocks:\n  c: {type: constant, value: $k}\n"
                        "simulation: {t_end: 0.01}\nlog: [c.y]\n")
    for key, where in (("k", "(the value of $k, from the sweep's k)"), ("c.value", "the sweep's c.value: block 'c'")):
        s = tmp_path / f"s_{key}.yaml"
        s.write_text(f"diagram: {d}\ngrid: {{{key}: [1.0, .inf]}}\n")
        code, err = run(capsys, "check", str(s))
        assert code == 2 and where in err and "--set" not in err, err


def test_an_analysis_line_from_an_extended_file_names_that_file(tmp_path, capsys):
    from hybridsim.app.cli import main

    base = tmp_path / "base.yaml"
    base.write_text("blocks:\n  c: {type: constant, value: 1.0}\n  g: {type: gain, K: 2.0}\nwires: [c.y -> g.u]\n"
                    "simulation: {t_end: 0.01}\nanalysis:\n  gains: {k: g.K}\n")
    child = tmp_path / "child.yaml"
    child.write_text("extends: base.yaml\nblocks:\n  g: {type: saturation}\n")  # g has no K now
    assert main(["check", str(child)]) == 2
    err = capsys.readouterr().err
    assert f"{base}:7: analysis gain 'k' 'g.K'" in err, err


def test_a_value_set_in_a_child_file_is_named_where_a_parent_block_uses_it(tmp_path, capsys):
    from hybridsim.app.cli import main

    (tmp_path / "base.yaml").write_text("params: {k: 1.0}\nblocks:\n  c: {type: constant, value: $k}\n"
                                        "simulation: {t_end: 0.01}\n")
    child = tmp_path / "child.yaml"
    child.write_text("extends: base.yaml\nparams:\n  k: null\n")
    assert main(["check", str(child)]) == 2
    err = capsys.readouterr().err
    assert "base.yaml:3: block 'c' (constant): parameter 'value'" in err and f"(the value of $k, from {child}:3)" in err, err


def test_analysis_step_and_compare_errors_point_at_their_own_lines(tmp_path, capsys):
    from hybridsim.app.cli import main

    base = ("blocks:\n  c: {type: constant, value: 1.0}\n  g: {type: gain, K: 2.0}\nwires: [c.y -> g.u]\n"
            "simulation: {t_end: 0.01}\nanalysis:\n  step:\n    input: c.y[0]\n    output: OUT\n    set: SET\n"
            "  compare:\n    soft: {g.K: 1.0}\n    hard: HARD\n")
    p = tmp_path / "a.yaml"
    for text, where in [(base.replace("OUT", "g.y[0]").replace("SET", "{c.nosuch: 1}").replace("HARD", "{g.K: 3.0}"), 10),
                        (base.replace("OUT", "g.yy[0]").replace("SET", "{}").replace("HARD", "{g.K: 3.0}"), 9),
                        (base.replace("OUT", "g.y[0]").replace("SET", "{}").replace("HARD", "{g.Kx: 3.0}"), 13)]:
        p.write_text(text)
        assert main(["check", str(p)]) == 2
        err = capsys.readouterr().err
        assert f"{p}:{where}: " in err, (where, err)


def test_setting_one_element_keeps_the_others_references(tmp_path):
    """K: [$Kv, 5.0] with kg.K[1] set: K[0] stays $Kv, so a variant of Kv still reaches it (the whole
    list was resolved and the variant silently ran at the file's Kv)."""
    p = tmp_path / "d.yaml"
    p.write_text("name: d\nparams: {Kv: 10.0}\nvariants: {Kv: [10.0, 30.0]}\nblocks:\n  c: {type: constant, "
                 "value: [1.0, 1.0]}\n  kg: {type: gain, K: [$Kv, 5.0]}\nwires: [c.y -> kg.u]\nlog: [kg.y]\n"
                 "simulation: {t_end: 0.01}\n")
    f = api.load(p, **{"kg.K[1]": 7.0})
    assert f.data["blocks"]["kg"]["K"] == ["$Kv", 7.0]
    assert [api.simulate(f, variant=v)["kg.y"][0].tolist() for _, v in f.variants()] == [[10.0, 7.0], [30.0, 7.0]]


def test_an_empty_setting_is_refused_unless_it_undoes_a_base_value(tmp_path, capsys):
    # 't_end:' and --set t_end=null ran to the table's 1 s where the diagram said 3 s, exit 0
    from hybridsim.app.cli import main
    import hybridsim as hs

    base = tmp_path / "base.yaml"
    base.write_text("blocks:\n  c: {type: constant, value: 1.0}\nlog: [c.y]\nsimulation: {t_end: 0.02, step: 0.001}\n")
    assert main(["check", str(base), "--set", "simulation.t_end=null"]) == 2
    assert "simulation setting 't_end' is empty (null): give a positive" in capsys.readouterr().err
    with pytest.raises(hs.InputError, match="'solver' is empty"):
        hs.simulate(base, solver=None)
    own = tmp_path / "own.yaml"
    own.write_text("blocks:\n  c: {type: constant, value: 1.0}\nmetrics: {}\nsimulation:\n  step:\n")
    assert main(["check", str(own)]) == 2
    assert f"{own}:5: simulation setting 'step' is empty (null)" in capsys.readouterr().err
    child = tmp_path / "child.yaml"
    child.write_text("extends: base.yaml\nsimulation: {step: null}\n")  # the base's 1 ms undone: 0.1 ms
    assert hs.simulate(child).meta["solver"] == "RK4(step=0.0001)"


def test_a_users_override_that_makes_an_analysis_case_idle_is_a_warning(tmp_path, capsys, caplog):
    # check and analyze refused '--set g.K=3' (which run takes) because the compare case sets $k, whose
    # only use that override replaces: "changes nothing ... give one of them", as though the user gave both
    from hybridsim.app.cli import main

    p = tmp_path / "a.yaml"
    p.write_text("params: {k: 2.0}\nblocks:\n  c: {type: constant, value: 1.0}\n  g: {type: gain, K: $k}\n"
                 "wires: [c.y -> g.u]\nsimulation: {t_end: 0.01}\nanalysis:\n  compare:\n    soft: {k: 1.0}\n")
    assert main(["check", str(p), "--set", "g.K=3"]) == 0
    assert "analysis compare soft: 'k' changes nothing here" in caplog.text
    assert main(["check", str(p), "--set", "k=3", "--set", "g.K=3"]) == 2  # both given by the user
    assert "changes nothing: every value that uses $k is set too" in capsys.readouterr().err


def test_an_empty_section_of_a_file_that_extends_another_is_refused(tmp_path):
    # 'simulation:' with its keys commented out ran 1 s where the base said 3 s; 'wires:' dropped every wire
    import hybridsim as hs

    (tmp_path / "base.yaml").write_text("params: {k: 1.0}\nblocks:\n  c: {type: constant, value: $k}\n  i: {type: integrator}\n"
                                        "wires: [c.y -> i.u]\nlog: [i.y]\nsimulation: {t_end: 0.03}\n")
    child = tmp_path / "child.yaml"
    for section, empty in (("simulation", "{}"), ("wires", "[]"), ("log", "[]"), ("params", "{}")):
        child.write_text(f"extends: base.yaml\n{section}:\n  # commented out\n")
        with pytest.raises(hs.LoaderError, match=f"child.yaml:2: section '{section}' is empty \\(null\\), which "
                                                 f"would drop that section of base.yaml: .* {section}: "
                                                 f"{re.escape(empty)} to add nothing"):
            hs.simulate(child)
    child.write_text("extends: base.yaml\nsimulation: {}\n")
    assert hs.simulate(child).t[-1] == pytest.approx(0.03)
