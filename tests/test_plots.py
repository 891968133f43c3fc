"""Figures: a grid of variants gets one small panel per case, as the paper draws Fig 7."""
import hybridsim as hs
from hybridsim.plots import experiment_figure
from conftest import DIAGRAMS


def test_a_two_parameter_grid_of_variants_gets_small_multiples():
    f, runs, settings = hs.run_experiment(DIAGRAMS / "fig7_force_steps.yaml", t_end=0.05)
    fig = experiment_figure(f, runs, settings)
    assert len(fig.axes) == 9  # force 1, 5, 10 N x rate 60, 80, 120 Hz
    titles = [ax.get_title() for ax in fig.axes[:3]]
    assert titles == ["rate = 60", "rate = 80", "rate = 120"]
    assert fig.axes[0].get_ylabel().startswith("force = 1.0")


def test_one_swept_parameter_stays_one_overlaid_figure():
    f, runs, settings = hs.run_experiment(DIAGRAMS / "fig9_force_and_position.yaml", t_end=0.05)
    fig = experiment_figure(f, runs, settings)
    assert len(fig.axes) == 3  # position, force, contact; the three rates overlaid as in Fig 9
