"""The seeded noise source: numpy's Philox bit for bit, the same everywhere, and N(0, 1) by statistical tests."""
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

import hybridsim as hs
from hybridsim.blocks.sources.noise import Noise, philox4x64, philox_keys
from paths import PATHS, check, run


def samples(seed, n=4000, width=1, **kw):
    b = Noise(mean=1.0, seed=seed, rate=100, width=width, **{"sigma": 2.0, **kw})
    x, out = b.initial_state(), []
    for k in range(n):
        out.append(b.output(k / 100, x, [])[0])
        x = b.update(k / 100, x, [])
    return np.array(out)


def block_normals(seed, n, channel):
    """n_k (k < n) of one channel, vectorized: the block's Philox words, then Box-Muller as its docstring says."""
    z = np.zeros(n, dtype=np.uint64)
    w0, w1, _, _ = philox4x64(np.arange(n, dtype=np.uint64), z + np.uint64(channel), z, z, philox_keys(seed))
    u1 = 1.0 - (w0 >> np.uint64(11)).astype(float) * 2.0**-53
    u2 = (w1 >> np.uint64(11)).astype(float) * 2.0**-53
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)


def test_the_philox_words_are_numpys():
    for seed, k, ch in ((0, 1, 0), (5, 1, 0), (2**64 - 1, 12345, 3), (42, 2**40, 7)):
        ref = np.random.Philox(key=np.array([seed, 0], np.uint64),
                               counter=np.array([k - 1, ch, 0, 0], np.uint64)).random_raw(4)  # numpy steps, then draws
        words = philox4x64(np.uint64(k), np.uint64(ch), np.uint64(0), np.uint64(0), philox_keys(seed))
        assert [int(w) for w in words] == [int(w) for w in ref]


def test_the_block_gives_the_vectorized_numbers():
    b = Noise(seed=9, rate=10, width=3, sigma=1.0)
    ref = np.stack([block_normals(9, 50, ch) for ch in range(3)], axis=1)
    got = np.array([b.output(0.0, (float(k),), [])[0] for k in range(50)])
    np.testing.assert_allclose(got, ref, rtol=1e-14, atol=1e-15)  # math.cos vs numpy's: an ulp


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 12345, 2**63 + 7])
def test_a_million_samples_are_standard_normal_and_channels_independent(seed):
    n = 1_000_000
    a, b = block_normals(seed, n, 0), block_normals(seed, n, 1)
    for v in (a, b):
        assert stats.kstest(v, "norm").pvalue > 1e-3
        se = 1 / np.sqrt(n)
        assert abs(v.mean()) < 5 * se
        assert abs(v.var() - 1) < 5 * np.sqrt(2) * se        # var of s^2 is 2/n
        assert abs(stats.skew(v)) < 5 * np.sqrt(6) * se
        assert abs(stats.kurtosis(v)) < 5 * np.sqrt(24) * se
        assert abs(np.corrcoef(v[:-1], v[1:])[0, 1]) < 5 * se  # white: no lag-1 correlation
    assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(n)  # |r| < 0.005 (the old hash: 0.045)
    assert abs(np.corrcoef(a, block_normals(seed + 1, n, 0))[0, 1]) < 5 / np.sqrt(n)


def test_noise_has_its_mean_and_sigma_and_depends_on_the_seed():
    a = samples(3)[:, 0]
    np.testing.assert_allclose(a, 1.0 + 2.0 * block_normals(3, 4000, 0), rtol=1e-14, atol=1e-14)
    assert np.array_equal(a, samples(3)[:, 0])
    assert not np.array_equal(a, samples(4)[:, 0])


def test_psd_sets_sigma_from_the_period():
    # band-limited white noise of PSD 0.01 units^2/Hz at 100 Hz: sigma = sqrt(0.01 / 0.01 s) = 1
    a = samples(3, n=200, sigma=None, psd=0.04)[:, 0]
    assert np.allclose(a, 1.0 + 2.0 * block_normals(3, 200, 0), rtol=0, atol=1e-14)
    with pytest.raises(hs.ParameterError, match="psd"):
        Noise(sigma=1.0, psd=1.0, rate=10)


@pytest.mark.slow
def test_noise_is_the_same_in_another_process():
    code = ("from hybridsim.blocks.sources.noise import Noise; b = Noise(seed=11, rate=10); x = b.initial_state(); "
            "import numpy as np; print(repr(float(b.output(0, b.update(0, b.update(0, x, []), []), [])[0][0])))")
    other = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    b = Noise(seed=11, rate=10)
    x = b.update(0, b.update(0, b.initial_state(), []), [])
    assert other == float(b.output(0, x, [])[0][0])


def test_noise_refuses_a_bad_seed():
    for bad in (-1, 2 ** 64, 1.5, "7"):
        with pytest.raises(hs.ParameterError, match="seed"):
            Noise(seed=bad, rate=10)


@pytest.mark.parametrize("path", PATHS)
def test_noise_is_the_same_on_every_path(path):
    res = run(path, [Noise("n", seed=2**40 + 3, rate=50, width=2, sigma=[1.0, 0.5]),
                     hs.registry.lookup("first_order")("lag", tau=0.1, width=2, initial=[0.0, 0.0])],
              [("n.y", "lag.u")], 1.0, ["n.y", "lag.y"], log_period=0.02)
    ref = np.stack([block_normals(2**40 + 3, 50, 0), 0.5 * block_normals(2**40 + 3, 50, 1)], axis=1)
    got = np.stack([res["n.y[0]"], res["n.y[1]"]], axis=1)[:-1]  # the last row holds the hit before t_end
    check("noise", path, got, ref, 1e-15)
