"""python-control systems as blocks (:func:`from_control`).

An LTI system (``TransferFunction`` or ``StateSpace``) becomes the library's
``state_space`` block when it is continuous, ``discrete_state_space`` (its
``dt`` as the period) when it is discrete, so it runs on every path. A
``NonlinearIOSystem`` becomes a block that calls its ``dynamics`` and
``output`` functions: the generic path only (Python functions have no
kernels). Linearizations come out of :mod:`hybridsim.analysis.linearize` as
python-control objects, so systems go both ways.
"""
import numpy as np

from hybridsim.engine.block import Block
from hybridsim.errors import ParameterError
from hybridsim.engine.registry import lookup


def from_control(sys, name="sys", feedthrough=None, x0=None):
    """A python-control system as a hybridsim block.

    Parameters
    ----------
    sys : control.TransferFunction, control.StateSpace or control.NonlinearIOSystem
        Continuous (dt = 0) or discrete (dt > 0, the block's period in s). A
        discrete system with an unspecified sample time (dt = True) is refused.
    name : str
        The block's name in the diagram.
    feedthrough : bool, optional
        Nonlinear systems only: whether the outputs depend directly on the
        inputs (default True, the safe assumption; False lets the block close
        a loop without an algebraic-loop error). LTI systems know it from D.
    x0 : array_like, optional
        Initial state (default zeros).

    Returns
    -------
    hybridsim.Block
        Ports ``u`` (width: the system's inputs) and ``y`` (its outputs).

    Examples
    --------
    >>> import control
    >>> blk = from_control(control.tf([1], [1, 1]), name="lag")   # 1/(s+1), continuous
    >>> blk.type_name, blk.input_port("u").width
    ('state_space', 1)
    """
    import control

    dt = getattr(sys, "dt", 0)
    if dt is True:
        raise ParameterError("dt", f"{name}: a discrete system needs a sample time (dt is True, "
                                   "unspecified); give dt in seconds")
    if dt is None:
        dt = 0
    if isinstance(sys, (control.TransferFunction, control.StateSpace)):
        ss = control.ss(sys)
        mats = {k: np.asarray(getattr(ss, k), float) for k in "ABCD"}
        init = None if x0 is None else list(np.ravel(x0))
        if dt == 0:
            return lookup("state_space")(name=name, **mats, x0=init)
        return lookup("discrete_state_space")(name=name, **mats, x0=init, period=float(dt))
    if isinstance(sys, control.NonlinearIOSystem):
        return ControlSystemBlock(sys, name, feedthrough=True if feedthrough is None else feedthrough, x0=x0)
    raise ParameterError("sys", f"{name}: not a python-control system: {type(sys).__name__}")


class ControlSystemBlock(Block):
    """A python-control ``NonlinearIOSystem`` as a block (generic path).

    Continuous: x' = dynamics(t, x, u), y = output(t, x, u). Discrete (dt > 0):
    x[k+1] = dynamics(t, x[k], u[k]) at the period dt. The system's own
    ``params`` are passed to its functions.
    """

    def __init__(self, sys, name="sys", feedthrough=True, x0=None):
        super().__init__(name)
        self.sys = sys
        n, m, p = sys.nstates, sys.ninputs, sys.noutputs
        self.declare_input("u", m)
        self.declare_output("y", p, depends_on=None if feedthrough or n == 0 else ())
        self.x0 = np.zeros(n) if x0 is None else np.asarray(x0, float).reshape(n)
        if sys.dt:
            self.declare_rate(period=float(sys.dt))
            self.declare_discrete_state(n)
        elif n:
            self.declare_continuous_state(n)
        self._params = getattr(sys, "params", None) or {}

    def initial_state(self, u=None):
        return self.x0.copy()

    def output(self, t, x, u):
        return (np.asarray(self.sys.output(t, np.asarray(x, float), u[0], self._params), float).reshape(-1),)

    def derivatives(self, t, x, u):
        return np.asarray(self.sys.dynamics(t, np.asarray(x, float), u[0], self._params), float).reshape(-1)

    update = derivatives  # discrete: the same function gives the next state
