"""Export a diagram or a subsystem file as a Co-Simulation FMU (FMI 2.0 or 3.0).

The FMU wraps the diagram with pythonfmu (FMI 2.0) or pythonfmu3 (FMI 3.0):
its binary embeds the Python interpreter it finds at run time, which must
have hybridsim (and its dependencies) installed; the diagram's files travel in
the FMU's ``resources/diagram/``. Inside, the diagram runs with its own
solver, rates and events (:class:`~hybridsim.fmi.runtime.DiagramStepper`).

* A subsystem file (one with ``inputs:`` / ``outputs:``): its input ports are
  the FMU's inputs (held over a communication step), its output ports the
  FMU's outputs. A port of width n is n variables ``name[1]`` .. ``name[n]``.
* A closed diagram (no ``inputs:``): no inputs; its ``log`` and ``signals``
  are the outputs.
* The file's ``params`` are the FMU's parameters (variability fixed: set
  before exitInitializationMode, when the diagram is built); a list is
  ``name[1]`` .. ``name[n]``.

An output read at a communication point ``t`` is the diagram's output at ``t``
for the inputs set at ``t`` (direct feedthrough, as within a diagram), before
the events those inputs cause: a relay that an input set at ``t`` switches
shows its switch from the next communication point (within a diagram it
switches at ``t``); the step from ``t`` acts on them first.
"""
import json
import re
import tempfile
import uuid
from pathlib import Path

from hybridsim.errors import FMUError, InputError
from hybridsim.fmi.runtime import fed_by
from hybridsim.fmi.slave import INTERFACE
from hybridsim.format import standalone

_SCRIPT = '''"""{description} -- an FMU exported by hybridsim {version} from {source}.

Runs the diagram in resources/diagram/ with hybridsim: the Python that loads
this FMU must have hybridsim installed.
"""
from {package} import {base}

from hybridsim.fmi.slave import Engine


class {cls}({base}):
    author = "hybridsim"
    description = {description!r}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.description = {description!r}
        self.engine = Engine(self, {fmi})

    def exit_initialization_mode(self):
        self.engine.start()

    def do_step(self, current_time, step_size):
        return self.engine.step(current_time, step_size)

    def terminate(self):
        self.engine.release()
'''


def _no_fmu_blocks(paths):
    """Refuse an fmu block in any of the diagram files ``paths`` (its FMU file would not travel)."""
    from hybridsim.format.diagram_file import DiagramFile

    from hybridsim.errors import LoaderError

    for p in paths:
        f = DiagramFile(p)
        for name, spec in (f.data.get("blocks") or {}).items():
            if isinstance(spec, dict) and spec.get("type") == "fmu":
                raise LoaderError(f"block {name!r}: block type fmu inside an exported diagram is not supported "
                                  "(its FMU file would have to travel with it)", f._locs("blocks").get(name, p))


def _param_value(name, value, f):
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, list) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                 for v in value):
        return [float(v) for v in value]
    from hybridsim.errors import LoaderError

    raise LoaderError(f"parameter {name!r} = {value!r} cannot be an FMU parameter "
                      "(numbers, Booleans, text and lists of numbers can)", f._locs("params").get(name, f.path))


def _unique_names(f, inputs, outputs, params, fmi, path):
    """Refuse two FMU variables of one name (a parameter and a port, or FMI 3.0's ``time``), at the line
    of the second; an importer refuses such an FMU."""
    from hybridsim.errors import LoaderError

    seen = {"time": "FMI 3.0's independent variable"} if fmi == 3 else {}
    named = ([(n, "parameter", "params") for n, _ in params] + [(n, "input", "inputs") for n, _, _ in inputs]
             + [(n, "output", "outputs") for n, _, _ in outputs])
    for name, kind, section in named:
        if name in seen:
            where = (f._locs(section).get(name) or (f._locs().get("log") if kind == "output" else None)
                     or str(path))  # a closed diagram's outputs: its log
            raise LoaderError(f"{kind} {name!r} would be an FMU variable of the same name as {seen[name]}: "
                              "rename one", where)
        seen[name] = f"{kind} {name!r}"


def _identifier(name):
    ident = re.sub(r"\W", "_", name)
    return ident if ident and not ident[0].isdigit() else "m_" + ident


def _port_of(name):
    """The port of FMI variable ``name`` (``q[2]`` -> ``q``)."""
    return name.split("[")[0]


def _declare(root, fmi, depends):
    """Declare in ``root`` (modelDescription.xml) each output's inputs (``depends``: port -> input
    ports), the outputs as FMI 2.0's InitialUnknowns and FMI 3.0's variable communication steps
    (pythonfmu and pythonfmu3 leave them out or write them wrong)."""
    import xml.etree.ElementTree as ET

    variables = list(root.find("ModelVariables"))
    port = lambda v: _port_of(v.get("name"))  # noqa: E731
    structure = root.find("ModelStructure")
    if fmi == 2:
        index = {v.get("name"): str(k + 1) for k, v in enumerate(variables)}
        ins = [v for v in variables if v.get("causality") == "input"]
        outs = structure.find("Outputs")
        for u in outs if outs is not None else []:
            name = variables[int(u.get("index")) - 1].get("name")
            u.set("dependencies", " ".join(index[v.get("name")] for v in ins if port(v) in depends[_port_of(name)]))
        if outs is not None and structure.find("InitialUnknowns") is None:
            init = ET.SubElement(structure, "InitialUnknowns")
            for u in outs:
                ET.SubElement(init, "Unknown", index=u.get("index"))
        return
    root.find("CoSimulation").set("canHandleVariableCommunicationStepSize", "true")
    by_ref = {v.get("valueReference"): v for v in variables}
    ins = [v for v in variables if v.get("causality") == "input"]
    for u in structure.findall("Output"):
        name = by_ref[u.get("valueReference")].get("name")
        u.set("dependencies", " ".join(v.get("valueReference") for v in ins if port(v) in depends[_port_of(name)]))


def _finish(built, out, fmi, depends):
    """Copy the FMU to ``out`` with its model description completed (:func:`_declare`)."""
    import xml.etree.ElementTree as ET
    import zipfile

    from hybridsim.files import atomic_file

    with zipfile.ZipFile(built) as src, atomic_file(out, "wb") as fh, \
            zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                root = ET.fromstring(data)
                _declare(root, fmi, depends)
                data = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
            dst.writestr(item, data)


def export_fmu(diagram, out, fmi=2, name=None):
    """Write ``diagram`` (a subsystem or a closed diagram file) as a Co-Simulation FMU at ``out``.

    Parameters
    ----------
    diagram : path-like
        The YAML diagram file.
    out : path-like
        The ``.fmu`` to write (checked first: a folder, an unknown suffix or no permission is refused).
    fmi : {2, 3}
        FMI version (pythonfmu for 2.0, pythonfmu3 for 3.0).
    name : str, optional
        The model identifier (default: the diagram's name, made a C identifier).

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    from hybridsim.version import __version__
    from hybridsim.format import build as api
    from hybridsim.files import check_output_file

    check_output_file(out, ["fmu"])  # a path that cannot be written is refused before anything is built
    if isinstance(fmi, bool) or fmi not in (2, 3):
        raise InputError(f"FMI version must be 2 or 3, got {fmi!r}")
    try:
        if fmi == 2:
            from pythonfmu import FmuBuilder
        else:
            from pythonfmu3 import FmuBuilder
    except ImportError:
        raise FMUError(f"exporting an FMI {fmi}.0 FMU needs {'pythonfmu' if fmi == 2 else 'pythonfmu3'}: "
                       f"pip install {'pythonfmu' if fmi == 2 else 'pythonfmu3'}") from None
    path = Path(diagram)
    f, _ = standalone.files(path)
    params = [(k, _param_value(k, v, f)) for k, v in f.params.items()]
    own = [k for k, _ in params if k in standalone.OWN_KEYS and standalone.is_subsystem(f)]
    if own:  # the FMU's parameter would set nothing
        from hybridsim.errors import LoaderError

        raise LoaderError(f"parameter {own[0]!r} cannot be an FMU parameter of a subsystem ('type' and 'file' are "
                          "the subsystem block's own keys, so nothing passes it in): rename it",
                          f._locs("params").get(own[0], path))
    if f.data.get("variants"):  # one FMU is one variant: the parameters as they are
        import logging

        logging.getLogger("hybridsim").warning(
            "%s: its 'variants' are not exported: the FMU runs the parameters as they are (%s), which "
            "its importer may set", path, ", ".join(f"{k}={dict(params).get(k)}" for k in f.data["variants"]))
    cls = _identifier(name or f.name)
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="hybridsim-export-") as tmp:
        staged = standalone.Staged(path, Path(tmp) / "diagram", params)
        _no_fmu_blocks(staged.paths)
        stage, entry, is_sub = staged.stage, staged.entry, staged.subsystem
        inputs, outputs = staged.inputs, staged.outputs
        _, sim_, settings = staged.build()  # fails here, not in the FMU
        system = sim_.system
        if not is_sub:
            refs = list(settings["log"]) + list(settings["signals"].values())
            outputs = []
            for port in dict.fromkeys(str(r).split("[")[0] for r in refs):  # a port once, however many elements named
                i, o = system.port_ref(port)
                outputs.append((port.replace(".", "_"), port, system.blocks[i].outputs[o].width))
        else:
            outputs = [(n, r, w) for (n, _, w), r in zip(outputs, settings["log"])]
        if not outputs:  # an FMU of no output: FMI 2.0's has no variable at all, which importers refuse
            raise InputError(f"{path}: nothing to export: the diagram has no outputs (a subsystem's "
                             "'outputs:', or a closed diagram's 'log' or 'signals' are the FMU's outputs)")
        _unique_names(f, inputs, outputs, params, fmi, path)
        fed = {f"in_{n}": n for n, _, _ in inputs}
        depends = {n: fed_by(system, ref, fed) for n, ref, _ in outputs}
        (stage / INTERFACE).write_text(json.dumps({"diagram": entry, "inputs": inputs, "outputs": outputs,
                                                   "params": params, "source": str(path),
                                                   "depends": {n: sorted(d) for n, d in depends.items()}},
                                                  indent=1))
        # the slave module's name is unique: the embedded interpreter of a process imports it once
        script = Path(tmp) / f"hybridsim_{cls}_fmi{fmi}_{uuid.uuid4().hex[:12]}.py"
        script.write_text(_SCRIPT.format(
            description=f.description or f.name, version=__version__, source=path.name, cls=cls, fmi=fmi,
            package="pythonfmu" if fmi == 2 else "pythonfmu3", base="Fmi2Slave" if fmi == 2 else "Fmi3Slave"))
        built = FmuBuilder.build_FMU(script, dest=tmp, project_files=[stage])
        out.parent.mkdir(parents=True, exist_ok=True)
        _finish(built, out, fmi, depends)
    return out
