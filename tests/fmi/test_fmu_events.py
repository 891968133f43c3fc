"""Model Exchange FMUs through the event protocol: state events with resets and time events.

The FMU (tests/data/ball and ball3, C, FMI 2.0 and 3.0 ME) is a ball bouncing with restitution 0.7 and a stair
counter stepping up at t = 1, 2, ... s; built during the tests. Oracles: the closed-form bounce
times and fmpy.simulate_fmu (which implements the event protocol) at tight tolerance.
"""
import math

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.errors import FMUError
from hybridsim.fmi.fmu_block import FMUBlock, build_fmu, find_compiler

from conftest import ROOT

G, E = 9.81, 0.7
T1 = math.sqrt(2 / G)
BOUNCES = [T1 + sum(2 * E ** k * T1 for k in range(1, m + 1)) for m in range(6)]


@pytest.fixture(scope="module", params=["ball", "ball3"], ids=["fmi2", "fmi3"])
def ball_fmu(request, tmp_path_factory):
    """The same ball as an FMI 2.0 and as an FMI 3.0 Model Exchange FMU."""
    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    name = request.param
    d = ROOT / "tests" / "data" / name
    sources = sorted(d.glob("*.c"))
    return build_fmu(tmp_path_factory.mktemp(name) / f"{name}.fmu", name, sources,
                     (d / "modelDescription.xml").read_text(), {})


def run(fmu, solver, t_end=2.4, log_period=1e-3):
    d = hs.Diagram("ball")
    d.add(FMUBlock("ball", path=str(fmu), mode="me"))
    return hs.Simulator(d.build(), solver, log=["ball.height", "ball.count"], log_period=log_period).run(t_end)


def state_events(res):
    """Times of the events that were not time events (leaving the floor after a bounce is a
    second, empty event within a microsecond: counted once)."""
    out = []
    for t, _ in res.meta["events"]:
        if abs(t - round(t)) > 1e-9 and (not out or t - out[-1] > 1e-6):
            out.append(t)
    return out


SOLVERS = {"rk4": lambda: hs.RK4(1e-3), "radau": lambda: hs.ScipySolver("Radau", rtol=1e-10, atol=1e-12),
           "rk45": lambda: hs.ScipySolver("RK45", rtol=1e-10, atol=1e-12)}


@pytest.mark.parametrize("name", list(SOLVERS))
def test_me_fmu_bounces_at_the_closed_form_times(ball_fmu, name):
    res = run(ball_fmu, SOLVERS[name]())
    assert np.max(np.abs(np.array(state_events(res)[:6]) - BOUNCES)) < 1e-9
    assert res["ball.height"].min() > -1e-9  # it never falls through the floor (it did: h(3 s) = -43 m)


@pytest.mark.parametrize("name", list(SOLVERS))
def test_me_fmu_time_events_step_the_stairs(ball_fmu, name):
    res = run(ball_fmu, SOLVERS[name](), log_period=0.01)
    count = dict(zip(np.round(res.t, 6), res["ball.count[0]"]))
    assert (count[0.99], count[1.0], count[1.99], count[2.0], count[2.39]) == (0, 1, 1, 2, 2)
    assert [t for t, _ in res.meta["events"] if abs(t - round(t)) <= 1e-12] == [1.0, 2.0]


def test_me_fmu_matches_fmpy(ball_fmu):
    import fmpy

    ref = fmpy.simulate_fmu(str(ball_fmu), stop_time=2.4, output=["height", "count"], output_interval=1e-3,
                            relative_tolerance=1e-10)
    t, keep = np.unique(ref["time"], return_index=True)  # fmpy adds a row before and after each event
    res = run(ball_fmu, SOLVERS["radau"]())
    ours = dict(zip(np.round(res.t, 9), res["ball.height[0]"]))
    common = [(ours[round(tt, 9)], h) for tt, h in zip(t, ref["height"][keep]) if round(tt, 9) in ours]
    assert len(common) > 2000
    a, b = np.array(common).T
    assert np.max(np.abs(a - b)) < 1e-6


def test_a_zeno_fmu_is_stopped_with_a_clear_message(ball_fmu):
    with pytest.raises(hs.SimulationError, match=r"events accumulate at t=2\.558.*ball.*Zeno"):
        run(ball_fmu, SOLVERS["rk4"](), t_end=3.0)


def test_terminate_simulation_ends_the_run_cleanly_with_the_results_so_far(ball_fmu, tmp_path, capsys):
    from hybridsim.app.cli import main

    d = hs.Diagram("ball")
    d.add(FMUBlock("ball", path=str(ball_fmu), mode="me", parameters={"t_stop": 1.5}))
    res = hs.Simulator(d.build(), hs.RK4(1e-3), log=["ball.height"], log_period=0.01).run(2.4)
    assert res.meta["stopped"] == {"t": 1.5, "block": "ball", "reason": "terminateSimulation"}
    assert res.meta["t_end"] == 1.5 and res.t[-1] < 1.5 and res.t[-1] == pytest.approx(1.49)
    assert state_events(res)[:2] == pytest.approx(BOUNCES[:2], abs=1e-9)  # the third would be at 1.526 s
    assert res.meta["events"][-1][0] == 1.5
    diagram = tmp_path / "b.yaml"
    diagram.write_text(f"blocks:\n  ball: {{type: fmu, path: {ball_fmu}, mode: me, parameters: {{t_stop: 1.5}}}}\n"
                       "simulation: {t_end: 2.4, step: 1.0e-3}\nlog: [ball.height]\n")
    code = main(["run", str(diagram), "-q", "-o", str(tmp_path / "o")])
    out = capsys.readouterr().out
    assert code == 0 and "ended the run at t=1.5 s (terminateSimulation)" in out
    assert (tmp_path / "o" / "b.csv").read_text().count("\n") == 3001  # header + rows 0 .. 1.4995 s


def test_integer_and_boolean_ports_cross_as_numbers(ball_fmu):
    """The balls' Integer/Boolean inputs are discrete-time: they accept values in event mode
    only (the FMU returns an error otherwise), so this also checks that they are set there."""
    from hybridsim.fmi.fmu_block import to_fmi

    d = hs.Diagram("ball")
    d.add(FMUBlock("ball", path=str(ball_fmu), mode="me"))
    d.add(hs.registry.lookup("constant")("k", value=41.6))
    d.add(hs.registry.lookup("constant")("f", value=1.0))
    d.connect("k.y", "ball.k_in")
    d.connect("f.y", "ball.flag_in")
    logged = ["ball.bounces", "ball.k_out", "ball.flag_out"] + (["ball.up"] if "ball3" not in str(ball_fmu) else [])
    res = hs.Simulator(d.build(), hs.RK4(1e-3), log=logged, log_period=0.01).run(2.4)
    assert res["ball.k_out[0]"][-1] == 43.0  # 41.6 rounds to 42; the FMU adds 1
    assert res["ball.flag_out[0]"][-1] == 0.0  # 1.0 is true; the FMU negates it
    assert res["ball.bounces[0]"][-1] == len(state_events(res))  # an Integer output counting the bounces
    if "ball3" not in str(ball_fmu):  # the FMI 2.0 ball also has a Boolean output of its state
        up = dict(zip(np.round(res.t, 6), res["ball.up[0]"]))
        assert (up[0.3], up[0.6]) == (0.0, 1.0)  # falling, then rising after the first bounce
    assert to_fmi("Int8", 127.4, "x") == 127 and to_fmi("Boolean", -2.0, "x") is True
    with pytest.raises(FMUError, match=r"'x' \(Int8\) got 128.0: outside -128 .. 127"):
        to_fmi("Int8", 128.0, "x")
    with pytest.raises(FMUError, match="not a finite number"):
        to_fmi("UInt16", float("nan"), "x")


def test_a_text_output_is_left_out_and_the_fmu_runs(ball_fmu, tmp_path):
    """A String output is not a port (text cannot cross the diagram); the rest of the FMU runs.
    (It used to refuse the whole FMU.)"""
    import zipfile

    fmi2 = (b'name="count" valueReference="7" causality="output" variability="discrete" initial="exact">'
            b'<Real start="0"/>', b'name="count" valueReference="7" causality="output" variability="discrete" '
            b'initial="exact"><String start="0"/>')
    fmi3 = (b'<Float64 name="count" valueReference="7" causality="output" variability="discrete" initial="exact" '
            b'start="0"/>', b'<String name="count" valueReference="7" causality="output" variability="discrete" '
            b'initial="exact"><Start value="0"/></String>')
    old, new = fmi3 if "ball3" in str(ball_fmu) else fmi2
    bad = tmp_path / "str.fmu"  # the ball with its count output declared String
    with zipfile.ZipFile(ball_fmu) as src, zipfile.ZipFile(bad, "w") as dst:
        for n in src.namelist():
            data = src.read(n)
            if n == "modelDescription.xml":
                assert old in data
                data = data.replace(old, new)
            dst.writestr(n, data)
    blk = FMUBlock("ball", path=str(bad), mode="me")
    assert blk.output_port("count") is None and blk.text_variables == ["count (String output)"]
    d = hs.Diagram("ball")
    d.add(blk)
    res = hs.Simulator(d.build(), hs.RK4(1e-3), log=["ball.height"], log_period=0.01).run(1.0)
    assert abs(state_events(res)[0] - BOUNCES[0]) < 1e-9


def test_state_tolerances_follow_the_nominals(ball_fmu, tmp_path):
    import zipfile

    blk = FMUBlock("ball", path=str(ball_fmu), mode="me")
    assert list(blk.atol) == [1e-12, 1e-12]  # no nominal given: 1
    scaled = tmp_path / "nominal.fmu"
    with zipfile.ZipFile(ball_fmu) as src, zipfile.ZipFile(scaled, "w") as dst:
        for n in src.namelist():
            data = src.read(n)
            if n == "modelDescription.xml":
                data = data.replace(b'<Real start="1"/>', b'<Real start="1" nominal="1000"/>', 1)
                data = data.replace(b'initial="exact" start="1"/>', b'initial="exact" start="1" nominal="1000"/>', 1)
            dst.writestr(n, data)
    assert list(FMUBlock("ball", path=str(scaled), mode="me").atol) == pytest.approx([1e-9, 1e-12])


def test_string_and_binary_parameters_reach_the_fmu(ball_fmu):
    fmi3 = "ball3" in str(ball_fmu)
    params = {"label": "hello"}
    log = ["ball.label_length"]
    if fmi3:  # FMI 3.0 has Binary variables: given as hex digits
        params["blob"] = "0a 0b 0c"
        log.append("ball.blob_sum")
    d = hs.Diagram("ball")
    d.add(FMUBlock("ball", path=str(ball_fmu), mode="me", parameters=params))
    res = hs.Simulator(d.build(), hs.RK4(1e-3), log=log, log_period=0.1).run(0.3)
    assert np.all(res["ball.label_length[0]"] == 5)  # strlen("hello"), computed by the FMU
    if fmi3:
        assert np.all(res["ball.blob_sum[0]"] == 10 + 11 + 12)
    d = hs.Diagram("ball")  # the defaults: "ab" and bytes 01 02
    d.add(FMUBlock("ball", path=str(ball_fmu), mode="me"))
    assert hs.Simulator(d.build(), hs.RK4(1e-3), log=log, log_period=0.1).run(0.1)["ball.label_length[0]"][0] == 2


@pytest.mark.parametrize("params, message", [
    ({"label": 3.0}, "label is a String: give text, got 3.0"),
    ({"blob": "xyz"}, "blob is Binary: give its bytes as hex digits"),
    ({"e": "high"}, "e: must be a finite number"),
])
def test_bad_text_parameters_are_parameter_errors(ball_fmu, params, message):
    if "blob" in params and "ball3" not in str(ball_fmu):
        pytest.skip("FMI 2.0 has no Binary variables")
    with pytest.raises(hs.ParameterError, match=message):
        FMUBlock("ball", path=str(ball_fmu), mode="me", parameters=params)


# -- FMUs without continuous states (tests/data/stair3: time events, feedthrough, a resource file) --

@pytest.fixture(scope="module")
def stair(tmp_path_factory):
    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    d = ROOT / "tests" / "data" / "stair3"
    return build_fmu(tmp_path_factory.mktemp("stair3") / "stair3.fmu", "stair3", sorted(d.glob("*.c")),
                     (d / "modelDescription.xml").read_text(), {},
                     extra_files={"resources/gain.txt": (d / "resources" / "gain.txt").read_text()})


def stair_run(fmu, mode, t_end, u=None, **kw):
    d = hs.Diagram("stair")
    extra = {"rate": 5} if mode == "cs" else {}
    d.add(FMUBlock("s", path=str(fmu), mode=mode, **extra, **kw))
    if u is not None:
        d.add(hs.registry.lookup("cosine")("src", amplitude=u, frequency=0.5))
        d.connect("src.y", "s.u")
    return hs.Simulator(d.build(), hs.RK4(1e-3), log=["s.counter", "s.y"], log_period=0.2).run(t_end)


@pytest.mark.parametrize("mode", ["me", "cs"])
def test_a_stair_counter_without_states_matches_fmpy(stair, mode):
    import fmpy

    ref = fmpy.simulate_fmu(str(stair), stop_time=4.4, output_interval=0.2, output=["counter"],
                            fmi_type="ModelExchange" if mode == "me" else "CoSimulation")
    res = stair_run(stair, mode, 4.4)
    t, keep = np.unique(np.round(ref["time"], 9), return_index=True)  # fmpy's ME rows around each event
    if mode == "me":  # fmpy's row at an event is the value after it: compare at the grid times
        after = {round(tt, 9): c for tt, c in zip(ref["time"], ref["counter"])}
        want = np.array([after[round(tt, 9)] for tt in res.t])
    else:
        want = ref["counter"][keep][:len(res.t)]
    assert np.array_equal(res["s.counter[0]"], want)
    assert list(res["s.counter[0]"][[0, 4, 5, 10, 20]]) == [1, 1, 2, 3, 5]  # t = 0, 0.8, 1.0, 2.0, 4.0


@pytest.mark.parametrize("mode", ["me", "cs"])
def test_a_feedthrough_fmu_reads_its_gain_from_a_resource_file(stair, mode):
    import fmpy

    res = stair_run(stair, mode, 2.0, u=1.0)
    n = len(res.t) - (mode == "cs")  # a CS output at t_end is the last hit's, held
    u = np.cos(2 * np.pi * 0.5 * res.t[:n])
    assert np.max(np.abs(res["s.y[0]"][:n] - 2.5 * u)) < 1e-12  # gain.txt says 2.5; y = gain u, the same instant
    ref = fmpy.simulate_fmu(str(stair), stop_time=2.0, output_interval=0.2, output=["y"],
                            input=np.array([(tt, np.cos(np.pi * tt)) for tt in res.t],
                                           dtype=[("time", float), ("u", float)]),
                            fmi_type="ModelExchange" if mode == "me" else "CoSimulation")
    t, keep = np.unique(np.round(ref["time"], 9), return_index=True)
    got = ref["y"][keep]
    if mode == "cs":  # fmpy samples a CS output before it sets the next input: one step behind
        assert got[0] == 2.5 and np.max(np.abs(got[1:n] - res["s.y[0]"][:n - 1])) < 1e-12
    else:
        assert np.max(np.abs(got[:n] - res["s.y[0]"][:n])) < 1e-9


def test_a_missing_resource_is_named_by_the_fmu_itself(stair, tmp_path):
    import zipfile

    bare = tmp_path / "noresource.fmu"
    with zipfile.ZipFile(stair) as src, zipfile.ZipFile(bare, "w") as dst:
        for n in src.namelist():
            if not n.startswith("resources/"):
                dst.writestr(n, src.read(n))
    with pytest.raises(FMUError, match="fmi3Instantiate failed.*cannot open the resource file gain.txt"):
        stair_run(bare, "cs", 1.0)


def test_a_co_simulation_stop_keeps_the_completed_step(stair):
    import fmpy

    res = stair_run(stair, "cs", 20.0, parameters={"limit": 9})
    ref = fmpy.simulate_fmu(str(stair), stop_time=20.0, output_interval=0.2, output=["counter"],
                            fmi_type="CoSimulation", start_values={"limit": 9})
    assert res.t[-1] == pytest.approx(8.0) and ref["time"][-1] == pytest.approx(8.0)  # not 7.8
    assert res["s.counter[0]"][-1] == ref["counter"][-1] == 9
    assert res.meta["stopped"]["t"] == pytest.approx(8.0)


def test_an_unwired_input_is_never_written(stair):
    res = stair_run(stair, "cs", 1.0)  # 'locked' refuses every write: left alone, the run goes through
    assert res.t[-1] == pytest.approx(1.0)


@pytest.mark.parametrize("params, message", [
    ({"limit": 0.5}, r"limit = 0.5 is outside its range: min = 1"),
    ({"time": 1.0}, r"time is the independent variable of the FMU: it cannot be set"),
    ({"y": 1.0}, r"y is an output variable of the FMU \(initial=calculated\): it cannot be set"),
])
def test_check_refuses_what_the_fmu_cannot_take(stair, params, message):
    with pytest.raises(hs.ParameterError, match=message):
        FMUBlock("s", path=str(stair), mode="cs", rate=5, parameters=params)


def test_a_non_finite_or_float32_overflowing_input_names_the_port(stair):
    from hybridsim.fmi.fmu_block import to_fmi

    with pytest.raises(FMUError, match=r"overflows Float32"):
        to_fmi("Float32", 1e39, "p.u")

    class Blowup(hs.Block):  # a source that overflows to inf at t = 0.4 s
        time_varying = True

        def __init__(self, name="src"):
            super().__init__(name)
            self.declare_output("y", 1)

        def output(self, t, x, u):
            return ([1e308 * 10 if t >= 0.4 else 1.0],)

    d = hs.Diagram("stair")
    d.add(FMUBlock("s", path=str(stair), mode="cs", rate=5))
    d.add(Blowup())
    d.connect("src.y", "s.u")
    with np.errstate(over="ignore"), pytest.raises(FMUError, match=r"input 's.u \(u\)' \(Float64\) got inf"):
        hs.Simulator(d.build(), hs.RK4(1e-3), log=["s.y"], log_period=0.2).run(1.0)


# -- FMI 3.0 arrays, String and Binary variables (tests/data/arrays3) ------------------------

@pytest.fixture(scope="module")
def arrays(tmp_path_factory):
    try:
        find_compiler()
    except FMUError:
        pytest.skip("no C compiler")
    d = ROOT / "tests" / "data" / "arrays3"
    return build_fmu(tmp_path_factory.mktemp("arrays3") / "arrays3.fmu", "arrays3", sorted(d.glob("*.c")),
                     (d / "modelDescription.xml").read_text(), {})


def arrays_run(fmu, params=None, u=None):
    d = hs.Diagram("arr")
    d.add(FMUBlock("a", path=str(fmu), mode="cs", rate=10, parameters=params or {}))
    if u is not None:
        d.add(hs.registry.lookup("constant")("c", value=u))
        d.connect("c.y", "a.u")
    return hs.Simulator(d.build(), hs.RK4(1e-3), log=["a.y", "a.total"], log_period=0.1).run(0.3)


def test_array_ports_and_parameters_match_fmpy(arrays):
    import fmpy

    blk = FMUBlock("a", path=str(arrays), mode="cs", rate=10)
    assert blk.input_port("u").width == 3 and blk.input_port("u").default == (0.5, 0.5, 0.5)  # start parsed
    assert blk.output_port("y").width == 3
    assert sorted(blk.text_variables) == ["blob (Binary input)", "label (String output)", "name (String input)"]
    for params, u in (({}, None), ({"gains": [2.0, -1.0, 4.0], "offs": [0.1, 0.2, 0.3]}, [1.0, 2.0, 3.0])):
        res = arrays_run(arrays, params, u)
        start = {"gains": params["gains"], "offs[0]": 0.1, "offs[1]": 0.2, "offs[2]": 0.3} if params else {}
        if u is not None:  # a constant input: its start value for fmpy
            start["u"] = u
        ref = fmpy.simulate_fmu(str(arrays), stop_time=0.3, output_interval=0.1, output=["y", "total"],
                                start_values=start)
        assert np.max(np.abs(res["a.y"][:-1] - np.array([list(r) for r in ref["y"]])[:3])) < 1e-12
        assert np.max(np.abs(res["a.total[0]"][:-1] - ref["total"][:3])) < 1e-12
    # 1 2 3 times 0.5, abc (3 characters) and bytes 01 02 at their start values: 3 + 3 + 3
    assert arrays_run(arrays)["a.total[0]"][0] == 9.0


@pytest.mark.parametrize("params, message", [
    ({"gains": [1.0, 2.0]}, r"gains is an array of 3 elements \[3\]: give 3 values"),
    ({"offs": [1.0, 2.0]}, r"offs: the FMU has 3 elements offs\[0\] .. offs\[2\]: give 3 values .*got \[1.0, 2.0\]"),
    ({"offs": 5.0}, r"offs: the FMU has 3 elements .*got 5.0"),  # was "no variable 'offs'", exit 4
])
def test_array_parameters_of_the_wrong_length_are_refused(arrays, params, message):
    with pytest.raises(hs.ParameterError, match=message):
        FMUBlock("a", path=str(arrays), mode="cs", rate=10, parameters=params)


def test_zero_based_element_names_are_set_as_declared(arrays):
    blk = FMUBlock("a", path=str(arrays), mode="cs", rate=10, parameters={"offs": [1.0, 2.0, 3.0]})
    assert blk.parameters == {"offs[0]": 1.0, "offs[1]": 2.0, "offs[2]": 3.0}  # not offs[1] .. offs[3]


def test_text_parameters_reach_an_fmi3_fmu(arrays):
    res = arrays_run(arrays, {"name": "hello!"})
    assert res["a.total[0]"][0] == 3 + 6 + 3  # len("hello!") = 6


def test_check_names_an_out_of_range_parameter_and_exits_2(stair, tmp_path, capsys):
    from hybridsim.app.cli import main

    diagram = tmp_path / "s.yaml"
    diagram.write_text(f"blocks:\n  s: {{type: fmu, path: {stair}, mode: cs, rate: 5, parameters: {{limit: 0.5}}}}\n"
                       "simulation: {t_end: 1}\n")
    code = main(["check", str(diagram)])
    err = capsys.readouterr().err
    assert code == 2 and "limit = 0.5 is outside its range: min = 1" in err and "Traceback" not in err


def test_a_scheduled_execution_only_fmu_is_refused_as_such(stair, tmp_path):
    import re
    import zipfile

    se = tmp_path / "se.fmu"
    with zipfile.ZipFile(stair) as src, zipfile.ZipFile(se, "w") as dst:
        for n in src.namelist():
            data = src.read(n)
            if n == "modelDescription.xml":
                text = re.sub(r'<ModelExchange[^>]*/>\s*<CoSimulation[^>]*/>',
                              '<ScheduledExecution modelIdentifier="stair3"/>', data.decode())
                assert "ScheduledExecution" in text
                data = text.encode()
            dst.writestr(n, data)
    with pytest.raises(FMUError, match="is a Scheduled Execution FMU \\(FMI 3.0\\)"):
        FMUBlock("s", path=str(se), mode="cs", rate=5)


def test_a_clock_port_is_still_refused_naming_it(arrays, tmp_path):
    import zipfile

    clocked = tmp_path / "clock.fmu"
    with zipfile.ZipFile(arrays) as src, zipfile.ZipFile(clocked, "w") as dst:
        for n in src.namelist():
            data = src.read(n)
            if n == "modelDescription.xml":
                data = data.replace(b"  </ModelVariables>", b'    <Clock name="tick" valueReference="11" causality="input" '
                                    b'variability="discrete" intervalVariability="constant" intervalDecimal="0.1"/>\n'
                                    b"  </ModelVariables>")
            dst.writestr(n, data)
    with pytest.raises(FMUError, match=r"cannot be ports.*tick \(Clock, input\)"):
        FMUBlock("a", path=str(clocked), mode="cs", rate=10)
