"""The compiled core's cache: one process compiles a piece of machine code, the others wait for it."""
import subprocess
import sys
import time

import pytest

from hybridsim.engine import native


@pytest.mark.slow
def test_a_second_process_waits_for_the_one_compiling_the_same_code(tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDSIM_CACHE", str(tmp_path))
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from hybridsim.engine import native\n"
         "with native.compiling('core_x'):\n    print('held', flush=True); time.sleep(1.0)"],
        stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    t0 = time.perf_counter()
    with native.compiling("core_x"):
        waited = time.perf_counter() - t0
    holder.wait(timeout=30)
    assert waited > 0.5  # s: it waited for the holder's second
    t0 = time.perf_counter()
    with native.compiling("core_y"):  # another piece of code: no wait
        assert time.perf_counter() - t0 < 0.5


def test_kernels_compiled_for_the_compiled_path_are_cached_in_hybridsims_folder(tmp_path):
    # numba picks a function's cache folder when its dispatcher is made: before the fix the first
    # diagram of a process cached its kernels beside their source (the package's __pycache__)
    import hybridsim as hs
    from hybridsim.engine import compiled

    path = tmp_path / "d.yaml"
    path.write_text("blocks:\n  s: {type: sine, frequency: 2.0}\n  g: {type: gain, K: 3.0}\n"
                    "  i: {type: integrator}\nwires: [s.y -> g.u, g.y -> i.u]\n"
                    "simulation: {t_end: 0.1, compiled: true}\n")
    hs.simulate(path)
    assert compiled._jitted
    for dispatcher in compiled._jitted.values():
        assert str(native.cache_dir()) in str(dispatcher._cache._cache_path)
