"""The seeded noise source: reproducible, independent of the path and the process, Gaussian."""
import subprocess
import sys

import numpy as np
import pytest

import hybridsim as hs
from hybridsim.blocks.noise import Noise


def samples(seed, n=4000, width=1):
    b = Noise(sigma=2.0, mean=1.0, seed=seed, rate=100, width=width)
    x, out = b.initial_state(), []
    for k in range(n):
        out.append(b.output(k / 100, x, [])[0])
        x = b.update(k / 100, x, [])
    return np.array(out)


def test_noise_has_its_mean_and_sigma_and_depends_on_the_seed():
    a = samples(3)[:, 0]
    assert abs(a.mean() - 1.0) < 4 * 2.0 / np.sqrt(a.size)  # 4 standard errors
    assert a.std() == pytest.approx(2.0, rel=0.05)
    assert np.array_equal(a, samples(3)[:, 0])
    assert not np.array_equal(a, samples(4)[:, 0])
    two = samples(3, n=200, width=2)
    assert not np.array_equal(two[:, 0], two[:, 1])  # channels differ


def test_noise_is_the_same_in_another_process():
    code = ("from hybridsim.blocks.noise import Noise; b = Noise(seed=11, rate=10); x = b.initial_state(); "
            "import numpy as np; print(repr(float(b.output(0, b.update(0, b.update(0, x, []), []), [])[0][0])))")
    other = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    b = Noise(seed=11, rate=10)
    x = b.update(0, b.update(0, b.initial_state(), []), [])
    assert other == float(b.output(0, x, [])[0][0])


def test_noise_refuses_a_bad_seed():
    for bad in (-1, 2 ** 32, 1.5, "7"):
        with pytest.raises(hs.ParameterError, match="seed"):
            Noise(seed=bad, rate=10)
