"""More linear blocks: zero-pole-gain and MIMO transfer functions (continuous, from rest)."""
import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.kernels import Kernels
from hybridsim.engine.registry import register

from hybridsim.blocks._util import scalar, vector
from hybridsim.blocks.continuous.linear import abcd_output, abcd_step
from hybridsim.blocks.continuous.basic import tf_to_ss

GROUP = "control"  # where `hybridsim blocks` lists this module's blocks


def _roots(values, name):
    """Roots given as numbers or [re, im] pairs; complex ones must come with their conjugates."""
    if not isinstance(values, (list, tuple)):
        raise ParameterError(name, f"must be a list of numbers or [re, im] pairs, got {values!r}")
    out = []
    for v in values:
        pair = vector(v, name) if isinstance(v, (list, tuple)) else vector([v, 0.0], name)
        if pair.size != 2:
            raise ParameterError(name, f"a complex root is [re, im], got {v!r}")
        out.append(complex(pair[0], pair[1]))
    r = np.array(out, complex)
    if not np.allclose(np.sort_complex(r), np.sort_complex(r.conj())):
        raise ParameterError(name, f"complex roots must come in conjugate pairs, got {values!r}")
    return r


def _setup(block, A, B, C, D):
    block.params = tuple(np.ascontiguousarray(M, dtype=float) for M in (A, B, C, D))
    block.declare_input("u", B.shape[1])
    block.declare_output("y", C.shape[0], depends_on=None if np.any(D) else ())
    block.declare_continuous_state(A.shape[0])


@register("zero_pole_gain")
class ZeroPoleGain(Block):
    """y = k prod(s - z_i) / prod(s - p_j) u: a proper SISO transfer function by its roots, from rest.

    Example: zeros [], poles [-1, -2], gain 2 is 2 / ((s + 1)(s + 2)): DC gain 1.

    Parameters
    ----------
    zeros : list
        Roots of the numerator in rad/s: numbers, or [re, im] pairs with their conjugates included.
    poles : list
        Roots of the denominator, as ``zeros``.
    gain : float
        k, in units of y per unit of u times s^(n_p - n_z) (n_p poles, n_z zeros).
    """

    def __init__(self, name="zpk", zeros=(), poles=(-1.0,), gain=1.0):
        super().__init__(name)
        z, p = _roots(list(zeros), "zeros"), _roots(list(poles), "poles")
        if z.size > p.size:
            raise ParameterError("zeros", f"the transfer function must be proper: {z.size} zeros, {p.size} poles")
        k = scalar(gain, "gain")
        num, den = np.real(k * np.poly(z)) if z.size else np.array([k]), np.real(np.poly(p))
        if p.size == 0:
            _setup(self, np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[k]]))
        else:
            _setup(self, *tf_to_ss(num, den, "zeros"))
        self.x0 = np.zeros(p.size)

    def initial_state(self, u=None):
        return self.x0.copy()


@register("transfer_function_mimo")
class TransferFunctionMIMO(Block):
    """y_i = sum_j num[i][j](s) / den[i][j](s) u_j: a p x m matrix of proper transfer functions, from rest.

    Parameters
    ----------
    num : list of lists of lists   num[i][j]: coefficients in descending powers of s
    den : list of lists of lists   den[i][j], the same shape (or one list for every entry)

    Realized entry by entry (a block-diagonal A of each entry's controllable
    form: the order is the sum of the entries' orders, not minimal). Example:
    num [[[1], [2]]], den [[[1, 1], [1, 2]]]: y = u1 / (s + 1) + 2 u2 / (s + 2).
    """

    def __init__(self, name="tf_mimo", num=(((1.0,),),), den=(((1.0, 1.0),),)):
        super().__init__(name)
        if not isinstance(num, (list, tuple)) or not num or not all(isinstance(r, (list, tuple)) and r for r in num):
            raise ParameterError("num", "must be a matrix (a list of rows) of coefficient lists")
        p, m = len(num), len(num[0])
        if any(len(r) != m for r in num):
            raise ParameterError("num", "every row must have the same number of entries")
        common = isinstance(den, (list, tuple)) and den and not isinstance(den[0], (list, tuple))
        if not common and (len(den) != p or any(len(r) != m for r in den)):
            raise ParameterError("den", f"must be {p} x {m} like num, or one coefficient list for every entry")
        blocks = [[tf_to_ss(num[i][j], den if common else den[i][j], "num") for j in range(m)] for i in range(p)]
        n = sum(b[0].shape[0] for row in blocks for b in row)
        A, B, C, D = np.zeros((n, n)), np.zeros((n, m)), np.zeros((p, n)), np.zeros((p, m))
        k = 0
        for i in range(p):
            for j in range(m):
                a, b, c, d = blocks[i][j]
                q = a.shape[0]
                A[k:k + q, k:k + q], B[k:k + q, j], C[i, k:k + q], D[i, j] = a, b[:, 0], c[0], d[0, 0]
                k += q
        _setup(self, A, B, C, D)
        self.x0 = np.zeros(n)

    def initial_state(self, u=None):
        return self.x0.copy()


ZeroPoleGain.kernels = Kernels(output=abcd_output, derivatives=abcd_step)
TransferFunctionMIMO.kernels = Kernels(output=abcd_output, derivatives=abcd_step)
