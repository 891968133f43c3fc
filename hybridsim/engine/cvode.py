"""CVODE (SUNDIALS' variable-order BDF) for the continuous states, through scikit-sundae.

:class:`CVode` runs wherever a scipy solver does: the generic path and Model
Exchange FMUs. Between two stops (sample hits, events) one CVODE integration
runs (:mod:`hybridsim.engine.cvode_stepper`):

* log times inside the interval come from CVODE's own interpolant (its
  ``CV_NORMAL`` output, never a step landed on purpose), so logging does not
  change the steps taken;
* zero crossings are found by CVODE's root finding (Hairer-style Illinois
  iteration to a few units of round-off in t) and handed to the stepping
  core, which runs the actions (a switch without one only restarts) and
  starts CVODE again there, at order 1, so a switch is never stepped across;
* ``tstop`` is the next stop: CVODE never integrates past a sample hit, where
  the held inputs change.

Its Newton iteration uses a dense finite-difference Jacobian, which suits the
stiff contact and friction laws and an FMU that gives no Jacobian; one call of
the right-hand side per Newton iteration rather than per stage is why it is
the solver to use for Model Exchange FMUs.
"""
import numpy as np

from hybridsim.engine.solvers import Solver, positive, tolerance


class CVode(Solver):
    """SUNDIALS CVODE with restarts at sample hits and at zero crossings.

    Parameters
    ----------
    rtol : float
        Relative tolerance.
    atol : float or array_like
        Absolute tolerance, one for every state or one per state (in the
        states' units).
    max_step : float
        Longest internal step in s (inf: no limit).
    method : {"BDF", "Adams"}
        BDF (orders 1-5) for stiff systems, Adams-Moulton for smooth ones.
    scan : float
        Longest internal step, s, while there are located event functions
        (default 1 ms): CVODE looks for roots only at its step ends, and a
        function driven by time rather than by the states (a relay on a sine)
        could cross and cross back inside one long step. The scipy solvers
        check the functions this often too.
    """

    def __init__(self, rtol=1e-8, atol=1e-10, max_step=np.inf, method="BDF", scan=1e-3):
        try:
            import sksundae  # noqa: F401
        except ImportError:  # pragma: no cover - a core dependency
            raise ImportError("solver cvode needs scikit-sundae: pip install scikit-sundae") from None
        if method not in ("BDF", "Adams"):
            raise ValueError(f"CVODE method must be 'BDF' or 'Adams', got {method!r}")
        self.rtol, self.atol = positive("rtol", rtol), tolerance("atol", atol)
        self.max_step, self.method = positive("max_step", max_step, inf=True), method
        self.scan = positive("scan", scan)
        self.name = "cvode"

    #: the core takes the points CVODE returns (log times, crossings, the stop) as its steps
    returns_points = True

    def stepper(self):
        """CVODE for the stepping core (:mod:`hybridsim.engine.cvode_stepper`)."""
        from hybridsim.engine.cvode_stepper import CVodeStepper, cvode_ops  # it imports this module

        return cvode_ops(), CVodeStepper(self)

    def __repr__(self):
        return f"CVode({self.method}, rtol={self.rtol:g})"
