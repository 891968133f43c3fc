"""Model Exchange through the FMI event protocol, for :class:`hybridsim.fmi.fmu_block.FMUBlock`.

Continuous-time mode between events (states and inputs set, derivatives and
event indicators read), event mode at state and time events and when a
discrete-time input changes (the newDiscreteStates / updateDiscreteStates
iteration). An FMU without continuous states has one dummy state of zero
derivative on the hybridsim side (``nx == 0``): it is never sent to the FMU.
"""
import ctypes

import numpy as np

from hybridsim.errors import FMUError, StopRequest
from hybridsim.fmi.calls import BoundCalls, error


def _raise(exc):
    """Raise ``exc`` (a call for :meth:`FMUBlock._call`, which adds the FMU's own words)."""
    raise exc


class ModelExchange:
    """The Model Exchange half of :class:`hybridsim.fmi.fmu_block.FMUBlock` (a mixin: it uses the block's
    ``_fmu``, ``_call``, ``_set_inputs``, ``nx``, ``nz`` and ``in_discrete``)."""

    _sent_state = None  # (t, states) last given to the instance; None: set them again
    _calls = None  # the instance's bound calls (hybridsim.fmi.calls)

    def _discrete_inputs(self, t, x, u):
        """Model Exchange: discrete-time inputs that changed enter the FMU through event mode."""
        values = np.concatenate(u)[self.in_discrete]
        if self._last_discrete is not None and np.array_equal(values, self._last_discrete):
            return
        self._last_discrete = values.copy()
        self._sent_state = None  # event mode: set the time and states again after it
        fmu = self._fmu
        self._call(f"enterEventMode at t={t:.9g}", fmu.enterEventMode)
        self._set_inputs(u, only=set(self.in_discrete))
        if self._event_update(t):
            raise FMUError(f"FMU block {self.name!r} changed its continuous states at t={t:.9g} s when a "
                           "discrete input changed; hybridsim cannot take that from an input yet")
        self._call("enterContinuousTimeMode", fmu.enterContinuousTimeMode)

    def _me_set(self, t, x, u):
        """Time, continuous states and inputs into the FMU; the time and states only when they
        differ from the last ones set (a right-hand side sets them for the outputs and again for
        the derivatives), the inputs only when they differ from the last ones set."""
        key = (t, (x if type(x) is np.ndarray else np.asarray(x, dtype=float)).tobytes())
        if key != self._sent_state:
            self._sent_state = None
            failed = (self._calls or self._bind_calls()).set_state(t, x)
            if failed is not None:
                what = f"setTime({t:.9g})" if "SetTime" in failed[0] else f"setContinuousStates at t={t:.9g}"
                self._call(what, _raise, error(*failed))
            self._sent_state = key
        if self.in_vars:
            try:
                same = b"".join([a.tobytes() for a in u]) == self._inputs_set
            except AttributeError:  # not arrays: _set_inputs compares them
                same = False
            if not same:
                self._set_inputs(u)

    def _bind_calls(self):
        """Bind the continuous-time FMI functions and output getters of the current instance
        (once per instance)."""
        self._calls = BoundCalls(self._fmu, self.fmi3, self.nx, self.nz, self.out_types)
        self._port_bounds = list(zip(self.cuts[:-1].tolist(), self.cuts[1:].tolist()))
        return self._calls

    def _me_outputs(self):
        """The outputs, one port after the other, through the bound getters."""
        vals = (self._calls or self._bind_calls()).outputs(np.zeros(self.n_out), self._outputs_failed)
        return tuple([vals[a:b] for a, b in self._port_bounds])

    def _outputs_failed(self, typ, exc):
        self._call(f"get {typ} outputs", _raise, exc)

    def derivatives(self, t, x, u):
        """The FMU's state derivatives at (t, x, u) (zero for the dummy state)."""
        self._me_set(t, x, u)
        if not self.nx:
            return np.zeros(1)  # the dummy state
        calls = self._calls
        status = calls.get_dx()
        if status > 1:
            self._call("get derivatives", _raise, calls.failure("get_dx", status))
        return calls.dx.copy()

    # -- Model Exchange events (FMI 2.0 and 3.0) -----------------------------------
    @property
    def has_event_action(self):
        """A Model Exchange FMU with event indicators: its events go through event mode."""
        return self.mode == "me" and self.nz > 0

    @property
    def has_time_events(self):
        """A Model Exchange FMU may announce time events (nextEventTime)."""
        return self.mode == "me"

    @property
    def has_after_step(self):
        """A Model Exchange FMU is told of every accepted step (completedIntegratorStep) unless
        its model description says it need not be (FMI 2.0 ``completedIntegratorStepNotNeeded``,
        FMI 3.0 without ``needsCompletedIntegratorStep``)."""
        return self.mode == "me" and self.needs_completed_step

    def after_step(self, t, x, u):
        """completedIntegratorStep at the end of an accepted step (states and inputs set first);
        returns whether the FMU asks for event mode there (a step event)."""
        self._me_set(t, x, u)
        enter, terminate = self._call(f"completedIntegratorStep at t={t:.9g}",
                                      self._fmu.completedIntegratorStep)
        if terminate:
            raise StopRequest(t, self.name, "terminateSimulation")
        return bool(enter)

    def _event_update(self, t):
        """The newDiscreteStates / updateDiscreteStates loop of event mode; returns whether the
        continuous states changed. Remembers the next time event."""
        update = self._fmu.updateDiscreteStates if self.fmi3 else self._fmu.newDiscreteStates
        changed = False
        for _ in range(100):
            need, terminate, _nominals, values, time_defined, t_next = self._call(
                f"{'updateDiscreteStates' if self.fmi3 else 'newDiscreteStates'} at t={t:.9g}", update)
            changed |= bool(values)
            self._next_event = float(t_next) if time_defined else np.inf
            if terminate:
                raise StopRequest(t, self.name, "terminateSimulation")
            if not need:
                return changed
        raise FMUError(f"FMU block {self.name!r}: the event iteration at t={t:.9g} s does not settle "
                       "(newDiscreteStatesNeeded after 100 updates)")

    def next_event_time(self, t, x):
        """The FMU's next time event (nextEventTime), or inf."""
        return getattr(self, "_next_event", np.inf)

    def event_action(self, t, x, u, fired):
        """Event mode at a state or time event: update the discrete states, read back the
        continuous ones if the FMU changed them, back to continuous-time mode."""
        self._me_set(t, x, u)
        fmu = self._fmu
        self._sent_state = None  # the event may change the FMU's states: set them again after it
        self._call(f"enterEventMode at t={t:.9g}", fmu.enterEventMode)
        changed = self._event_update(t)
        self._call("enterContinuousTimeMode", fmu.enterContinuousTimeMode)
        if not changed or not self.nx:
            return None
        x_new = np.zeros(self.nx)
        self._call("getContinuousStates", fmu.getContinuousStates,
                   x_new.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), self.nx)
        return x_new

    def zero_crossings(self, t, x, u):
        """The FMU's event indicators at (t, x, u) (none in Co-Simulation); an indicator at exactly
        0 is returned as -1e-300: FMI's domains are z > 0 and z <= 0 (FMI 2.0 section 3.1, 3.0
        section 3.1.1), so a z that an event left at 0 and that then goes negative is no event."""
        if self.mode != "me" or not self.nz:
            return np.zeros(0)
        self._me_set(t, x, u)
        calls = self._calls
        status = calls.get_z()
        if status > 1:
            self._call("getEventIndicators", _raise, calls.failure("get_z", status))
        return np.where(calls.z == 0.0, -1e-300, calls.z)
