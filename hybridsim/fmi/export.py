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
for the inputs set at ``t`` (direct feedthrough, as within a diagram).
"""
import json
import os
import re
import shutil
import tempfile
import uuid
from pathlib import Path

from hybridsim.errors import FMUError, InputError, LoaderError
from hybridsim.fmi.slave import INTERFACE

WRAPPER = "hybridsim_fmu.yaml"

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


def _files(path, seen=None):
    """The diagram file, every file it extends and every subsystem file it uses, resolved."""
    from hybridsim.format.diagram_file import DiagramFile
    from hybridsim.format.values import _is_subsystem, subsystem_path

    seen = [] if seen is None else seen
    f = DiagramFile(path)
    for p in f.files or [Path(path).resolve()]:
        if Path(p).resolve() not in seen:
            seen.append(Path(p).resolve())
    for spec in (f.data.get("blocks") or {}).values():
        if _is_subsystem(spec):
            sub = subsystem_path(spec, Path(path).parent).resolve()
            if sub not in seen:
                _files(sub, seen)
        elif isinstance(spec, dict) and spec.get("type") == "fmu":
            raise FMUError(f"{path}: block type fmu inside an exported diagram is not supported "
                           "(its FMU file would have to travel with it)")
    return f, seen


def _ports(f):
    """(inputs, outputs) of subsystem file ``f``: [(name, width, start)], [(name, 'sub.port', width)]."""
    from hybridsim.engine.diagram import Diagram

    d = Diagram(f.name, source=str(f.path))
    f.aliases, f._cut, f._broken, f._bad_ports = {}, set(), set(), set()
    ins, outs = f._expand(d, dict(f.params), "", (f.path.resolve(),), "")
    if d.problems:  # each names its file and line
        raise InputError("; ".join(d.problems[:3]))
    inputs = []
    for name, refs in ins.items():
        b, p = refs[0].rsplit(".", 1)
        inputs.append((name, d.blocks[b].input_port(p).width, [0.0] * d.blocks[b].input_port(p).width))
    outputs = []
    for name, ref in outs.items():
        b, p = ref.rsplit(".", 1)
        outputs.append((name, f"sub.{name}", d.blocks[b].output_port(p).width))
    return inputs, outputs


def _param_value(name, value, where):
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, list) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                 for v in value):
        return [float(v) for v in value]
    raise FMUError(f"{where}: parameter {name!r} = {value!r} cannot be an FMU parameter "
                   "(numbers, Booleans, text and lists of numbers can)")


def _blank_section(path, key):
    """Blank the lines of top-level ``key`` in the YAML file ``path`` (the other lines keep their numbers)."""
    import yaml

    text = path.read_text()
    try:
        node = yaml.compose(text)
    except yaml.YAMLError:
        return  # the build that follows says what is wrong
    if not isinstance(node, yaml.MappingNode):
        return
    lines = text.splitlines(keepends=True)
    for k, v in node.value:
        if k.value == key:
            first, last = k.start_mark.line, v.end_mark.line - (v.end_mark.column == 0)
            for n in range(first, min(last, len(lines) - 1) + 1):
                lines[n] = "\n"
    path.write_text("".join(lines))


def _unstaged(message, stage, root):
    """``message`` with the staged copies' paths as the user's files (the wrapper's own place dropped)."""
    wrapper = re.escape(str(stage / WRAPPER)) + r"(:\d+)?"
    message = re.sub(wrapper + r": (in subsystem 'sub': )?", "", message)
    message = re.sub(r"in subsystem sub \(" + wrapper + r"\): ", "", message)
    return message.replace(str(stage) + os.sep, str(root) + os.sep)


def _identifier(name):
    ident = re.sub(r"\W", "_", name)
    return ident if ident and not ident[0].isdigit() else "m_" + ident


def _finish(built, out, fmi):
    """Copy the FMU to ``out``, listing the outputs as InitialUnknowns (FMI 2.0; pythonfmu leaves them out)."""
    import xml.etree.ElementTree as ET
    import zipfile

    from hybridsim.files import atomic_file

    with zipfile.ZipFile(built) as src, atomic_file(out, "wb") as fh, \
            zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml" and fmi == 2:
                root = ET.fromstring(data)
                structure = root.find("ModelStructure")
                outs = structure.find("Outputs")
                if outs is not None and structure.find("InitialUnknowns") is None:
                    init = ET.SubElement(structure, "InitialUnknowns")
                    for u in outs:
                        ET.SubElement(init, "Unknown", index=u.get("index"))
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
    if fmi not in (2, 3):
        raise FMUError(f"FMI version must be 2 or 3, got {fmi!r}")
    try:
        if fmi == 2:
            from pythonfmu import FmuBuilder
        else:
            from pythonfmu3 import FmuBuilder
    except ImportError:
        raise FMUError(f"exporting an FMI {fmi}.0 FMU needs {'pythonfmu' if fmi == 2 else 'pythonfmu3'}: "
                       f"pip install {'pythonfmu' if fmi == 2 else 'pythonfmu3'}") from None
    path = Path(diagram)
    f, files = _files(path)
    params = [(k, _param_value(k, v, path)) for k, v in f.params.items()]
    is_sub = bool(f.data.get("inputs") or f.data.get("outputs"))
    if is_sub:  # its simulation section becomes the wrapper's: checked here, in its own file and line
        f.check_section("simulation")
    root = Path(os.path.commonpath([p.parent for p in files]))
    main = path.resolve().relative_to(root).as_posix()
    cls = _identifier(name or f.name)
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="hybridsim-export-") as tmp:
        stage = Path(tmp) / "diagram"
        for p in files:
            dst = stage / p.relative_to(root)
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(p, dst)
        if is_sub:  # its simulation section (merged over what it extends) is the wrapper's
            for p in f.files:
                _blank_section(stage / Path(p).resolve().relative_to(root), "simulation")
            inputs, outputs = _ports(f)
            blocks = {f"in_{n}": {"type": "constant", "value": start} for n, _, start in inputs}
            blocks["sub"] = {"type": "subsystem", "file": main, **{k: f"${k}" for k, _ in params}}
            sim = {k: v for k, v in (f.data.get("simulation") or {}).items() if k != "t_end"}
            wrapper = {"name": f.name, "params": {k: v for k, v in params},
                       "blocks": blocks, "wires": [f"in_{n}.y -> sub.{n}" for n, _, _ in inputs],
                       "log": [ref for _, ref, _ in outputs]}
            if sim:
                wrapper["simulation"] = sim
            (stage / WRAPPER).write_text(json.dumps(wrapper, indent=1))  # JSON is YAML
            entry = WRAPPER
        else:
            inputs, entry = [], main
        try:
            _, sim_, settings = api.build(stage / entry, check_only=True)  # fails here, not in the FMU
        except InputError as exc:  # in the user's files' names
            raise InputError(_unstaged(str(exc), stage, root)) from None
        system = sim_.system
        if not is_sub:
            refs = list(settings["log"]) + list(settings["signals"].values())
            outputs = []
            for ref in dict.fromkeys(refs):
                i, o = system.port_ref(ref.split("[")[0])
                outputs.append((ref.split("[")[0].replace(".", "_"), ref.split("[")[0], system.blocks[i].outputs[o].width))
        else:
            outputs = [(n, r, w) for (n, _, w), r in zip(outputs, settings["log"])]
        (stage / INTERFACE).write_text(json.dumps({"diagram": entry, "inputs": inputs, "outputs": outputs,
                                                   "params": params, "source": str(path)}, indent=1))
        # the slave module's name is unique: the embedded interpreter of a process imports it once
        script = Path(tmp) / f"hybridsim_{cls}_fmi{fmi}_{uuid.uuid4().hex[:12]}.py"
        script.write_text(_SCRIPT.format(
            description=f.description or f.name, version=__version__, source=path.name, cls=cls, fmi=fmi,
            package="pythonfmu" if fmi == 2 else "pythonfmu3", base="Fmi2Slave" if fmi == 2 else "Fmi3Slave"))
        built = FmuBuilder.build_FMU(script, dest=tmp, project_files=[stage])
        out.parent.mkdir(parents=True, exist_ok=True)
        _finish(built, out, fmi)
    return out
