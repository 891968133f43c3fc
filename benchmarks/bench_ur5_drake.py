"""UR5 press-and-trace (diagrams/ur5_press_and_trace.yaml, 2 s) in hybridsim and in Drake, in one run.

The same robot (example-robot-data's UR5 URDF), the same wrist sensor and tool (the ft_sensor
block's states and law), the same table (the plane_contact law: a linear
unilateral spring-damper with smoothed Coulomb friction) and the same controller (the
hybrid_control_6d, task_phases and gravity_torque blocks, called at 500 Hz) run in:

* hybridsim: the diagram on its generic, fused and compiled paths;
* Drake: a continuous MultibodyPlant (pydrake, its own rigid-body code) integrated by Drake's
  Simulator with a fixed-step RK2 or the error-controlled RK3; the sensor's tool (continuous
  states) and the table in a LeafSystem whose pull is applied to the flange body, the controller a
  LeafSystem with a 500 Hz periodic update.

Default: speed. Each run's CPU time (``time.process_time``, median of --repeat; the integration
only: building the diagram, Drake's system and the compiled loop's first compile are outside it,
the compile time is printed apart) at the same method and step: Heun's method (Drake's RK2 is the
same explicit trapezoid) at 0.25 ms, and the diagram's own RK4 at 0.25 ms against real time; with
the ratios to Drake's RK2 of the same process, the load average and the largest difference of the
C-Z force between the paths. ``--accuracy``: each run against a converged run of itself (hybridsim:
RK4 at a tenth of the step; Drake: RK3 at accuracy 1e-9), the force over the trace phase in % of
the 10 N command. Run on demand:

    python benchmarks/bench_ur5_drake.py [--repeat 3] [--accuracy]

Needs the robots extra, numba and pydrake (`pip install -e ".[robots,fast]" drake`).
"""
import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path[:0] = [str(Path(__file__).resolve().parents[1]), str(Path(__file__).resolve().parent)]
import hybridsim as hs  # noqa: E402
from hybridsim.blocks.robot.arm import urdf_path  # noqa: E402

DIAGRAM = Path(__file__).resolve().parents[1] / "diagrams" / "ur5_press_and_trace.yaml"
T_END = 2.0


def run_hybridsim(step=None, solver=None, fused=False):
    """(wall s, t, C-Z force, phase) of the diagram on hybridsim's generic (or fused) path."""
    ov = {"step": step} if step else {}
    if solver:
        ov["solver"] = solver
    t0 = time.perf_counter()
    r = hs.simulate(DIAGRAM, t_end=T_END, fused=fused, **ov)
    wall = time.perf_counter() - t0
    return wall, r.t, r["hybrid.F_C"][:, 2], r["phases.phase"][:, 0]


def hybridsim_runner(path, solver):
    """A function that runs the diagram once on ``path`` (generic, fused, compiled) with ``solver``
    and returns (CPU s, result); built (and, compiled, compiled and run once) before it is timed.
    Also returns the seconds the build took (the compile, for the compiled path)."""
    flags = {"generic": dict(fused=False), "fused": dict(fused=True), "compiled": dict(compiled=True)}[path]
    t0 = time.perf_counter()
    _, sim, _ = hs.build(DIAGRAM, solver=solver, **flags)
    if path == "compiled":
        sim.run(0.002)
    built = time.perf_counter() - t0

    def once():
        c0 = time.process_time()
        res = sim.run(T_END)
        return time.process_time() - c0, res

    return once, built


def _blocks():
    """The diagram's controller, table and kinematics blocks, as the diagram builds them."""
    diagram, _ = hs.load(DIAGRAM).build()
    return {name: diagram.blocks[name] for name in ("arm", "kin", "ft", "table", "gravity", "phases", "hybrid")}


def run_drake(integrator="runge_kutta2", step=2.5e-4, accuracy=None):
    """(CPU s, t, C-Z force, phase) of the same robot, table and controller in Drake."""
    from pydrake.common.value import AbstractValue
    from pydrake.multibody.math import SpatialForce
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
    from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem

    b = _blocks()
    arm, kin, ft, table, gravity, phases, hybrid = (b[k] for k in ("arm", "kin", "ft", "table", "gravity", "phases", "hybrid"))
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(0.0))
    Parser(plant).AddModels(str(urdf_path(robot="ur5")))
    plant.Finalize()
    tool = plant.GetFrameByName("tool0")
    n = plant.num_positions()
    damping = arm.b

    def pose_twist(q, v, ctx):
        plant.SetPositions(ctx, q)
        plant.SetVelocities(ctx, v)
        X = tool.CalcPoseInWorld(ctx)
        V = tool.CalcSpatialVelocityInWorld(ctx)
        return X.translation(), X.rotation().matrix(), np.concatenate([V.translational(), V.rotational()])

    class Tool(LeafSystem):
        """The wrist sensor's tool (ft_sensor: 9 continuous states) on the table (plane_contact); its
        pull on the flange applied to the tool body at the tool frame's origin."""

        def __init__(self):
            super().__init__()
            self.state = self.DeclareVectorInputPort("x", 2 * n)
            self.ctx = plant.CreateDefaultContext()
            self.DeclareContinuousState(ft.n_continuous)
            self.DeclareAbstractOutputPort("f", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
                                           self.calc_force)
            self.DeclareVectorOutputPort("F", BasicVector(6), self.calc_reading)

        def inputs(self, context):
            x = self.state.Eval(context)
            p, R, tw = pose_twist(x[:n], x[n:], self.ctx)
            z = context.get_continuous_state_vector().CopyToVector()
            pt, twt = ft.output(0.0, z, [p, R.ravel(), tw, np.zeros(6), np.zeros(1)])[1:3]
            env = table.output(0.0, None, [pt, twt])[0]
            return z, [p, R.ravel(), tw, env, np.zeros(1)]

        def DoCalcTimeDerivatives(self, context, derivatives):
            z, u = self.inputs(context)
            derivatives.get_mutable_vector().SetFromVector(ft.derivatives(0.0, z, u))

        def calc_force(self, context, out):
            z, u = self.inputs(context)
            w = ft.output(0.0, z, u)[0]
            f = ExternallyAppliedSpatialForce()
            f.body_index = tool.body().index()
            f.p_BoBq_B = tool.GetFixedPoseInBodyFrame().translation()
            f.F_Bq_W = SpatialForce(w[3:], w[:3])
            out.set_value([f])

        def calc_reading(self, context, out):
            z, u = self.inputs(context)
            out.SetFromVector(ft.output(0.0, z, u)[3])

    class Controller(LeafSystem):
        """task_phases + hybrid_control_6d + gravity_torque at 500 Hz, the torque held; damping continuous."""

        def __init__(self):
            super().__init__()
            self.state = self.DeclareVectorInputPort("x", 2 * n)
            self.reading = self.DeclareVectorInputPort("F", 6)
            self.ctx = plant.CreateDefaultContext()
            self.xs = self.DeclareDiscreteState(phases.n_discrete + hybrid.n_discrete + n)
            T = float(hybrid.period)
            self.DeclarePeriodicDiscreteUpdateEvent(T, 0.0, self.tick)
            self.DeclareVectorOutputPort("tau", BasicVector(n), self.torque)
            self.log = []

        def tick(self, context, discrete):
            x = self.state.Eval(context)
            z = discrete.get_mutable_vector().get_mutable_value()
            zp, zh = z[:phases.n_discrete].copy(), z[phases.n_discrete:-n].copy()
            if context.get_time() == 0.0:
                zp, zh = phases.initial_state(), hybrid.initial_state()
            q, v = x[:n], x[n:]
            p, R, tw = pose_twist(q, v, self.ctx)
            J = kin.output(0.0, None, [q, v])[3]
            F = self.reading.Eval(context)
            t = context.get_time()
            S, Xd, Xdd, Fd, ph = phases.output(t, zp, [p, R.ravel(), F])
            u = [p, R.ravel(), tw, J, F, Xd, Xdd, Fd, S, hybrid.inputs[9].default, gravity.output(0, None, [q])[0]]
            tau, FC = hybrid.output(t, zh, u)
            self.log.append((t, FC[2], ph[0]))
            z[:] = np.concatenate([phases.update(t, zp, [p, R.ravel(), F]), hybrid.update(t, zh, u), tau])

        def torque(self, context, out):
            x = self.state.Eval(context)
            out.SetFromVector(context.get_discrete_state_vector().value()[-n:] - damping * x[n:])

    tol, ctl = builder.AddSystem(Tool()), builder.AddSystem(Controller())
    builder.Connect(plant.get_state_output_port(), tol.state)
    builder.Connect(plant.get_state_output_port(), ctl.state)
    builder.Connect(tol.get_output_port(1), ctl.reading)
    builder.Connect(tol.get_output_port(0), plant.get_applied_spatial_force_input_port())
    builder.Connect(ctl.get_output_port(0), plant.get_actuation_input_port())
    system = builder.Build()
    sim = Simulator(system)
    ctx = sim.get_mutable_context()
    pctx = plant.GetMyMutableContextFromRoot(ctx)
    plant.SetPositions(pctx, arm.q0)
    p, R, tw = pose_twist(arm.q0, np.zeros(n), plant.CreateDefaultContext())
    tol.GetMyMutableContextFromRoot(ctx).SetContinuousState(ft.initial_state([p, R.ravel(), tw, np.zeros(6), np.zeros(1)]))
    ResetIntegratorFromFlags(sim, integrator, step)
    if accuracy:
        sim.get_mutable_integrator().set_target_accuracy(accuracy)
    else:
        sim.get_mutable_integrator().set_fixed_step_mode(True)
    sim.Initialize()
    t0 = time.process_time()
    sim.AdvanceTo(T_END)
    wall = time.process_time() - t0  # CPU s (Drake's Simulator runs in this thread)
    t, f, ph = (np.array(c) for c in zip(*ctl.log))
    return wall, t, f, ph


def trace_error(run, ref):
    """Largest |F - F_ref| (% of 10 N) over the trace phase, on the run's own controller ticks."""
    _, t, f, ph = run
    _, tr, fr, _ = ref
    m = ph == 2
    return float(np.max(np.abs(f[m] - np.interp(t[m], tr, fr))) / 10.0 * 100.0)


def speed(repeat):
    """CPU time of each path at Heun / RK2 and RK4 against Drake's RK2 in this process (see the module
    docstring); returns the text it printed."""
    load = os.getloadavg()
    rows, builds, results = {}, {}, {}
    for solver, method in (("heun", "Heun (RK2)"), ("rk4", "RK4")):
        for path in ("generic", "fused", "compiled"):
            once, built = hybridsim_runner(path, solver)
            runs = [once() for _ in range(repeat)]
            label = f"hybridsim {path}, {method} h = 0.25 ms"
            rows[label] = statistics.median(r[0] for r in runs)
            builds[label], results[(path, solver)] = built, runs[0][1]
    drake = [run_drake("runge_kutta2", 2.5e-4) for _ in range(repeat)]
    rows["Drake MultibodyPlant, RK2 h = 0.25 ms"] = dk = statistics.median(r[0] for r in drake)
    lines = [f"UR5 press and trace, {T_END:g} s simulated; CPU time of the integration, median of {repeat}; "
             f"load average {load[0]:.1f} before, {os.getloadavg()[0]:.1f} after (2 cores shared)", "",
             "| run | CPU (s) | Drake RK2 / this | real time / this |", "|---|---|---|---|"]
    for label, cpu in rows.items():
        lines.append(f"| {label} | {cpu:.3f} | {dk / cpu:.2f} | {T_END / cpu:.2f} |")
    for solver in ("heun", "rk4"):
        g = results[("generic", solver)]["hybrid.F_C"][:, 2]
        for path in ("fused", "compiled"):
            diff = np.max(np.abs(results[(path, solver)]["hybrid.F_C"][:, 2] - g))
            lines.append(f"\n{path} vs generic, {solver}: largest |C-Z force difference| {diff:.2g} N")
    comp = {k: v for k, v in builds.items() if "compiled" in k}
    lines.append("\ncompiled loop: built in " + ", ".join(f"{v:.1f} s ({k.split(', ')[1]})" for k, v in comp.items())
                 + " (numba's compile, or its cache's load when it holds the loop)")
    heun = results[("compiled", "heun")]
    _, t, f, ph = drake[0]
    m = ph == 2
    lines.append(f"compiled Heun vs Drake RK2 over the trace: largest |C-Z force difference| "
                 f"{np.max(np.abs(f[m] - np.interp(t[m], heun.t, heun['hybrid.F_C'][:, 2]))):.2g} N")
    text = "\n".join(lines)
    print(text)
    return text


def accuracy(repeat):
    """Each run's force over the trace against a converged run of itself (``--accuracy``)."""
    rows = []
    hs_ref = run_hybridsim(step=2.5e-5)
    dk_ref = run_drake("runge_kutta3", 1e-4, accuracy=1e-9)
    for label, fn, ref in (
            ("hybridsim, generic path, RK4 h = 0.25 ms", lambda: run_hybridsim(), hs_ref),
            ("hybridsim, generic path, Heun (RK2) h = 0.25 ms", lambda: run_hybridsim(solver="heun"), hs_ref),
            ("hybridsim, generic path, RK4 h = 0.5 ms", lambda: run_hybridsim(step=5e-4), hs_ref),
            ("Drake MultibodyPlant, RK2 h = 0.25 ms", lambda: run_drake("runge_kutta2", 2.5e-4), dk_ref),
            ("Drake MultibodyPlant, RK3 accuracy 1e-4", lambda: run_drake("runge_kutta3", 2.5e-4, 1e-4), dk_ref)):
        runs = [fn() for _ in range(repeat)]
        wall = statistics.median(r[0] for r in runs)
        rows.append((label, wall, trace_error(runs[0], ref), trace_error(runs[0], hs_ref)))
    base = rows[0][1]
    print(f"UR5 press and trace, {T_END:g} s simulated, median of {repeat} (hybridsim wall s, Drake CPU s)")
    print("| run | time (s) | / hybridsim | force vs its converged run (% of 10 N) | vs hybridsim's converged run (%) |")
    print("| --- | --- | --- | --- | --- |")
    for label, wall, err, cross in rows:
        print(f"| {label} | {wall:.2f} | {wall / base:.2f} | {err:.2g} | {cross:.2g} |")
    print(f"converged runs apart: {trace_error(dk_ref, hs_ref):.2g} % of 10 N over the trace")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--accuracy", action="store_true", help="each run against a converged run of itself")
    args = ap.parse_args(argv)
    return accuracy(args.repeat) if args.accuracy else speed(args.repeat)


if __name__ == "__main__":
    from results import recorded  # benchmarks/results.py: the dated section in RESULTS.md

    with recorded("UR5 press and trace: hybridsim's paths beside Drake" + (" (accuracy)" if "--accuracy" in sys.argv else "")):
        main()
