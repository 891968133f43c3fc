"""Linearize a diagram about an operating point; the exact sampled-data loop.

A built system splits into the continuous part ``xc' = f(xc, h)`` (``h``: the held
outputs of discrete and piecewise-constant blocks) and the *tick pass* at each
sample hit, a function of ``s = (xc, xd, yd)`` (continuous and discrete states,
held discrete outputs). Both are linearized by central differences
(:mod:`.jacobians`, checked against a step four times smaller); between hits the
continuous part is discretized exactly by zero-order hold, and the product over
the hits of one hyperperiod is the closed loop lifted to it - exact for any mix
of rates. States whose columns vanish are dropped (only zero eigenvalues go).

A loop opened at a signal (an analysis point) replaces its value at the hits by
an input ``v`` and measures what the diagram computes there, ``y``; the loop
transfer is ``L = -y/v`` (closed loop ``1/(1+L)``). A diagram with nothing sampled
is the continuous system ``xc' = A xc`` with continuous loops ``L(s)``. Sources are
frozen at the operating time; nonsmooth blocks are linearized on the branch the
operating point lies on (choose it with overrides). docs/stability.md has the method.
"""
import math

import control
import numpy as np

from hybridsim.errors import LinearizationError
from hybridsim.analysis.jacobians import checked_jacobian, nonzero_columns, zoh
from hybridsim.analysis.lti import ContinuousModel, DiscreteModel
from hybridsim.analysis.standins import linear_standins
from hybridsim.engine.result import parse_signal


def start_outputs(system, ctx, t=0.0):
    """Compute a fresh context's outputs as a run's first hit does (before any update), so the
    held values - constants, the controller's first output - are those of the operating point."""
    sched = system.schedule
    due = {system.discrete[j] for j in sched.due(0)} if sched.ticks else set()
    system.plan.outputs(ctx, t, ctx.xc, due)


def hidden_state(blocks):
    """Why ``blocks`` cannot be linearized by differences, each named with its reason (a block's
    ``not_linearizable``: a Co-Simulation FMU keeps its state inside, a transport delay its dead time
    in a buffer sampled at events); or None."""
    hidden = [b.name for b in blocks if getattr(b, "hidden_state", False)]
    other = [(b.name, b.not_linearizable) for b in blocks if getattr(b, "not_linearizable", None)]
    why = []
    if hidden:
        why.append(f"block(s) {', '.join(map(repr, hidden))} keep their state inside (a Co-Simulation FMU), "
                   "where no linearization can reach it; linearize the same model with its states in the "
                   "diagram (a Model Exchange FMU, or the blocks themselves)")
    why += [f"block {name!r} {reason}" for name, reason in other]
    return "; ".join(why) or None


class Linearization:
    """Linear models of a system about the state held in ``context`` at time ``t``.

    Parameters
    ----------
    system : System
    context : Context, optional
        The operating point (default: the system's initial state, which the
        shipped diagrams set to a static equilibrium, with the outputs of a
        run's first hit: see :func:`start_outputs`).
    t : float
        Time at which time-varying sources are frozen.
    rel_step : float
        Finite-difference step relative to each variable's magnitude.
    """

    def __init__(self, system, context=None, t=0.0, rel_step=1e-6):
        system, context = linear_standins(system, context)
        self.system = system
        fresh = context is None
        self.ctx = context or system.create_context()
        self.t = float(t)
        if fresh:
            start_outputs(system, self.ctx, self.t)
        self.rel_step = rel_step
        sysm = system
        self.n_x = sysm.n_x
        self.disc = sysm.discrete
        self.xd_sizes = [sysm.blocks[i].n_discrete for i in self.disc]
        self.yd_ports = [(i, o) for i in self.disc for o in range(len(sysm.blocks[i].outputs))]
        self.h_ports = sysm.plan.held_ports()
        self.held = sysm.x_held  # modes and counts: held at their operating values, dropped from the models
        self.xd_held = np.concatenate([np.zeros(n, bool) if getattr(sysm.blocks[i], "discrete_held", None) is None
                                       else sysm.blocks[i].discrete_held for i, n in zip(self.disc, self.xd_sizes)]
                                      ) if self.disc else np.zeros(0, bool)
        self.fd_error = 0.0
        hidden = hidden_state(sysm.blocks)
        if hidden:
            raise LinearizationError(hidden)
        self._save()

    # -- packing -----------------------------------------------------------------
    def _save(self):
        c = self.ctx
        self.xc0 = c.xc.copy()
        self.xd0 = np.concatenate([c.xd[i] for i in self.disc]) if self.disc else np.zeros(0)
        self.yd0 = np.concatenate([c.y[i][o] for i, o in self.yd_ports]) if self.yd_ports else np.zeros(0)
        self.h0 = self._read(self.h_ports)
        with np.errstate(invalid="ignore"):  # the magnitude of the signals: what rounding is relative to
            vals = np.abs(np.concatenate([c.ywire, c.xc, self.xd0]))
        self.size = float(np.max(vals[np.isfinite(vals)], initial=0.0))

    def _read(self, ports):
        y = self.ctx.y
        return np.concatenate([y[i][o] for i, o in ports]) if ports else np.zeros(0)

    def _write(self, ports, vec):
        k = 0
        for i, o in ports:
            buf = self.ctx.y[i][o]
            buf[:] = vec[k:k + buf.size]
            k += buf.size

    def _set_xd(self, xd):
        k = 0
        for i, n in zip(self.disc, self.xd_sizes):
            self.ctx.xd[i] = xd[k:k + n].copy()
            k += n

    def _pin(self, x):
        """``x`` with the held states (modes, counts) at their operating values: their columns are 0."""
        if self.held.any():
            x = x.copy()
            x[self.held] = self.xc0[self.held]
        return x

    def _kept(self, whole=False):
        """Which entries of xc (``whole``: of s = (xc, xd, yd)) a model keeps: all but the held states."""
        if not whole:
            return ~self.held
        return np.concatenate([~self.held, ~self.xd_held, np.ones(self.yd0.size, bool)])

    def _steps(self, v, floor):
        return self.rel_step * np.maximum(np.abs(v), floor)

    def _floor_x(self):
        """The smallest difference step base of each continuous state: 1e4 x its absolute tolerance."""
        return np.maximum(np.where(np.isnan(self.system.atol), 1e-9, self.system.atol) * 1e4, 1e-9)

    def state_names(self):
        """Names of the entries of s = (xc, xd, yd)."""
        sysm = self.system
        names = [f"{sysm.state_owner(k)[0]}.x[{sysm.state_owner(k)[1]}]" for k in range(self.n_x)]
        for i, n in zip(self.disc, self.xd_sizes):
            names += [f"{sysm.blocks[i].name}.xd[{j}]" for j in range(n)]
        for i, o in self.yd_ports:
            p = sysm.blocks[i].outputs[o]
            names += [f"{sysm.blocks[i].name}.{p.name}[{j}]" for j in range(p.width)]
        return names

    # -- continuous part ----------------------------------------------------------
    def _rhs(self):
        from hybridsim.engine.glue import state_derivatives

        return state_derivatives(self.system, self.ctx)

    def continuous(self):
        """(A, B): xc' = A dxc + B dh about the operating point; h = held inputs."""
        rhs = self._rhs()
        t = self.t
        floor_x = self._floor_x()

        def fx(x):
            self._write(self.h_ports, self.h0)
            return rhs(t, self._pin(x))

        def fh(h):
            self._write(self.h_ports, h)
            return rhs(t, self.xc0.copy())

        A, e1 = checked_jacobian(fx, self.xc0.copy(), self._steps(self.xc0, floor_x), size=self.size)
        B, e2 = checked_jacobian(fh, self.h0.copy(), self._steps(self.h0, 1e-3), size=self.size)
        self._write(self.h_ports, self.h0)
        self.fd_error = max(self.fd_error, e1, e2)
        return A, B

    def plant(self, outputs):
        """Continuous plant from the held inputs to signals ``outputs`` (python-control ss)."""
        A, B = self.continuous()
        C, D = self._output_maps(outputs)
        return control.ss(A, B, C, D)

    def _output_maps(self, outputs):
        sysm = self.system
        refs = [parse_signal(r) for r in outputs]
        ports = [self._port(r, "output")[:2] for r in outputs]
        path = sysm.evaluation_path({i for i, _ in ports})

        def measure():
            vals = []
            for (i, o), (_, el) in zip(ports, refs):
                v = self.ctx.y[i][o]
                vals.extend(v if el is None else [v[el]])
            return np.array(vals, float)

        def gx(x):
            self._write(self.h_ports, self.h0)
            self.ctx.evaluate(path, self.t, self._pin(x))
            return measure()

        def gh(h):
            self._write(self.h_ports, h)
            self.ctx.evaluate(path, self.t, self.xc0)
            return measure()

        C, e1 = checked_jacobian(gx, self.xc0.copy(), self._steps(self.xc0, self._floor_x()), size=self.size)
        D, e2 = checked_jacobian(gh, self.h0.copy(), self._steps(self.h0, 1e-3), size=self.size)
        self._write(self.h_ports, self.h0)
        self.fd_error = max(self.fd_error, e1, e2)
        return C, D

    # -- the tick pass --------------------------------------------------------------
    def _tick_pass(self, s, due, inject=None, v=None, measure=None):
        """(h, xd+, yd+, y) after one pass from state s = (xc, xd, yd).

        ``inject`` = (block, output, element, mode): after that block computes
        its output, the element is replaced by (mode 'replace') or increased
        by (mode 'add') ``v``. ``measure`` = (block, output, element): the value
        computed there is returned as ``y`` (before any injection).
        """
        sysm, ctx, t = self.system, self.ctx, self.t
        nx, nd = self.n_x, self.xd0.size
        xc, xd, yd = self._pin(s[:nx]), s[nx:nx + nd].copy(), s[nx + nd:]
        xd[self.xd_held] = self.xd0[self.xd_held]  # a memory of the logic (a count, the last mode): held
        self._set_xd(xd)
        self._write(self.yd_ports, yd)
        y_meas = []

        def after(i):  # the plan's hit, with the loop opened at one signal
            if measure is not None and i == measure[0]:
                y_meas.append(np.array([ctx.y[i][measure[1]][measure[2]]]))
            if inject is not None and i == inject[0]:
                buf = ctx.y[i][inject[1]]
                buf[inject[2]] = v[0] if inject[3] == "replace" else buf[inject[2]] + v[0]

        sysm.plan.outputs(ctx, t, xc, due, after)
        y_meas = y_meas[0] if y_meas else None
        h = self._read(self.h_ports)
        updated = dict(sysm.plan.updates(ctx, t, due))
        xd_new = [updated[i] if i in updated else ctx.xd[i].copy() for i in self.disc]
        xd_new = np.concatenate(xd_new) if xd_new else np.zeros(0)
        yd_new = self._read(self.yd_ports)
        return h, xd_new, yd_new, y_meas

    def _hits(self):
        """[(due block indices, interval to next hit in s)] over one hyperperiod."""
        sched = self.system.schedule
        if not sched.ticks:
            raise LinearizationError("the diagram has no discrete block: nothing is sampled")
        H = 1
        for p, _ in sched.ticks:
            H = H * p // math.gcd(H, p)
        hits = [n for n in range(H) if sched.due(n)]
        out = []
        for k, n in enumerate(hits):
            n_next = hits[k + 1] if k + 1 < len(hits) else H + hits[0]
            due = {self.disc[j] for j in sched.due(n)}
            out.append((due, float((n_next - n) * sched.base)))
        return out, float(H * sched.base)

    def _state0(self):
        return np.concatenate([self.xc0, self.xd0, self.yd0])

    def _pass_matrices(self, due, inject=None, measure=None):
        """Linearized pass: [h; xd+; yd+ (; y)] = P [s (; v)]."""
        s0 = self._state0()
        floor = np.concatenate([self._floor_x(),
                                np.full(self.xd0.size + self.yd0.size, 1e-3)])
        v0 = np.zeros(1)
        if inject is not None and inject[3] == "replace":
            self._tick_pass(s0.copy(), due)  # the value computed at the operating point
            v0 = np.array([self.ctx.y[inject[0]][inject[1]][inject[2]]])
        io = inject is not None

        def fun(z):
            s, v = z[:s0.size], z[s0.size:]
            h, xd, yd, y = self._tick_pass(s.copy(), due, inject, v if io else None, measure)
            return np.concatenate([h, xd, yd] + ([y] if measure is not None else []))

        z0 = np.concatenate([s0, v0]) if io else s0
        steps = self._steps(z0, np.concatenate([floor, [1e-3]]) if io else floor)
        P, err = checked_jacobian(fun, z0, steps, size=self.size)
        self.fd_error = max(self.fd_error, err)
        self._restore()
        return P

    def _restore(self):
        self.ctx.xc = self.xc0.copy()
        self._set_xd(self.xd0)
        self._write(self.yd_ports, self.yd0)
        self._write(self.h_ports, self.h0)

    def _step_matrix(self, P, A, B, tau, n_in=0, Bv=None):
        """Rows of P -> one hit plus the held interval: s+ = M s (+ N v); ``Bv``: xc' = ... + Bv v
        where v also enters the right-hand side (held over the interval)."""
        nx, nh = self.n_x, self.h0.size
        ns = self._state0().size
        Phi, Gam = zoh(A, B if Bv is None else np.hstack([B, Bv]), tau)
        Ph = P[:nh]
        Pd = P[nh:nh + (ns - nx)]
        M = np.zeros((ns, ns + n_in))
        M[:nx, :] = Gam[:, :nh] @ Ph
        M[:nx, :nx] += Phi
        if Bv is not None:
            M[:nx, ns:] += Gam[:, nh:]
        M[nx:, :] = Pd
        return M[:, :ns], M[:, ns:]

    def _read_continuously(self, i):
        """Whether block ``i``'s output is computed along the plant's right-hand side."""
        return self.system.kind[i] not in ("discrete", "constant") and i in set(self.system.rhs_path)

    @property
    def sampled(self):
        """Whether the diagram has a sampled (discrete) block; else it is linearized in continuous time."""
        return bool(self.system.schedule.ticks)

    def closed_loop(self):
        """The lifted closed loop: a :class:`DiscreteModel` over one hyperperiod, or, for a
        diagram with nothing sampled, the :class:`ContinuousModel` ``xc' = A xc``."""
        A, B = self.continuous()
        if not self.sampled:
            k = self._kept()
            return ContinuousModel(A[np.ix_(k, k)], [n for n, x in zip(self.state_names(), k) if x], self.fd_error)
        hits, H = self._hits()
        ns = self._state0().size
        M = np.eye(ns)
        for due, tau in hits:
            P = self._pass_matrices(due)
            Mk, _ = self._step_matrix(P, A, B, tau)
            M = Mk @ M
        keep = nonzero_columns(M, ~self._kept(whole=True))
        names = [n for n, k in zip(self.state_names(), keep) if k]
        return DiscreteModel(M[np.ix_(keep, keep)], H, names, self.fd_error)

    def _port(self, signal, what):
        """(block, output, element) of ``signal`` ('block.port[i]'); LinearizationError naming it."""
        try:
            base, el = parse_signal(signal)
            i, o = self.system.port_ref(base)
        except (KeyError, AttributeError, ValueError):
            raise LinearizationError(f"{what} {signal!r}: no such output") from None
        width = self.system.blocks[i].outputs[o].width
        if el is not None and not 0 <= el < width:
            raise LinearizationError(f"{what} {signal!r}: {base} has {width} element(s), [0] to [{width - 1}]")
        return i, o, 0 if el is None else el

    def _single_rate_model(self, inject, measure):
        """Discrete ss from v (at ``inject``) to y (at ``measure``), one servo period."""
        hits, H = self._hits()
        if len(hits) != 1:
            raise LinearizationError(
                "loop openings and input/output models need a single-rate loop; this diagram "
                "is multi-rate (its closed-loop poles are still exact, lifted to the hyperperiod)")
        A, B = self.continuous()
        due, tau = hits[0]
        P = self._pass_matrices(due, inject, measure)
        ns = self._state0().size
        Bv = None
        if self._read_continuously(inject[0]):  # an input added along the interval too, held
            Bv = self._continuous_model(inject, inject[:3]).B
        M, N = self._step_matrix(P[:-1], A, B, tau, n_in=1, Bv=Bv)
        Cy, Dy = P[-1:, :ns], P[-1:, ns:]
        keep = nonzero_columns(np.vstack([M, Cy]), ~self._kept(whole=True))
        return control.ss(M[np.ix_(keep, keep)], N[keep], Cy[:, keep], Dy, H)

    def loop(self, signal):
        """Discrete loop transfer L(z) opened at ``signal`` ('block.port[i]').

        The signal must be one that only the sampled controller reads (not the
        plant's right-hand side). L = -y/v: closing the loop is 1/(1 + L).
        """
        i, o, el = self._port(signal, "analysis point")
        if not self.sampled:
            return -self._continuous_model((i, o, el, "replace"), (i, o, el))
        if self._read_continuously(i):
            raise LinearizationError(
                f"analysis point {signal!r} is read continuously by the plant; open a loop at a "
                "signal that is only sampled (a controller input or output)")
        return -self._single_rate_model((i, o, el, "replace"), (i, o, el))

    def io(self, input_signal, output_signal):
        """Closed-loop discrete model from an additive input at ``input_signal``
        (e.g. a command, 'force_cmd.y[0]') to ``output_signal`` sampled at the hits."""
        i, o, el = self._port(input_signal, "input")
        j, p, em = self._port(output_signal, "output")
        if not self.sampled:
            return self._continuous_model((i, o, el, "add"), (j, p, em))
        return self._single_rate_model((i, o, el, "add"), (j, p, em))

    def _continuous_model(self, inject, measure):
        """Continuous ss from v (at ``inject``) to y (at ``measure``), nothing sampled:
        xc' = A xc + B v, y = C xc + D v, the right-hand side evaluated with the signal
        at ``inject`` replaced by (or increased by) v; y is read before any injection."""
        sysm, ctx, t = self.system, self.ctx, self.t
        blocks, n = ctx.blocks, self.n_x
        path = sorted(set(sysm.rhs_path) | set(sysm.evaluation_path({measure[0]})))
        kept = ctx.y[inject[0]][inject[1]].copy()  # restored after (a held block is not re-evaluated)

        def apply(v):
            buf = ctx.y[inject[0]][inject[1]]
            buf[inject[2]] = v[0] if inject[3] == "replace" else buf[inject[2]] + v[0]

        def fun(z, injecting=True):
            x, v = self._pin(z[:n]), z[n:]
            self._write(self.h_ports, self.h0)
            if inject[0] not in path:  # a held signal: its operating value, then v
                ctx.y[inject[0]][inject[1]][:] = kept
                if injecting:
                    apply(v)
            y = None
            for i in path:
                for buf, val in zip(ctx.y[i], blocks[i].output(t, ctx.block_state(i, x), ctx.u[i])):
                    buf[:] = val
                if i == measure[0]:
                    y = ctx.y[i][measure[1]][measure[2]]
                if injecting and i == inject[0]:
                    apply(v)
            if y is None:  # a held signal
                y = ctx.y[measure[0]][measure[1]][measure[2]]
            dx = np.empty(n)
            for i in sysm.stateful:
                dx[sysm.xslices[i]] = blocks[i].derivatives(t, x[sysm.xslices[i]], ctx.u[i])
            return np.concatenate([dx, [y]])

        v0 = np.zeros(1)
        if inject[3] == "replace":  # the value computed at the operating point
            fun(np.concatenate([self.xc0, v0]), injecting=False)
            v0 = np.array([ctx.y[inject[0]][inject[1]][inject[2]]])
        z0 = np.concatenate([self.xc0, v0])
        floor = np.concatenate([self._floor_x(), [1e-3]])
        J, err = checked_jacobian(fun, z0, self._steps(z0, floor), size=self.size)
        self.fd_error = max(self.fd_error, err)
        ctx.y[inject[0]][inject[1]][:] = kept
        self._write(self.h_ports, self.h0)
        k = self._kept()
        return control.ss(J[:n, :n][np.ix_(k, k)], J[:n, n:][k], J[n:, :n][:, k], J[n:, n:])
