"""Subsystems: a diagram file used as a block, nested, flattened, addressed as sub.block.param."""
import numpy as np
import pytest

import hybridsim as hs
from hybridsim.app.cli import main

INNER = """params: {gain: 2.0}
blocks:
  g: {type: gain, K: $gain}
  s: {type: sum, signs: "+-"}
inputs: {a: [s.u1], b: s.u2}
outputs: {y: g.y}
wires: [s.y -> g.u]
"""
MIDDLE = """params: {k: 3.0}
blocks:
  in1: {type: subsystem, file: inner.yaml, gain: $k}
  in2: {type: subsystem, file: inner.yaml}
  lag: {type: transfer_function, num: [1.0], den: [0.1, 1.0]}
inputs: {u: [in1.a, in2.a], v: [in1.b, in2.b]}
outputs: {p: in1.y, q: lag.y}
wires: [in2.y -> lag.u]
"""
OUTER = """params: {k: 10.0}
blocks:
  c1: {type: cosine, amplitude: 5.0, frequency: 2.0}
  c2: {type: constant, value: 1.0}
  m: {type: subsystem, file: sub/middle.yaml, k: $k, in2.g.K: 7.0}
  hold: {type: zoh, rate: 50}
  integ: {type: integrator}
wires: [c1.y -> m.u, c2.y -> m.v, m.p -> hold.u, hold.y -> integ.u]
simulation: {t_end: 0.5, step: 1.0e-3, log_period: 0.01}
log: [m.p, m.q, integ.y]
"""


@pytest.fixture
def nested(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "inner.yaml").write_text(INNER)
    (tmp_path / "sub" / "middle.yaml").write_text(MIDDLE)
    (tmp_path / "outer.yaml").write_text(OUTER)
    return tmp_path / "outer.yaml"


def test_a_subsystem_two_levels_deep_is_flattened_with_dotted_names(nested):
    system = hs.build(nested)[0]
    names = {b.name for b in system.blocks}
    assert {"m.in1.g", "m.in1.s", "m.in2.g", "m.in2.s", "m.lag"} <= names
    res = hs.simulate(nested)
    t = res.t
    u = 5.0 * np.cos(2 * np.pi * 2.0 * t)
    # m.p = k (u - 1) with k = 10 from the outer file through the middle one; its outputs are named
    # by the inner ports they are
    assert np.allclose(res["m.in1.g.y[0]"], 10.0 * (u - 1.0), atol=1e-12)
    assert res["m.lag.y[0]"][-1] != 0.0


def test_a_result_answers_to_a_subsystems_port_names(nested):
    res = hs.simulate(nested)
    assert "m.p" in res and np.array_equal(res["m.p"], res["m.in1.g.y"])  # the file logs m.p
    assert np.array_equal(res["m.q[0]"], res["m.lag.y[0]"])
    with pytest.raises(KeyError, match="did you mean 'm.p'"):
        res["m.pp"]
    # a log given to the API names the ports as the file may
    res = hs.simulate(nested, log=["m.p", "integ.y"])
    assert list(res.signals) == ["m.in1.g.y", "integ.y"] and res["m.p"].shape == (res.t.size, 1)


@pytest.mark.slow
def test_a_nested_subsystem_runs_identically_on_every_path(nested):
    generic = hs.simulate(nested, fused=False)
    fused = hs.simulate(nested)
    compiled = hs.simulate(nested, compiled=True)
    assert np.array_equal(generic.table(), fused.table())
    assert np.array_equal(generic.table(), compiled.table())


def test_inner_parameters_are_set_by_path(nested):
    base = hs.simulate(nested)
    res = hs.simulate(nested, **{"m.in2.g.K": 1.0})  # --set m.in2.g.K=1 (7 in the file)
    assert not np.array_equal(res["m.lag.y[0]"], base["m.lag.y[0]"])
    # the same value as a run-time parameter of the built system, no rebuild
    f = hs.load(nested)
    system, sim, _ = hs.build(f)
    again = sim.run(0.5, params=f.runtime_params({"m.in2.g.K": 1.0}))
    assert np.array_equal(again["m.lag.y[0]"], res["m.lag.y[0]"])
    with pytest.raises(hs.LoaderError, match="used by subsystem 'm'"):
        f.runtime_params({"k": 3.0})  # a name the subsystem takes: rebuild instead


def test_check_names_the_path_with_file_and_line_at_each_level(nested, capsys):
    mid = nested.parent / "sub" / "middle.yaml"
    mid.write_text(MIDDLE.replace("in2.a]", "in2.x]"))
    assert main(["check", str(nested)]) == 2
    err = capsys.readouterr().err
    assert "in subsystem m (" in err and "outer.yaml:5)" in err
    assert "middle.yaml:6: subsystem 'in2' (" in err and "has no input 'x'; its inputs: a, b" in err


def test_an_algebraic_loop_through_a_subsystem_names_each_wire(tmp_path, capsys):
    (tmp_path / "inner.yaml").write_text(INNER)
    (tmp_path / "alg.yaml").write_text("blocks:\n  c: {type: constant, value: 1.0}\n"
                                       "  m: {type: subsystem, file: inner.yaml}\n"
                                       "wires: [c.y -> m.a, m.y -> m.b]\n")
    assert main(["check", str(tmp_path / "alg.yaml")]) == 2
    err = capsys.readouterr().err
    assert "algebraic loop: m.s.y -> m.g.y -> m.s.y" in err
    assert "m.s.y -> m.g.u (in subsystem m (" in err and "inner.yaml:7)" in err
    assert "m.g.y -> m.s.u2 (" in err and "alg.yaml:4)" in err


@pytest.mark.parametrize("spec, message", [
    ("{type: subsystem, file: inner.yaml, gian: 3}", "has no parameter 'gian' (did you mean 'gain'?)"),
    ("{type: subsystem, file: inner.yaml, q.K: 3}", "has no block 'q'"),
    ("{type: subsystem}", "needs 'file'"),
    ("{type: subsystem, file: nope.yaml}", "no such file"),
    ("{type: subsystem, file: self.yaml}", "contains itself"),
    # a declared input given as a parameter got no hint
    ("{type: subsystem, file: inner.yaml, a: c.y}",
     "('a' is an input port: connect it in the 'wires:' section, '- c.y -> m.a')"),
    ("{type: subsystem, file: inner.yaml, input: c.y}",
     "(signals are connected in the 'wires:' section, '- c.y -> m.a'; its inputs: a, b)"),
])
def test_bad_subsystems_are_clear_errors(tmp_path, capsys, spec, message):
    (tmp_path / "inner.yaml").write_text(INNER)
    (tmp_path / "self.yaml").write_text(f"blocks:\n  m: {spec}\n")
    assert main(["check", str(tmp_path / "self.yaml")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("ports, message", [
    ("outputs: {y: nope.y}", "output 'y': no block 'nope'"),
    ("outputs: {y: g.u}", "output 'y': block 'g' (gain) has no output 'u'; its outputs: y"),
    ("inputs: {a: [s.u1, g.x], b: s.u2}", "input 'a': block 'g' (gain) has no input 'x'; its inputs: u"),
    ('outputs: {y: "g.y[0]"}', "output 'y': 'g.y[0]' is one element; a subsystem's port is a whole port"),
])
def test_a_subsystem_files_declared_ports_are_checked_where_they_are_declared(tmp_path, capsys, ports, message):
    # an output naming no block passed check and ran (exit 0) while nothing wired it; wired, the error
    # named the outer wire, never the subsystem file's line
    key = ports.split(":")[0]
    lines = [line for line in INNER.splitlines() if not line.startswith(key)] + [ports]
    (tmp_path / "inner.yaml").write_text("\n".join(lines) + "\n")
    (tmp_path / "d.yaml").write_text("blocks:\n  c: {type: constant, value: 1.0}\n"
                                     "  m: {type: subsystem, file: inner.yaml}\n  h: {type: gain}\n"
                                     "wires: [c.y -> m.a, c.y -> m.b, m.y -> h.u]\n")
    assert main(["check", str(tmp_path / "d.yaml")]) == 2
    err = capsys.readouterr().err
    assert f"inner.yaml:{len(lines)}: {message}" in err and "in subsystem m (" in err, err
    assert "1 problem(s)" in err, err  # not also the wire to it, nor the input that wire left unwired


def test_a_section_a_subsystem_file_never_reads_is_refused_or_noted(tmp_path, capsys, caplog):
    # a subsystem with inputs never runs on its own: its 'simulation: {t_end: -5}' passed check, ignored.
    # That section is the solver of an FMU exported from it: checked where it is used, then noted
    (tmp_path / "inner.yaml").write_text(INNER + "simulation: {t_end: -5}\n")
    (tmp_path / "d.yaml").write_text("blocks:\n  c: {type: constant, value: 1.0}\n"
                                     "  m: {type: subsystem, file: inner.yaml}\nwires: [c.y -> m.a, c.y -> m.b]\n")
    assert main(["check", str(tmp_path / "d.yaml")]) == 2
    err = capsys.readouterr().err
    assert "inner.yaml:8: simulation setting 't_end' must be" in err, err
    (tmp_path / "inner.yaml").write_text(INNER + "simulation: {solver: heun, step: 1.0e-3}\n")
    with caplog.at_level("WARNING", logger="hybridsim"):
        assert main(["check", str(tmp_path / "d.yaml")]) == 0
    assert "inner.yaml: 'simulation' ignored where it is used as a subsystem" in caplog.text
    (tmp_path / "inner.yaml").write_text(INNER + "metrics: {}\n")
    assert main(["check", str(tmp_path / "d.yaml")]) == 2
    assert "section 'metrics' has no effect in a subsystem file that declares inputs" in capsys.readouterr().err
    # one without inputs may run on its own: there a note, and it runs
    (tmp_path / "plant.yaml").write_text("blocks:\n  c: {type: constant, value: 2.0}\noutputs: {y: c.y}\n"
                                         "simulation: {t_end: 0.5}\n")
    (tmp_path / "e.yaml").write_text("blocks:\n  p: {type: subsystem, file: plant.yaml}\n  g: {type: gain}\n"
                                     "wires: [p.y -> g.u]\n")
    with caplog.at_level("WARNING", logger="hybridsim"):
        assert main(["check", str(tmp_path / "e.yaml")]) == 0
    assert "plant.yaml: 'simulation' ignored where it is used as a subsystem" in caplog.text


@pytest.mark.parametrize("name", ["a.b", "''"])
def test_a_dot_in_a_block_name_or_an_empty_one_is_refused(tmp_path, capsys, name):
    # '' was taken: "input .u (1 wide) is not connected", with no file or line
    (tmp_path / "d.yaml").write_text(f"blocks:\n  {name}: {{type: gain}}\n")
    assert main(["check", str(tmp_path / "d.yaml")]) == 2
    err = capsys.readouterr().err
    assert "d.yaml:2: block name" in err and "may not be empty or contain '.'" in err, err


def test_draw_shows_a_subsystem_as_one_box_or_expanded(nested, tmp_path):
    from hybridsim.report.picture import draw_diagram

    system = hs.build(nested)[0]
    boxes = lambda fig: {t.get_text() for t in fig.axes[0].texts}  # noqa: E731
    closed = boxes(draw_diagram(system))
    assert "m" in closed and "subsystem (5 blocks)" in closed and "m.in1.g" not in closed
    opened = boxes(draw_diagram(system, expand=True))
    assert {"m.in1.g", "m.in2.s", "m.lag"} <= opened and "integ:reset=default" not in opened
    assert main(["draw", str(nested), "--expand", "-o", str(tmp_path / "d.png")]) == 0
    assert (tmp_path / "d.png").stat().st_size > 1000


def test_a_broken_subsystem_is_one_problem_not_also_its_wires(tmp_path, capsys):
    """Its outer wires are left out; the inputs they would have fed are not reported unconnected."""
    (tmp_path / "inner.yaml").write_text(INNER)
    (tmp_path / "d.yaml").write_text("blocks:\n  c: {type: constant, value: 1.0}\n"
                                     "  m: {type: subsystem, file: inner.yaml, gian: 3}\n"
                                     "  g: {type: gain}\n"
                                     "wires: [c.y -> m.a, c.y -> m.b, m.y -> g.u]\n")
    assert main(["check", str(tmp_path / "d.yaml")]) == 2
    err = capsys.readouterr().err
    assert "diagram has 1 problem(s)" in err and "has no parameter 'gian'" in err
    assert "g.u" not in err


def test_a_wire_to_a_broken_block_still_has_its_other_end_checked(tmp_path, capsys):
    # a wire with a broken block at one end was skipped whole: a wrong port or block name at the other
    # end showed only once the block was mended (inside a subsystem file and in a diagram alike)
    (tmp_path / "inner.yaml").write_text("blocks:\n  g: {type: gain, K: [1, 2], width: 3}\n  k: {type: integrator}\n"
                                         "wires: [g.y -> nosuch.u, k.y -> g.u]\ninputs: {e: k.u}\noutputs: {u: k.y}\n")
    (tmp_path / "d.yaml").write_text("blocks:\n  src: {type: step}\n  m: {type: subsystem, file: inner.yaml}\n"
                                     "  bad: {type: gain, K: x}\nwires: [src.y -> m.e, src.yy -> bad.u]\n")
    assert main(["check", str(tmp_path / "d.yaml")]) == 2
    err = capsys.readouterr().err
    assert "diagram has 4 problem(s)" in err, err
    assert "inner.yaml:4): no block named 'm.nosuch'" in err and "d.yaml:5): block 'src' (step) has no output 'yy'" in err


def test_a_bad_inner_value_is_one_problem_that_names_the_users_set(tmp_path, capsys):
    (tmp_path / "inner.yaml").write_text(INNER)
    (tmp_path / "d.yaml").write_text("blocks:\n  c: {type: constant, value: 1.0}\n"
                                     "  m: {type: subsystem, file: inner.yaml}\n  g: {type: gain}\n"
                                     "wires: [c.y -> m.a, c.y -> m.b, m.y -> g.u]\n")
    assert main(["check", str(tmp_path / "d.yaml"), "--set", "m.g.K=[[1, 2], [3]]"]) == 2
    err = capsys.readouterr().err
    assert "diagram has 1 problem(s)" in err and "--set m.g.K: block 'g' (gain): parameter 'K'" in err


def test_check_of_a_subsystem_file_builds_it_as_a_diagram_using_it_would(nested, capsys):
    # it exited 2, "its inputs are not wired": a subsystem could not be checked before its use
    mid = nested.parent / "sub" / "middle.yaml"
    mid.write_text(MIDDLE + "simulation: {solver: rk4, step: 1.0e-3}\n")
    assert main(["check", str(mid)]) == 0
    out = capsys.readouterr().out
    assert "a subsystem of" in out and "inputs u (1), v (1), outputs p (1), q (1)" in out
    from hybridsim.checking import check_file

    info = check_file(mid, k=4.0)
    assert info["kind"] == "subsystem" and info["states"] == 1 and info["outputs"] == [("p", 1), ("q", 1)]
    # its errors at its own lines, overrides named as given, nothing of the staged copies shown
    assert main(["check", str(mid), "--set", "lag.nope=1"]) == 2
    err = capsys.readouterr().err
    assert "--set lag.nope: block 'lag'" in err and "hybridsim-check" not in err
    mid.write_text(MIDDLE.replace("in2.x]", "") + "simulation: {solver: rk4, step: -1.0}\n")
    assert main(["check", str(mid)]) == 2
    assert f"{mid}:9: simulation setting 'step' must be a positive" in capsys.readouterr().err
    (nested.parent / "sub" / "inner.yaml").write_text(INNER.replace("K: $gain", "K: $gain, nope: 1"))
    mid.write_text(MIDDLE)
    assert main(["check", str(mid)]) == 2
    err = capsys.readouterr().err
    assert "inner.yaml:3: block 'g' (gain) has no parameter 'nope'" in err and "hybridsim-check" not in err


def test_a_subsystem_files_parameter_no_value_uses_is_named_at_check(tmp_path, caplog):
    # its parent's block may set it: that changes nothing, silently
    p = tmp_path / "sub.yaml"
    p.write_text("params: {k: 2, spare: 3}\ninputs: {u: g.u}\noutputs: {y: g.y}\nblocks:\n  g: {type: gain, K: $k}\n")
    with caplog.at_level("WARNING", logger="hybridsim"):
        assert hs.check_file(p)["unused_params"] == ["spare"]
    assert "parameter 'spare' is used by no value of the file" in caplog.text
