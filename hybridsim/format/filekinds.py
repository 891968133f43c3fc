"""What kind of file a user gave: a diagram, sweep or tune file by its keys, or another kind of
file altogether (a URDF, an FMU, a Simulink model, Python ...) by its content or name.

:func:`parse_file <hybridsim.format.yamlio.parse_file>` says what a file that is not YAML
is, where it belongs; :func:`file_kind` tells the three YAML files apart, misspelled keys
too, so each command can say which command runs a file of another kind.
"""
import difflib
import os
import re
import stat
import zipfile

from hybridsim.errors import LoaderError

#: a file of another kind given where a diagram is read (known by its content): what it is, what to do
NOT_YAML = {
    "urdf": "is a URDF robot description, not a diagram; name it in a robot block's 'urdf:' "
            "(robot_arm, robot_kinematics ...; see 'hybridsim blocks -v robot_arm')",
    "xml": "is XML or HTML, not a YAML diagram (a modelDescription.xml belongs inside an .fmu; "
           "an FMU is imported with an 'fmu' block's 'path:')",
    "zip": "is a zip archive (an FMU?), not a diagram; import an FMU with an 'fmu' block (its 'path:'), "
           "see 'hybridsim blocks -v fmu'",
    "slx": "is a Simulink model (.slx), not a diagram: hybridsim reads YAML diagrams (docs/diagram-format.md); "
           "a model Simulink exports as an FMU is imported with an 'fmu' block",
    "notebook": "is a Jupyter notebook, not a YAML diagram (diagrams, sweeps and tune files are YAML)",
}

#: what a text file that does not read as a YAML mapping probably is, by its suffix
SUFFIX_KINDS = {".py": "Python source", ".md": "Markdown", ".rst": "reStructuredText", ".toml": "TOML",
                ".ini": "an INI file", ".cfg": "a config file", ".csv": "CSV data", ".m": "MATLAB code",
                ".mdl": "a Simulink model", ".ipynb": "a Jupyter notebook", ".txt": "plain text"}

#: ... else by lines only that kind writes (a YAML file that fails to parse has none of them)
_CONTENT_KINDS = [
    ("Python source", re.compile(r"^(import \w|from [\w.]+ import |def \w+\(|class \w+[(:])", re.M)),
    ("TOML", re.compile(r"^\[[\w.\-\"]+\][ \t]*\n(?:[ \t]*#.*\n|[ \t]*\n)*[\w\-\"]+[ \t]*=", re.M)),
    ("a Simulink model", re.compile(r"\A\s*Model \{")),
]

#: the command that runs each kind of YAML file
COMMANDS = {"diagram": "run", "sweep": "sweep", "tune": "tune"}


def text_hint(path, text):
    """' (FILE looks like Python source, not YAML: ...)' for a file whose name or content shows another
    kind of text, else ''."""
    kind = SUFFIX_KINDS.get(os.path.splitext(str(path))[1].lower())
    kind = kind or next((k for k, pattern in _CONTENT_KINDS if pattern.search(text)), None)
    return (f" ({os.path.basename(str(path))} looks like {kind}, not YAML: diagrams, sweeps and tune files "
            "are YAML)" if kind else "")


def binary_kind(path):
    """The :data:`NOT_YAML` key of a regular file at ``path`` that is a zip archive ("slx" for a Simulink
    model), else None. A FIFO or device is not opened (it would wait for a writer)."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        with open(path, "rb") as fh:
            if fh.read(4) != b"PK\x03\x04":
                return None
    except OSError:
        return None
    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
    except (OSError, zipfile.BadZipFile):  # it begins as one: a zip archive cut short
        return "zip"
    return "slx" if any(n.startswith("simulink/") for n in names) else "zip"


def refuse_other(data, path):
    """LoaderError when a parsed mapping is plainly not a hybridsim file (a Jupyter notebook)."""
    if "nbformat" in data and "cells" in data:
        raise LoaderError(NOT_YAML["notebook"], path, 1)


def file_kind(data):
    """What a parsed file is: "diagram" (it has 'blocks' or 'extends'), else "tune" (a 'diagram'
    with 'parameters' or 'objectives'), else "sweep" (a 'diagram'); None when it shows none of these.
    Keys misspelled ('Diagram:', 'gird:') count."""
    def near(words, cutoff=0.8):
        return any(difflib.get_close_matches(str(k).lower(), words, n=1, cutoff=cutoff) for k in data)

    if "blocks" in data or "extends" in data or near(("blocks", "wires")):
        return "diagram"
    if "diagram" not in data and not near(("diagram",)):
        return None
    if near(("parameters", "objectives", "constraints")):
        return "tune"
    return "sweep" if "diagram" in data or near(("grid", "scale", "random", "set"), 0.7) else None


def refuse_kind(data, expected, path):
    """LoaderError when ``data`` is another kind of file than ``expected``, naming the command for it."""
    kind = file_kind(data)
    if kind is not None and kind != expected:
        line = (getattr(data, "lines", None) or {}).get("diagram", 1) if "diagram" in data else 1
        raise LoaderError(f"this is a {kind} file, not a {expected} file; run it with "
                          f"'hybridsim {COMMANDS[kind]}'", path, line)
