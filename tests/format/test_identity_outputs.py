"""A run's identity covers what it reads; outputs never collide, never replace a user's file; one
writer per folder; exit codes by origin (the environment, a plugin)."""
import builtins
import errno
import json
import os
import sys
from pathlib import Path

import pytest

from hybridsim import files

from hybridsim.engine import registry
from hybridsim.app.cli import main
from hybridsim.format import identity

from conftest import write
from conftest import GOOD


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def tree(folder):
    out = {}
    for root, dirs, names in os.walk(folder):
        for n in dirs + names:
            p = Path(root) / n
            out[str(p.relative_to(folder))] = None if p.is_dir() else p.read_bytes()
    return out


# -- identity ------------------------------------------------------------------------------------

SUB = "inputs: {u: g.u}\noutputs: {y: g.y}\nblocks:\n  g: {type: gain, K: 2.0}\n"
TOP = """params: {k: 1.0, note: none}
blocks:
  c: {type: constant, value: $k}
  s: {type: subsystem, file: sub.yaml}
wires: [c.y -> s.u]
simulation: {t_end: 0.02, log_period: 1.0e-2}
log: [s.y]
"""


def test_editing_a_subsystem_file_invalidates_resumed_points(tmp_path, capsys):
    (tmp_path / "sub.yaml").write_text(SUB)
    d = write(tmp_path, TOP)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{k: [1, 2]}}\n", "s.yaml")
    out = tmp_path / "o"
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 0
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 0  # unchanged: resumes
    (tmp_path / "sub.yaml").write_text(SUB.replace("K: 2.0", "K: 3.0"))
    code, _, err = run(capsys, "sweep", s, "-q", "-o", out)
    assert code == 2 and "different sweep" in err and "subsystem" in err


def test_editing_a_file_named_in_the_grid_invalidates_resumed_points(tmp_path, capsys):
    (tmp_path / "sub.yaml").write_text(SUB)
    (tmp_path / "a.txt").write_text("one")
    d = write(tmp_path, TOP)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{note: [a.txt]}}\n", "s.yaml")
    out = tmp_path / "o"
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 0
    (tmp_path / "a.txt").write_text("two")
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 2


def test_identity_covers_urdf_meshes_block_files_and_plugins(tmp_path):
    (tmp_path / "meshes").mkdir()
    mesh = tmp_path / "meshes" / "link.stl"
    mesh.write_text("solid a")
    urdf = tmp_path / "arm.urdf"
    urdf.write_text('<robot name="a"><link name="l"><visual><geometry>'
                    '<mesh filename="package://meshes/link.stl"/></geometry></visual></link></robot>')

    class Fake:
        def __init__(self):
            self.path = urdf

    got = identity.block_files([Fake()])
    assert got == {urdf.resolve(), mesh.resolve()}
    before = identity.identity(got)
    mesh.write_text("solid b")
    assert identity.identity(got) != before
    assert identity.identity(got, {"set": 1}) != identity.identity(got, {"set": 2})
    assert Path(registry.__file__).resolve() not in identity.plugin_files()


# -- one writer per output folder ------------------------------------------------------------------

def test_a_second_writer_into_a_folder_is_refused_and_changes_nothing(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    s = write(tmp_path, f"diagram: {d}\ngrid: {{k: [1, 2]}}\n", "s.yaml")
    out = tmp_path / "o"
    assert run(capsys, "sweep", s, "-q", "-o", out)[0] == 0
    before = tree(out)
    with files.output_lock(out):  # another hybridsim holds the folder
        code, _, err = run(capsys, "sweep", s, "-q", "-o", out, "--force")
        assert code == 2 and "is writing into" in err
        code, _, err = run(capsys, "run", d, "-q", "-o", out)
        assert code == 2 and "is writing into" in err
    assert tree(out) == before
    assert run(capsys, "run", d, "-q", "-o", out)[0] == 0  # released


# -- outputs -------------------------------------------------------------------------------------------

def test_labels_that_slug_alike_get_names_that_cannot_collide(tmp_path, capsys):
    text = GOOD.replace("params:\n  k: 2.0\n", "params:\n  k: 2.0\n  tag: x\n") + \
        "variants: {tag: ['a b', 'a-b', 'A B']}\n"
    out = tmp_path / "o"
    code, _, err = run(capsys, "run", write(tmp_path, text), "-q", "-o", out)
    assert code == 0, err
    csvs = sorted(p.name for p in out.glob("*.csv"))
    assert len(csvs) == 3 and len({c.lower() for c in csvs}) == 3
    doc = json.loads((out / "metrics.json").read_text())
    assert sorted(r["csv"] for r in doc["runs"]) == csvs


def test_draw_without_o_never_replaces_a_file_hybridsim_did_not_write(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    d = write(tmp_path, GOOD)
    (tmp_path / "d.png").write_text("my own picture")
    code, _, err = run(capsys, "draw", d)
    assert code == 0 and "writing d-2.png instead" in err
    assert (tmp_path / "d.png").read_text() == "my own picture"
    code, _, err = run(capsys, "draw", d)  # d-2.png is ours now: replaced, no d-3.png
    assert code == 0 and not (tmp_path / "d-3.png").exists()
    assert not (tmp_path / ".hybridsim").exists()


def test_fmu_build_without_o_keeps_a_users_plant_fmu(tmp_path, capsys, monkeypatch):
    import hybridsim.fmus.build as build

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(build, "build_plant_fmu", lambda out, fmi=2: (Path(out).write_text("fmu"), out)[1])
    (tmp_path / "plant.fmu").write_text("the user's FMU")
    code, out, err = run(capsys, "fmu", "build")
    assert code == 0 and "plant-2.fmu" in out + err
    assert (tmp_path / "plant.fmu").read_text() == "the user's FMU"


def test_a_run_folder_keeps_a_users_file_with_or_without_o(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    d = write(tmp_path, GOOD)
    (tmp_path / "out" / "d").mkdir(parents=True)
    (tmp_path / "out" / "d" / "d.csv").write_text("mine")
    for extra in ((), ("-o", tmp_path / "out" / "d")):
        code, _, err = run(capsys, "run", d, "-q", *extra)
        assert code == 2 and "hybridsim did not write it" in err
        assert tree(tmp_path / "out" / "d") == {"d.csv": b"mine"}
    (tmp_path / "out" / "d" / "d.csv").unlink()
    assert run(capsys, "run", d, "-q", "-o", tmp_path / "out" / "d")[0] == 0
    assert (tmp_path / "out" / "d" / "d.csv").read_text().startswith("time")
    assert run(capsys, "run", d, "-q")[0] == 0  # ours: a default run replaces it


def test_a_result_path_that_is_a_folder_leaves_every_earlier_result(tmp_path, capsys):
    d = write(tmp_path, GOOD)
    out = tmp_path / "o"
    assert run(capsys, "run", d, "-q", "-o", out)[0] == 0
    (out / "metrics.json").unlink()
    (out / "metrics.json").mkdir()
    before = tree(out)
    code, _, err = run(capsys, "run", d, "-q", "-o", out)
    assert code == 2 and "is a folder" in err and "nothing was written" in err
    assert tree(out) == before


# -- exit codes by origin: the environment -----------------------------------------------------------

def test_disk_full_is_exit_5_with_the_os_message(tmp_path, capsys, monkeypatch):
    def full(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(a[-1]))

    monkeypatch.setattr(os, "replace", full)
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", tmp_path / "o")
    assert code == 5 and "No space left on device" in err and "ENOSPC" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("target", ["x" * 300, "/proc/hybridsim-test/out"])
def test_an_output_the_os_refuses_is_exit_5(tmp_path, capsys, target):
    out = tmp_path / target if not target.startswith("/") else Path(target)
    code, _, err = run(capsys, "run", write(tmp_path, GOOD), "-q", "-o", out)
    assert code == 5 and "error:" in err, err


def test_a_folder_that_takes_no_file_says_so(tmp_path, capsys, monkeypatch):
    # /proc passes os.access for root but creates no file: it said "cannot write output folder
    # '/proc': No such file or directory", as though the folder were missing
    import tempfile

    def refuse(*a, **k):
        raise OSError(errno.ENOENT, os.strerror(errno.ENOENT), "probe")

    monkeypatch.setattr(tempfile, "TemporaryFile", refuse)
    code, _, err = run(capsys, "fmu", "build", "-o", tmp_path / "x.fmu")
    assert code == 5 and f"cannot create a file in output folder '{tmp_path}'" in err, err


def test_a_missing_package_is_named_with_its_extra(tmp_path, capsys, monkeypatch):
    real = builtins.__import__

    def no_matplotlib(name, *a, **k):
        if name.split(".")[0] == "matplotlib":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return real(name, *a, **k)

    d = write(tmp_path, GOOD)
    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    code, _, err = run(capsys, "draw", d, "-o", tmp_path / "x.png")
    monkeypatch.setattr(builtins, "__import__", real)
    assert code == 5 and "the Python package 'matplotlib' is missing" in err and "pip install" in err
    from hybridsim import errors

    exc = errors.missing_dependency(ModuleNotFoundError("No module named 'pinocchio'", name="pinocchio"))
    assert exc.exit_code == 5 and "'pin'" in str(exc) and 'hybridsim[robots]' in str(exc)
    assert errors.missing_dependency(ModuleNotFoundError("x", name="not_a_dependency")) is None


# -- exit codes by origin: a plugin ----------------------------------------------------------------

PLUGIN = '''
import numpy as np
from hybridsim.engine.block import Block
from hybridsim.engine.registry import register


@register("wide_{tag}")
class Wide(Block):
    """y has the wrong width."""

    def __init__(self, name="wide"):
        super().__init__(name)
        self.declare_input("u", 1)
        self.declare_output("y", 1)

    def output(self, t, x, u):
        return (np.zeros(3),)


@register("boom_{tag}")
class Boom(Block):
    """Its constructor raises."""

    def __init__(self, name="boom", k=1.0):
        raise RuntimeError("constructor exploded")


class Thing:
    pass


@register("undoc_{tag}")
class Undoc(Block):
    def __init__(self, name="undoc", thing=Thing()):
        super().__init__(name)
        self.declare_output("y", 1)
'''


@pytest.fixture
def plugin_dir(tmp_path, monkeypatch):
    """A folder on sys.path for plugin modules; the registry is restored afterwards."""
    registry._load_libraries()
    saved = (dict(registry._TYPES), dict(registry.REPLACED), set(registry.PLUGIN_MODULES), set(sys.modules))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    registry._TYPES.clear()
    registry._TYPES.update(saved[0])
    registry.REPLACED.clear()
    registry.REPLACED.update(saved[1])
    registry.PLUGIN_MODULES.clear()
    registry.PLUGIN_MODULES.update(saved[2])
    for name in set(sys.modules) - saved[3]:
        if name.startswith("hs_test_plugin"):
            del sys.modules[name]


def _diagram(tmp_path, tname):
    return write(tmp_path, f"blocks:\n  c: {{type: constant, value: 1.0}}\n  w: {{type: {tname}}}\n"
                           "wires: [c.y -> w.u]\nsimulation: {t_end: 0.01}\nlog: [w.y]\n", "p.yaml")


def test_plugin_faults_name_the_plugin_the_block_and_what_it_did(plugin_dir, capsys):
    (plugin_dir / "hs_test_plugin_a.py").write_text(PLUGIN.replace("{tag}", "a"))
    code, _, err = run(capsys, "run", _diagram(plugin_dir, "wide_a"), "-q", "-o", plugin_dir / "o",
                       "--plugin", "hs_test_plugin_a")
    assert code == 6 and "plugin 'hs_test_plugin_a': block 'w' (wide_a): output 'y' returned shape (3,)" in err
    assert not (plugin_dir / "o").exists()
    text = _diagram(plugin_dir, "boom_a").read_text().replace("wires: [c.y -> w.u]\n", "").replace("log: [w.y]\n", "")
    code, _, err = run(capsys, "check", write(plugin_dir, text, "b.yaml"), "--plugin", "hs_test_plugin_a")
    assert code == 6 and "block 'w' (boom_a): its constructor raised RuntimeError: constructor exploded" in err
    code, out, _ = run(capsys, "blocks", "--plugin", "hs_test_plugin_a")
    assert code == 0 and "no docstring" in out
    code, out, _ = run(capsys, "schema", "--plugin", "hs_test_plugin_a")
    assert code == 0 and "undoc_a" in json.loads(out)["properties"]["blocks"]["additionalProperties"]["anyOf"][-4]["title"] \
        or "undoc_a" in out


def test_a_plugin_may_not_silently_replace_a_block_type(plugin_dir, capsys):
    (plugin_dir / "hs_test_plugin_b.py").write_text(
        "from hybridsim.engine.registry import register, lookup\n\n@register('gain')\nclass G(lookup('gain')):\n    '''mine'''\n")
    d = write(plugin_dir, GOOD)
    code, _, err = run(capsys, "check", d, "--plugin", "hs_test_plugin_b")
    assert code == 6 and "registers block type 'gain'" in err and "replaces=True" in err
    assert registry.lookup("gain").__module__ == "hybridsim.blocks.math.signals"
    (plugin_dir / "hs_test_plugin_c.py").write_text(
        "from hybridsim.engine.registry import register, lookup\n\n@register('gain', replaces=True)\n"
        "class G(lookup('gain')):\n    '''mine'''\n")
    code, _, err = run(capsys, "check", d, "--plugin", "hs_test_plugin_c")
    assert code == 0 and "warning: block type 'gain' is replaced by hs_test_plugin_c.G" in err
    code, _, err = run(capsys, "blocks")  # every command warns while it is replaced
    assert code == 0 and "warning: block type 'gain' is replaced" in err


def test_a_plugin_calling_sys_exit_on_import_is_its_fault(plugin_dir, capsys):
    (plugin_dir / "hs_test_plugin_d.py").write_text("import sys\nsys.exit(0)\n")
    code, _, err = run(capsys, "check", write(plugin_dir, GOOD), "--plugin", "hs_test_plugin_d")
    assert code == 6 and "plugin 'hs_test_plugin_d': its import raised SystemExit" in err
    code, _, err = run(capsys, "check", write(plugin_dir, GOOD), "--plugin", "hs_no_such_module_xyz")
    assert code == 2 and "no such module" in err


def test_nan_signals_and_dollars_in_texts_do_not_break_plotting(tmp_path, capsys):
    text = """description: "cost $\\\\frac{x$ and $unbalanced"
blocks:
  z: {type: constant, value: 1.0}
  p$x: {type: product, ops: "*/"}
wires: [z.y -> p$x.u1, z.y -> p$x.u2]
simulation: {t_end: 0.01}
log: [p$x.y]
signals: {force: 'p$x.y[0]', force_desired: 'z.y[0]'}
"""
    out = tmp_path / "o"
    code, _, err = run(capsys, "run", write(tmp_path, text), "-q", "-o", out)
    assert code == 0, err
    assert (out / "d.png").stat().st_size > 0
    code, _, err = run(capsys, "draw", write(tmp_path, text), "-o", tmp_path / "x.png")
    assert code == 0, err
    # a block output may be NaN only where the block declares it may (the engine stops the run
    # otherwise), so the figure is handed one directly: it still draws, with finite axis limits
    import math

    import matplotlib.pyplot as plt

    from hybridsim.runs.variants import run_experiment
    from hybridsim.report.figures import experiment_figure

    f, runs, settings = run_experiment(write(tmp_path, text))
    runs[0]["result"].signals["p$x.y"][:] = math.nan
    fig = experiment_figure(f, runs, settings)
    fig.savefig(tmp_path / "nan.png")
    plt.close(fig)
    assert (tmp_path / "nan.png").stat().st_size > 0


def test_a_linearisation_that_overflows_is_the_models_not_a_bug():
    import numpy as np

    from hybridsim.analysis import stability as analysis
    from hybridsim.app.cli import _origin

    exc = _origin(np.linalg.LinAlgError("Array must not contain infs or NaNs"))
    assert exc.exit_code == 3 and "no finite solution" in str(exc)
    res = {"diagram": "d", "period_s": 0.01, "branch": {}, "growth": 0.5, "integrator_modes": 0, "stable": True,
           "poles": [], "loops": {}, "cases": {"a": {"set": {}, "spectral_radius": None, "stable": False}},
           "rates": [{"rate_hz": 1e-3, "spectral_radius": None, "stable": False}], "gains": {}}
    text = "\n".join(analysis.summary_lines(res))
    assert "largest |z| n/a" in text and "0.001:n/a!" in text


def test_default_output_folders_of_report_sweep_and_tune_keep_a_users_files(tmp_path, capsys, monkeypatch):
    """Without -o, report, sweep and tune write into out/NAME...: a file there that hybridsim did
    not write is refused before any work, and left as it was."""
    monkeypatch.chdir(tmp_path)
    d = write(tmp_path, "params: {k: 1.0}\nblocks:\n  c: {type: constant, value: $k}\nsimulation: {t_end: 0.01}\nlog: [c.y]\n")
    sweep = write(tmp_path, f"diagram: {d}\ngrid: {{k: [1.0, 2.0]}}\n", name="s.yaml")
    for args, folder in ((["sweep", str(sweep), "-q"], tmp_path / "out" / "s"),):
        folder.mkdir(parents=True)
        mine = folder / "sweep.csv"
        mine.write_text("my own numbers\n")
        code, _, err = run(capsys, *args)
        assert code == 2 and "hybridsim did not write it" in err, err
        assert mine.read_text() == "my own numbers\n" and sorted(p.name for p in folder.iterdir()) == ["sweep.csv"]
        mine.unlink()
        code, _, err = run(capsys, *args)  # its own files are no obstacle: a second run resumes
        assert code == 0, err
        code, _, err = run(capsys, *args)
        assert code == 0, err
    rep = tmp_path / "out" / "d_report"
    rep.mkdir(parents=True)
    (rep / "notes.txt").write_text("mine\n")
    code, _, err = run(capsys, "report", str(d))
    assert code == 2 and "notes.txt" in err, err
    assert (rep / "notes.txt").read_text() == "mine\n"


def test_a_symbolic_link_to_nothing_is_refused_as_an_output_file_or_folder(tmp_path, capsys, monkeypatch):
    # -o onto a dangling link said "File exists" (exit 5) for a folder and followed it for a file
    monkeypatch.chdir(tmp_path)
    d = write(tmp_path, GOOD)
    (tmp_path / "folder").symlink_to(tmp_path / "nowhere")
    code, _, err = run(capsys, "run", d, "-q", "-o", "folder")
    assert code == 2 and "symbolic link to a missing target" in err, err
    (tmp_path / "pic.svg").symlink_to(tmp_path / "elsewhere.svg")
    code, _, err = run(capsys, "draw", d, "-o", "pic.svg")
    assert code == 2 and "symbolic link to a missing target" in err, err
    assert not (tmp_path / "nowhere").exists() and not (tmp_path / "elsewhere.svg").exists()


def test_the_identity_holds_hybridsims_code(tmp_path, monkeypatch):
    """An edited install computed other numbers under the same version (a resumed sweep served the
    old code's largest |z|): the source's hash is part of every identity."""
    first = identity.code_identity()
    assert first == identity.code_identity() and len(first) == 24
    before = identity.identity([], {"a": 1})
    monkeypatch.setattr(identity, "code_identity", lambda: "edited")
    assert identity.identity([], {"a": 1}) != before


def test_a_symbolic_link_to_a_file_hybridsim_wrote_is_not_replaced(tmp_path, capsys, monkeypatch):
    # the link's target was judged (hybridsim's), and the rename replaced the user's link with a file
    monkeypatch.chdir(tmp_path)
    d = write(tmp_path, GOOD)
    code, _, err = run(capsys, "draw", d, "-o", "pic.svg")
    assert code == 0, err
    (tmp_path / "link.svg").symlink_to(tmp_path / "pic.svg")
    code, _, err = run(capsys, "draw", d, "-o", "link.svg")
    assert code == 2 and "is a symbolic link; hybridsim does not replace it" in err, err
    assert (tmp_path / "link.svg").is_symlink()
