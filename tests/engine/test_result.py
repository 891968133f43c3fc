"""Results in notebooks: a DataFrame, a plot; a diagram shows itself as SVG."""
import numpy as np

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
