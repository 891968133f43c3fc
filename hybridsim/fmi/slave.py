"""The Python side of an exported FMU: what its pythonfmu / pythonfmu3 slave class calls.

The FMU's ``resources/diagram/`` folder holds the diagram files and
``hybridsim_export.json`` (its interface, written by :mod:`hybridsim.fmi.export`).
At exitInitializationMode the diagram is built with the parameters set, then
every doStep advances it with :class:`~hybridsim.fmi.runtime.DiagramStepper`.
"""
import json
from pathlib import Path

import numpy as np

INTERFACE = "hybridsim_export.json"


def element_names(name, width):
    """FMI variable names of a port: ``name`` for width 1, else ``name[1]`` .. ``name[width]``."""
    return [name] if width == 1 else [f"{name}[{k}]" for k in range(1, width + 1)]


class Engine:
    """Registers the FMU's variables on ``slave`` and runs the diagram behind them.

    Parameters
    ----------
    slave : pythonfmu.Fmi2Slave or pythonfmu3.Fmi3Slave
    fmi : int
        2 or 3.
    """

    def __init__(self, slave, fmi):
        self.slave, self.fmi = slave, fmi
        self.folder = Path(slave.resources) / "diagram"
        self.spec = json.loads((self.folder / INTERFACE).read_text())
        self.inputs = {name: np.array(start, float) for name, width, start in self.spec["inputs"]}
        self.params = {name: value for name, value in self.spec["params"]}
        self.spec_params = dict(self.params)  # as exported (a whole number an int)
        self.stepper, self.provisional = None, False
        self._register()

    # -- variables -----------------------------------------------------------------
    def _register(self):
        if self.fmi == 2:
            from pythonfmu import Boolean, Fmi2Causality as C, Fmi2Variability as V, Integer, Real, String

            kinds = {"input": (C.input, V.continuous), "output": (C.output, V.continuous),
                     "parameter": (C.parameter, V.fixed)}

            def var(typ, name, kind, getter, setter=None):
                c, v = kinds[kind]
                cls = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}[typ]
                return cls(name, causality=c, variability=v, getter=getter, setter=setter)
        else:
            from pythonfmu3 import Boolean, Fmi3Causality as C, Fmi3Variability as V, Float64, Int64, String

            kinds = {"input": (C.input, V.continuous), "output": (C.output, V.continuous),
                     "parameter": (C.parameter, V.fixed)}

            def var(typ, name, kind, getter, setter=None):
                c, v = kinds[kind]
                cls = {"Real": Float64, "Integer": Int64, "Boolean": Boolean, "String": String}[typ]
                if typ == "Real" and kind == "output":
                    v = V.continuous
                return cls(name, causality=c, variability=v, getter=getter, setter=setter,
                           start=None if kind == "output" else getter())

        reg = self.slave.register_variable
        if self.fmi == 3:  # FMI 3.0 wants its independent variable declared
            reg(Float64("time", causality=C.independent, variability=V.continuous,
                        getter=lambda: self.stepper.t if self.stepper is not None else 0.0))
        for name, width, _ in self.spec["inputs"]:
            for k, el in enumerate(element_names(name, width)):
                reg(var("Real", el, "input", self._input_getter(name, k), self._input_setter(name, k)))
        offset = 0
        for name, _ref, width in self.spec["outputs"]:
            for k, el in enumerate(element_names(name, width)):
                reg(var("Real", el, "output", self._output_getter(offset + k)))
            offset += width
        for name, value in self.spec["params"]:
            if isinstance(value, list):
                for k in range(len(value)):  # a list: name[1] .. name[n], whatever its length
                    el = f"{name}[{k + 1}]"
                    reg(var("Real", el, "parameter", self._param_getter(name, k), self._param_setter(name, k)))
            else:
                # a number is Real, a whole one too (Kp: 2 set to 2.5 by the importer); a whole value
                # reaches the diagram as an int again (a width, a count): see _param_setter
                typ = "Boolean" if isinstance(value, bool) else "String" if isinstance(value, str) else "Real"
                reg(var(typ, name, "parameter", self._param_getter(name), self._param_setter(name)))

    def _input_getter(self, name, k):
        return lambda: float(self.inputs[name][k])

    def _input_setter(self, name, k):
        def setter(value):
            self.inputs[name][k] = value
            if self.stepper is not None:
                self.stepper.set_input("in_" + name, self.inputs[name])
        return setter

    def _output_getter(self, k):
        def getter():
            if self.stepper is None:  # initialization mode: built with the parameters set so far
                self.start()
                self.provisional = True
            return float(self.stepper.outputs()[k])
        return getter

    def _param_getter(self, name, k=None):
        def scalar():
            v = self.params[name]
            return v if isinstance(v, (str, bool)) else float(v)
        return scalar if k is None else (lambda: float(self.params[name][k]))

    def _param_setter(self, name, k=None):
        def setter(value):
            if self.stepper is not None and not self.provisional:  # built at exitInitializationMode
                raise ValueError(f"parameter {name} is fixed: set it before exitInitializationMode")
            if self.stepper is not None:  # outputs read in initialization mode: built again
                self.stepper.release()
                self.stepper, self.provisional = None, False
            if k is None:
                whole = isinstance(self.spec_params[name], int) and not isinstance(value, bool)
                self.params[name] = int(value) if whole and float(value).is_integer() else value
            else:
                self.params[name] = list(self.params[name])
                self.params[name][k] = float(value)
        return setter

    # -- running ---------------------------------------------------------------------
    def start(self):
        """Build the diagram with the parameters set (exitInitializationMode, or an output read
        in initialization mode)."""
        from hybridsim.format import build as api
        from hybridsim.fmi.runtime import DiagramStepper

        if self.provisional:  # built for an output read in initialization mode, parameters as now
            self.provisional = False
            return

        try:
            _, sim, settings = api.build(self.folder / self.spec["diagram"], **self.params)
            self._check_dependencies(sim.system)
            self.stepper = DiagramStepper(sim, {"in_" + n: v for n, v in self.inputs.items()},
                                          [ref for _, ref, _ in self.spec["outputs"]])
        except Exception as exc:
            self._log(f"cannot build the diagram: {exc}")
            raise

    def _check_dependencies(self, system):
        """Refuse parameters under which an output depends on an input the model description does
        not declare (a lag's tau set to 0 passes its input through): an importer trusting the
        declaration would order its evaluation wrong."""
        from hybridsim.errors import FMUError
        from hybridsim.fmi.runtime import fed_by

        declared = self.spec.get("depends")
        if declared is None:
            return
        fed = {f"in_{n}": n for n, _, _ in self.spec["inputs"]}
        for name, ref, _ in self.spec["outputs"]:
            extra = fed_by(system, ref, fed) - set(declared.get(name, ()))
            if extra:
                raise FMUError(f"with these parameters output {name} depends directly on input(s) "
                               f"{', '.join(sorted(extra))}, which the FMU does not declare: export the "
                               "diagram with these parameter values")

    def step(self, t, h):
        """doStep: advance by ``h`` from ``t``; False (FMI 2) or terminateSimulation (FMI 3) on a stop."""
        from hybridsim.errors import StopRequest

        try:
            self.stepper.step(t, h)
            stopped = False
        except StopRequest as stop:
            self._log(f"block {stop.block!r} ended the run at t={stop.t:.9g} s ({stop.reason})", error=False)
            stopped = True
        except Exception as exc:
            self._log(f"doStep at t={t:.9g} s failed: {exc}")
            raise
        if self.fmi == 2:
            return not stopped
        from pythonfmu3 import Fmi3StepResult

        return Fmi3StepResult(terminateSimulation=stopped)

    def _log(self, message, error=True):
        if self.fmi == 2:
            from pythonfmu.enums import Fmi2Status as S
        else:
            from pythonfmu3.enums import Fmi3Status as S
        self.slave.log(message, S.error if error else S.warning)

    def release(self):
        """terminate: free what the diagram's blocks hold."""
        if self.stepper is not None:
            self.stepper.release()
