"""Installed from a wheel, outside the checkout, hybridsim does its main jobs and claims no generic name."""
import os
import site as _site
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from conftest import ROOT


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh virtual environment with hybridsim installed from a wheel built here.

    The environment sees the packages of the interpreter running the tests (numpy, fmpy,
    ...: nothing is downloaded), whether that is a virtual environment or a system-wide
    install, but not the checkout: hybridsim comes from the wheel alone.
    """
    tmp = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                    "-w", str(tmp / "dist"), str(ROOT)], check=True, capture_output=True, timeout=300)
    wheel = next((tmp / "dist").glob("hybridsim-*.whl"))
    venv.EnvBuilder(system_site_packages=False, with_pip=False).create(tmp / "env")
    py = tmp / "env" / "bin" / "python"
    # pip of this interpreter installs into the new environment's site-packages
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          check=True, capture_output=True, text=True).stdout.strip()
    # After its own site-packages, the environment reads this interpreter's (a venv's or the
    # system's: system_site_packages would read the base interpreter's, which a venv does not
    # install into). addsitedir also runs their .pth files (Pinocchio's cmeel prefix).
    dirs = [d for d in _site.getsitepackages() + [_site.getusersitepackages()]
            if _site.ENABLE_USER_SITE or d != _site.getusersitepackages()]
    (Path(site) / "zz_tests_parent_site.pth").write_text(
        "import site; " + "; ".join(f"site.addsitedir({d!r})" for d in dirs) + "\n")
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target", site,
                    str(wheel)], check=True, capture_output=True, timeout=300)
    work = tmp / "elsewhere"
    work.mkdir()
    return py, work


def run(installed, *args, code=None):
    py, work = installed
    cmd = [str(py), "-c", code] if code else [str(py), "-m", "hybridsim.app.cli", *args]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(cmd, cwd=work, capture_output=True, text=True, timeout=600, env=env)


@pytest.mark.slow
def test_the_wheel_runs_the_shipped_diagrams_from_any_folder(installed):
    where = run(installed, code="import hybridsim, hybridsim.blocks; print(hybridsim.__file__)")
    assert where.returncode == 0 and str(ROOT) not in where.stdout and "site-packages" in where.stdout
    for name in ("blocks", "fmus", "diagrams"):  # installed under hybridsim's namespace only
        r = run(installed, code=f"import {name}")
        assert r.returncode != 0 and "No module named" in r.stderr, name
    r = run(installed, "check", "diagrams/fig9_force_and_position.yaml")
    assert r.returncode == 0, r.stderr
    assert "using the shipped" in r.stderr and "fig9_force_and_position.yaml: OK - " in r.stdout
    r = run(installed, "run", "diagrams/fig9_force_and_position.yaml", "-q", "--set", "simulation.t_end=0.1",
            "--set", "rate=120", "-o", "fig9")
    assert r.returncode == 0, r.stderr
    assert (installed[1] / "fig9" / "fig9_force_and_position.csv").is_file()
    r = run(installed, "reproduce", "--quick", "-o", "rq")
    assert r.returncode == 0, r.stderr
    assert (installed[1] / "rq" / "reproduce.html").is_file() and "272.5 Hz" in r.stdout
    assert "sensitivity runs" not in r.stderr  # --quick runs none; it said it did
    r = run(installed, "examples", "-o", "mine")
    assert r.returncode == 0, r.stderr
    assert (installed[1] / "mine" / "subsystems" / "fig6_controller.yaml").is_file()
    r = run(installed, "run", "mine/fig10_force_ramp.yaml", "-q", "--set", "simulation.t_end=0.1", "-o", "f10")
    assert r.returncode == 0, r.stderr


@pytest.mark.slow
def test_the_wheel_builds_the_plant_fmu(installed):
    r = run(installed, "fmu", "build", "--fmi", "3", "-o", "plant3.fmu")
    assert r.returncode == 0, r.stderr
    assert (installed[1] / "plant3.fmu").stat().st_size > 10_000


def test_every_package_folder_is_in_the_wheel():
    """pyproject.toml lists the packages by hand (blocks/, fmus/ and diagrams/ map into hybridsim's
    namespace): a new subpackage or diagram folder missing from the list would be left out of the
    wheel."""
    import tomllib

    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(cfg["packages"])
    found = {"hybridsim." + ".".join(p.parent.relative_to(ROOT / "hybridsim").parts)
             for p in (ROOT / "hybridsim").rglob("__init__.py") if p.parent != ROOT / "hybridsim"}
    found |= {"hybridsim", "hybridsim.blocks", "hybridsim.fmus", "hybridsim.diagrams"}
    found |= {f"hybridsim.diagrams.{d.name}" for d in (ROOT / "diagrams").iterdir()
              if d.is_dir() and any(d.glob("*.yaml")) or d.is_dir() and any(d.glob("*.urdf"))}
    assert found - listed == set(), "add these to pyproject.toml's packages"
    data = cfg["package-data"]
    for pkg in (p for p in listed if p.startswith("hybridsim.diagrams")):
        assert pkg in data, f"{pkg} has no package-data entry (its YAML files would be left out)"
