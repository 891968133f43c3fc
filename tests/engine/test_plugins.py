"""Plugins: blocks from another package (entry points) or from a module named with --plugin."""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from hybridsim.app.cli import main

PLUGIN_MODULE = '''
"""A third party's block: y = a u^3."""
import numpy as np

from hybridsim.engine.block import Block
from hybridsim.engine.kernels import Kernels, kernel
from hybridsim.engine.registry import register

GROUP = "plugins"


@register("cubic")
class Cubic(Block):
    """y = a u^3 (a plugin's block)."""

    def __init__(self, name="cubic", a=1.0):
        super().__init__(name)
        self.params = (float(a),)
        self.declare_input("u", 1)
        self.declare_output("y", 1)


@kernel
def cubic_output(p, t, x, u):
    v = np.asarray(u[0])
    return (p[0] * v * v * v,)  # not v ** 3: numpy and numba compute powers differently (last bit)


Cubic.kernels = Kernels(output=cubic_output)
'''

DIAGRAM = """blocks:
  w: {type: cosine, amplitude: 2.0, frequency: 1.0}
  c: {type: cubic, a: 0.5}
  i: {type: integrator}
wires: [w.y -> c.u, c.y -> i.u]
simulation: {t_end: 0.5, step: 1.0e-3, log_period: 0.01}
log: [c.y, i.y]
"""


@pytest.fixture(scope="module")
def installed_plugin(tmp_path_factory):
    """A tiny plugin package, built and installed into a folder put on PYTHONPATH."""
    root = tmp_path_factory.mktemp("plugin")
    src = root / "src"
    (src / "hs_demo_plugin").mkdir(parents=True)
    (src / "hs_demo_plugin" / "__init__.py").write_text(PLUGIN_MODULE)
    (src / "pyproject.toml").write_text(textwrap.dedent("""
        [build-system]
        requires = ["setuptools>=64"]
        build-backend = "setuptools.build_meta"
        [project]
        name = "hs-demo-plugin"
        version = "0.1"
        [project.entry-points."hybridsim.blocks"]
        demo = "hs_demo_plugin"
        [tool.setuptools]
        packages = ["hs_demo_plugin"]
        """))
    target = root / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                    "--target", str(target), str(src)], check=True, capture_output=True, timeout=300)
    (root / "d.yaml").write_text(DIAGRAM)
    return target, root


def _python(installed_plugin, code):
    target, root = installed_plugin
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(target), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_an_installed_plugin_block_runs_from_yaml_on_the_generic_and_compiled_paths(installed_plugin):
    r = _python(installed_plugin, textwrap.dedent("""
        import numpy as np, hybridsim as hs
        from hybridsim.app.cli import main
        generic = hs.simulate("d.yaml", fused=False)
        compiled = hs.simulate("d.yaml", compiled=True)
        assert np.array_equal(generic.table(), compiled.table()), "paths differ"
        t = generic.t
        assert np.allclose(generic["c.y[0]"], 0.5 * (2.0 * np.cos(2 * np.pi * t)) ** 3, atol=1e-12)
        assert main(["blocks"]) == 0
        """))
    assert r.returncode == 0, r.stderr[-3000:]
    assert "plugins:" in r.stdout and "cubic" in r.stdout  # listed under its own group


def test_plugin_named_on_the_command_line(tmp_path, monkeypatch, capsys):
    (tmp_path / "my_blocks_demo.py").write_text(PLUGIN_MODULE.replace('"cubic"', '"cubic_cli"'))
    (tmp_path / "d.yaml").write_text(DIAGRAM.replace("type: cubic", "type: cubic_cli"))
    monkeypatch.syspath_prepend(str(tmp_path))
    assert main(["check", str(tmp_path / "d.yaml"), "--plugin", "my_blocks_demo"]) == 0
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "d.yaml"), "-q", "--plugin", "my_blocks_demo", "-o", str(out)]) == 0
    assert (out / "d.csv").is_file() or any(out.glob("*.csv"))
    assert main(["check", str(tmp_path / "d.yaml"), "--plugin", "not_a_module_xyz"]) == 2
    assert "cannot import plugin module 'not_a_module_xyz'" in capsys.readouterr().err


@pytest.mark.slow
def test_a_broken_installed_plugin_is_skipped_with_a_warning(installed_plugin):
    target, _ = installed_plugin
    broken = target / "hs_demo_plugin" / "__init__.py"
    text = broken.read_text()
    try:
        broken.write_text("raise RuntimeError('broken on purpose')\n")
        r = _python(installed_plugin, "from hybridsim.app.cli import main; import sys; "
                                      "sys.exit(main(['check', 'd.yaml']))")
    finally:
        broken.write_text(text)
    assert r.returncode == 2  # the diagram's block type is unknown, the built-in blocks still load
    assert "plugin 'demo' (hs_demo_plugin) cannot be imported and is skipped" in r.stderr
    assert "unknown block type 'cubic'" in r.stderr
