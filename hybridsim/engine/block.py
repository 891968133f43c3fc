"""The block API: what a block declares and the functions it implements.

A block is a pure description plus functions of ``(t, x, u)``; it never holds
the numbers of a run (those live in a :class:`~hybridsim.engine.context.Context`) and
never reaches into another block. In its ``__init__`` a block declares

* input ports and output ports with fixed widths (``declare_input``,
  ``declare_output``), and for each output which inputs it depends on directly
  (direct feedthrough; the default is "all of them");
* either continuous state (``declare_continuous_state``) with per-state
  absolute tolerances, or a sample period (``declare_rate``) and optionally
  discrete state (``declare_discrete_state``);
* ``time_varying = True`` if its outputs depend on ``t`` itself (sources).

and implements some of (or gives them as pure ``kernels``, see
:mod:`hybridsim.engine.kernels`)

* ``output(t, x, u)`` -> sequence of arrays, one per output port;
* ``derivatives(t, x, u)`` -> array (continuous state);
* ``update(t, x, u)`` -> array (discrete state, called at each sample hit
  after all outputs of that hit are computed);
* ``initial_state(u)`` -> array; ``u`` holds the inputs at t=0 when the block
  sets ``init_needs_inputs = True`` (e.g. a pre-loaded spring whose direction
  depends on another block's state);
* ``zero_crossings(t, x, u)`` -> array whose sign changes mark
  discontinuities (friction stick/slip, contact make/break), with
  ``event_directions`` (per function: +1 fires rising, -1 falling, 0 both);
* ``event_action(t, x, u, fired)`` -> the block's state right after its
  events ``fired`` (a state event with a reset, x+ = h(x-, u): a bounce, a
  latch); every solver locates such events and restarts after the reset;
* ``next_event_time(t, x)`` -> the next time after ``t`` at which the block
  needs a stop (a time event; ``event_action`` then runs with ``fired = ()``);
* ``release()``: free outside resources when a run ends (FMU instances).

``u`` is a list of numpy arrays in input declaration order, ``x`` a numpy
array (a view of the diagram's state vector for continuous blocks).
"""
import functools
from fractions import Fraction

import numpy as np

from hybridsim.errors import ParameterError, RateError

#: the widest port a block may declare
MAX_WIDTH = 10_000


def port_width(width, param="width"):
    """``width`` as a port width: a whole number 1..MAX_WIDTH, else ParameterError."""
    ok = not isinstance(width, bool) and (isinstance(width, (int, np.integer)) or (
        isinstance(width, float) and width.is_integer()))
    if not ok or not 1 <= int(width) <= MAX_WIDTH:
        raise ParameterError(param, f"must be a whole number of elements from 1 to {MAX_WIDTH}, "
                                    f"got {width!r}")
    return int(width)


class Port:
    """A named, fixed-width input or output of a block (an input may have a ``default``:
    the value it takes when no wire drives it)."""

    __slots__ = ("block", "name", "width", "index", "depends_on", "default", "optional")

    def __init__(self, block, name, width, index, depends_on=None, default=None, optional=False):
        self.block, self.name, self.width, self.index = block, name, width, index
        self.depends_on = depends_on
        self.default = default
        self.optional = optional

    def __repr__(self):
        return f"{self.block.name}.{self.name}"


def to_period(value, what="period"):
    """Return a sample period as an exact Fraction of a second.

    Periods given as floats (``0.016666...``) are snapped to the nearest
    fraction with a denominator below 10**7 when that is within 1e-12 s, so
    that ``1/60`` is exactly one sixtieth. Rates in Hz should go through
    :func:`rate_to_period`, which is exact for integer and decimal rates.
    """
    try:
        if isinstance(value, Fraction):
            period = value
        elif isinstance(value, str):
            period = Fraction(value)
        else:
            v = float(value)
            if not np.isfinite(v):
                raise ValueError
            period = Fraction(v).limit_denominator(10**7)
            if abs(float(period) - v) > 1e-12 and 0.0 < v < 1e-3:  # a tiny period: the inverse of a rate
                period = Fraction(1, max(1, round(1.0 / v)))
            if abs(float(period) - v) > min(1e-12, 1e-9 * abs(v)):
                raise RateError(
                    f"{what} {value!r} s is not a ratio of small integers; "
                    "give the rate in Hz (rate: 60) or the period as a fraction ('1/60')"
                )
    except (ValueError, TypeError, ZeroDivisionError):
        raise RateError(f"{what} {value!r} is not a number") from None
    if period <= 0:
        raise RateError(f"{what} must be positive, got {value!r}")
    return period


def rate_to_period(rate_hz):
    """Exact period (Fraction, s) of a sample rate in Hz (int, float or str): a decimal rate as written,
    one that is the float nearest a ratio of small integers (``1000 / 3``) as that ratio."""
    try:
        r = Fraction(str(rate_hz)) if not isinstance(rate_hz, Fraction) else rate_hz
        small = r.limit_denominator(10**6)
        if small != r and float(small) == float(r):  # 333.3333333333333 is 1000/3
            r = small
    except (ValueError, ZeroDivisionError, OverflowError):
        raise RateError(f"rate {rate_hz!r} is not a number") from None
    if r <= 0:
        raise RateError(f"rate must be positive, got {rate_hz!r} Hz")
    return 1 / r


@functools.lru_cache(maxsize=None)
def _init_parameters(cls):
    """The parameters of ``cls.__init__`` (read once per class)."""
    import inspect

    return inspect.signature(cls.__init__).parameters


class Block:
    """Base class of every block. See the module docstring for the contract."""

    #: outputs depend on t itself (sources); otherwise only on x and u
    time_varying = False
    #: initial_state wants the inputs at t = 0
    init_needs_inputs = False
    #: the simulator records every input of this block (a scope / recorder)
    log_inputs = False
    #: the block's outputs may be NaN or infinite (else such an output stops the run)
    may_be_nonfinite = False
    #: why a linearization by differences would not see this block's dynamics (its memory changes
    #: only at events: a delay's buffer), or None; analysis refuses such a diagram with this reason
    not_linearizable = None
    #: ``max_state`` bounds the discrete states (see :meth:`declare_discrete_state`)
    discrete_bounded = True
    #: per continuous state: ``max_state`` bounds it (see :meth:`declare_continuous_state`); None: all
    continuous_bounded = None
    #: per continuous state: held between events (see :meth:`declare_continuous_state`); None: none
    continuous_held = None
    #: per discrete state: a memory of the block's logic (see :meth:`declare_discrete_state`); None: none
    discrete_held = None
    #: the block's equations as pure functions f(p, t, x, u) (hybridsim.engine.kernels);
    #: the methods below call them with ``params``. Blocks with kernels run on
    #: the fused and compiled paths as well as the generic one.
    kernels = None
    #: the numbers the kernels read (a tuple or namedtuple, set in __init__)
    params = ()

    def __init_subclass__(cls, **kwargs):
        """Record the arguments each block is built with, so :meth:`with_params` can rebuild it."""
        super().__init_subclass__(**kwargs)
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        @functools.wraps(init)
        def recording_init(self, *args, **kw):
            if "_init_args" not in self.__dict__:  # the outermost constructor's arguments
                self._init_args = (args, dict(kw))
            init(self, *args, **kw)

        cls.__init__ = recording_init

    def __init__(self, name="block"):
        self.name = name
        self.inputs = []
        self.outputs = []
        self.n_continuous = 0
        self.n_discrete = 0
        self.atol = None
        self.period = None
        self.time_offset = Fraction(0)

    # -- declarations ---------------------------------------------------
    def declare_input(self, name, width, default=None, optional=False):
        """Add an input port of ``width`` elements; returns its index.

        ``default``: the values the input takes when no wire drives it (an FMU
        input's start values); without one an unwired input is an error.
        ``optional``: leaving it unwired is the usual case (an integrator's
        reset), so the loader says nothing about it.
        """
        width = port_width(width)
        if default is not None:
            default = tuple(float(v) for v in np.broadcast_to(np.asarray(default, float), (width,)))
        self.inputs.append(Port(self, name, width, len(self.inputs), default=default, optional=optional))
        return len(self.inputs) - 1

    def declare_output(self, name, width, depends_on=None):
        """Add an output port.

        ``depends_on``: names of the inputs this output depends on directly;
        ``None`` means all inputs, ``()`` means none (a state-only output).
        """
        dep = None if depends_on is None else tuple(depends_on)
        self.outputs.append(Port(self, name, port_width(width), len(self.outputs), dep))
        return len(self.outputs) - 1

    def declare_continuous_state(self, n, atol=None, bounded=True, held=False):
        """Declare ``n`` continuous states; ``atol`` per state (or scalar). ``bounded`` (per state or
        scalar): ``max_state`` bounds them (False for states that grow by design: a count, a time).
        A state that is not finite stops the run either way. ``held`` (per state or scalar): the
        state's derivative is 0 and only the block's event actions change it (a mode, a count, a
        time of the last event); a linearization holds it, it is no dynamics."""
        self.n_continuous = port_width(n, "states") if n else 0
        if atol is not None:
            self.atol = np.broadcast_to(np.asarray(atol, float), (n,)).copy()
        self.continuous_bounded = np.broadcast_to(np.asarray(bounded, bool), (self.n_continuous,)).copy()
        self.continuous_held = np.broadcast_to(np.asarray(held, bool), (self.n_continuous,)).copy()

    def declare_rate(self, period=None, rate=None, offset=0):
        """Make the block discrete: sampled every ``period`` s (or ``rate`` Hz)."""
        if rate is not None and period is not None:
            raise RateError("give rate (Hz) or period (s), not both")
        if rate is None and period is None:
            raise RateError("needs a rate (Hz) or a period (s)")
        self.period = rate_to_period(rate) if rate is not None else to_period(period)
        self.time_offset = Fraction(0) if not offset else to_period(offset, "offset")
        if self.time_offset >= self.period:
            raise RateError(
                f"block {self.name!r}: offset {float(self.time_offset)} s must be "
                f"smaller than its period {float(self.period)} s"
            )

    def declare_discrete_state(self, n, bounded=True, held=False):
        """Declare ``n`` discrete states (needs a rate). ``bounded``: ``max_state`` bounds them
        (False for states that grow by design: a count of samples, a time). ``held`` (per state or
        scalar): a memory of the block's logic, no dynamics (a count, the last tick's mode, a time);
        a linearization holds it."""
        self.n_discrete = port_width(n, "states") if n else 0
        self.discrete_bounded = bool(bounded)
        self.discrete_held = np.broadcast_to(np.asarray(held, bool), (self.n_discrete,)).copy()

    # -- parameters at run time -------------------------------------------------
    def linear_standin(self):
        """A block with the same ports that analysis linearizes in this one's place (a transport
        delay's Pade approximation), or None: this block itself."""
        return None

    def with_params(self, **changes):
        """This block rebuilt with some constructor parameters changed.

        The copy must keep the block's structure (ports and their widths,
        states, rate, kernels): only its numbers (``params``, initial state)
        may differ, so it can replace this block in a built system for one
        run. Raises :class:`~hybridsim.errors.ParameterError` otherwise.
        """
        args, kwargs = self.__dict__.get("_init_args", ((), {"name": self.name}))
        sig = _init_parameters(type(self))
        known = [p for p in sig if p not in ("self", "name")]
        open_ended = any(p.kind is p.VAR_KEYWORD for p in sig.values())  # it takes any keyword
        for key in changes:
            if key not in known and not open_ended:
                hint = (f"a run-time value is the whole parameter: give {key.split('[')[0]!r} whole" if "[" in key
                        else f"its parameters: {', '.join(known)}")
                raise ParameterError(key, f"is not a parameter of block {self.name!r} ({self.type_label}); {hint}")
        try:
            new = type(self)(*args, **{**kwargs, **changes})
        except TypeError as exc:
            raise ParameterError(next(iter(changes), "?"), f"cannot be set on block {self.name!r}: {exc}") from None
        except ValueError as exc:
            if isinstance(exc, ParameterError):
                raise
            raise ParameterError(next(iter(changes), "?"), f"on block {self.name!r}: {exc}") from None
        if new.structure() != self.structure():
            raise ParameterError(", ".join(changes), f"would change the structure of block {self.name!r} "
                                 "(ports, states, rate or equations); rebuild the diagram for that")
        return new

    def structure(self):
        """What a built system depends on: type, ports, states, rate and kernels."""
        ports = lambda ps: tuple((p.name, p.width, p.depends_on) for p in ps)  # noqa: E731
        return (type(self), ports(self.inputs), ports(self.outputs), self.n_continuous, self.n_discrete,
                self.period, self.time_offset, self.time_varying, self.kernels)

    # -- queries ------------------------------------------------------------
    @property
    def type_label(self):
        """The block's type as a file writes it (``transfer_function``), else its class name."""
        return getattr(type(self), "type_name", type(self).__name__)

    @property
    def is_discrete(self):
        return self.period is not None

    def feedthrough(self, out_index):
        """Indices of the inputs that output ``out_index`` depends on directly."""
        dep = self.outputs[out_index].depends_on
        if dep is None:
            return list(range(len(self.inputs)))
        names = {p.name: p.index for p in self.inputs}
        return [names[d] for d in dep]

    def input_port(self, name):
        """The input port named ``name`` (a :class:`Port`), or None."""
        return next((p for p in self.inputs if p.name == name), None)

    def output_port(self, name):
        """The output port named ``name`` (a :class:`Port`), or None."""
        return next((p for p in self.outputs if p.name == name), None)

    # -- computations (override) --------------------------------------------
    def output(self, t, x, u):
        """Outputs at time ``t`` (s) from state ``x`` and inputs ``u``: one sequence per output port."""
        k = self.kernels
        if k is not None and k.output_into is not None:
            return k.output_into(self.params, t, x, u, tuple(np.empty(p.width) for p in self.outputs))
        return k.output(self.params, t, x, u) if k is not None and k.output else ()

    def derivatives(self, t, x, u):
        """dx/dt of the continuous states at ``t`` (s), as a sequence of floats."""
        k = self.kernels
        if k is not None and k.derivatives:
            return k.derivatives(self.params, t, x, u)
        return np.zeros(self.n_continuous)

    def update(self, t, x, u):
        """The discrete state after the sample hit at ``t`` (s) (default: unchanged)."""
        k = self.kernels
        if k is not None and k.update_into is not None:
            return k.update_into(self.params, t, x, u, np.empty(self.n_discrete))
        return k.update(self.params, t, x, u) if k is not None and k.update else x

    def initial_state(self, u=None):
        """The state at t = 0 (default zeros); ``u`` the initial inputs when known."""
        return np.zeros(self.n_continuous or self.n_discrete)

    #: per zero-crossing function: +1 fires when it rises through 0, -1 when it falls, 0 both
    event_directions = None
    #: what to do when the state slides along this block's switch (a run stopped there says it),
    #: or None: the engine's general advice
    sliding_advice = None
    #: the time between this block's regular events (s), when it makes them (a run is warned of many)
    event_spacing = None

    def zero_crossings(self, t, x, u):
        """The block's event functions at ``t`` (a sequence of floats), or None without events."""
        k = self.kernels
        return k.zero_crossings(self.params, t, x, u) if k is not None and k.zero_crossings else None

    def event_action(self, t, x, u, fired):
        """The state right after the events ``fired`` (None: no reset, only a restart)."""
        k = self.kernels
        return k.event_action(self.params, t, x, u, fired) if k is not None and k.event_action else None

    def next_event_time(self, t, x):
        """The next time after ``t`` (s) at which this block needs a stop; inf for none."""
        return float("inf")

    @property
    def has_zero_crossings(self):
        """True when the block gives event functions (a method or a kernel)."""
        k = self.kernels
        return type(self).zero_crossings is not Block.zero_crossings or (k is not None and k.zero_crossings is not None)

    @property
    def has_event_action(self):
        """True when the block resets its state at its events."""
        k = self.kernels
        return type(self).event_action is not Block.event_action or (k is not None and k.event_action is not None)

    @property
    def has_time_events(self):
        """True when the block asks for stops at times of its own."""
        return type(self).next_event_time is not Block.next_event_time

    #: ``after_step(t, x, u) -> bool``, when a block defines it: called after every accepted
    #: integrator step with the state there; True asks for a step event at ``t`` (its
    #: ``event_action`` runs with no functions fired). None: the block needs no such call.
    after_step = None

    @property
    def has_after_step(self):
        """True when the block is to be told of every accepted integrator step."""
        return self.after_step is not None

    def release(self):
        """Free outside resources (an FMU instance, files) when a run ends."""

    def __repr__(self):
        return f"<{type(self).__name__} {self.name!r}>"
