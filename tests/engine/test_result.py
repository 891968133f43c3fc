"""Results in notebooks: a DataFrame, a plot; a diagram shows itself as SVG."""
import numpy as np
import pytest

import hybridsim as hs
from conftest import DIAGRAMS


def _res():
    return hs.simulate(DIAGRAMS / "examples" / "msd_pid.yaml", t_end=0.5)


def test_a_result_is_a_dataframe_indexed_by_time():
    res = _res()
    df = res.to_dataframe()
    assert list(df.columns) == res.columns()[1:] and df.index.name == "time"
    assert np.array_equal(df["plant.y[0]"].to_numpy(), res["plant.y[0]"])
    assert np.array_equal(df.index.to_numpy(), res.t)


def test_a_result_plots_one_panel_per_signal():
    res = _res()
    fig = res.plot()
    assert len(fig.axes) == len(res.signals)
    assert fig.axes[-1].get_xlabel() == "time (s)"
    assert len(res.plot(["plant.y"]).axes) == 1


def test_a_diagram_shows_itself_as_svg():
    d = hs.Diagram("demo")
    d.add(hs.registry.lookup("constant")("c", value=1.0))
    d.add(hs.registry.lookup("gain")("g", K=2.0))
    d.connect("c.y", "g.u")
    svg = d._repr_svg_()
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg


def test_a_signal_not_logged_or_not_a_name_is_a_clear_error():
    import pytest

    res = _res()
    with pytest.raises(KeyError, match=r"'plant\.x' was not logged \(did you mean 'plant\.y'\?\); logged: "):
        res["plant.x"]
    with pytest.raises(TypeError, match="'block.port' or 'block.port\\[i\\]', got 5"):
        res[5]
    with pytest.raises(IndexError, match=r"plant\.y has 1 element\(s\): \[7\] is not one of them"):
        res["plant.y[7]"]
    with pytest.raises(KeyError, match="is not 'block.port' or"):
        res["plant.y[x]"]
    assert np.array_equal(res["plant.y[-1]"], res["plant.y"][:, 0])


def test_the_api_refuses_a_variant_params_or_end_time_of_the_wrong_kind():
    import pytest

    path = DIAGRAMS / "examples" / "msd_pid.yaml"
    with pytest.raises(hs.InputError, match="a variant is a mapping"):
        hs.simulate(path, variant=99)
    _, sim, _ = hs.build(path)
    with pytest.raises(hs.InputError, match="run-time params are a mapping"):
        sim.run(0.1, params=[1])
    with pytest.raises(hs.InputError, match="end time must be a number of seconds, got '1'"):
        sim.run("1")
    with pytest.raises(TypeError, match="a diagram file is a path"):
        hs.simulate(None)


def test_the_api_refuses_logs_jobs_batches_and_run_time_params_of_the_wrong_kind():
    import pytest

    path = DIAGRAMS / "examples" / "msd_pid.yaml"
    with pytest.raises(TypeError, match="log is a list of signals"):
        hs.build(path, log=[5])
    with pytest.raises(hs.InputError, match="jobs must be a whole number >= 1, got 1.5"):
        hs.run(path, jobs=1.5)
    _, sim, _ = hs.build(path)
    with pytest.raises(hs.InputError, match="param_sets is a list of"):
        sim.run_batch(0.1, {"pid.Kp": 1.0})
    with pytest.raises(hs.InputError, match=r"'Kp\[0\]' is not a parameter of block 'pid' .*give 'Kp' whole"):
        sim.run(0.1, params={"pid.Kp[0]": 2.0})
    with pytest.raises(hs.InputError, match="'Kpp' is not a parameter of block 'pid' .*its parameters: Kp, Ki"):
        sim.run(0.1, params={"pid.Kpp": 2.0})
    assert 5 not in _res() and "plant.y" in _res()


def test_a_csv_reads_back_a_value_near_the_largest_float_as_finite(tmp_path):
    # 1.7976931348622732e308 written with 10 digits is 1.797693135e+308: inf when read back
    import hybridsim as hs

    p = tmp_path / "huge.yaml"
    p.write_text("blocks:\n  c: {type: constant, value: [709.782712893384, 1.0]}\n"
                 "  e: {type: math_function, function: exp, width: 2}\nwires: [c.y -> e.u]\nlog: [e.y]\n"
                 "simulation: {t_end: 0.01, log_period: 0.005}\n")
    hs.simulate(p).to_csv(tmp_path / "huge.csv")
    back = np.genfromtxt(tmp_path / "huge.csv", delimiter=",", skip_header=1)
    assert np.isfinite(back).all() and back[-1, 1] == np.exp(709.782712893384)
    assert back[-1, 2] == pytest.approx(np.e, abs=1e-9)  # the others as ever, 10 digits
