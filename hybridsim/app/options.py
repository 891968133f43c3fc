"""What the commands share: argument types, the diagram and ``--set`` options, and reading them.

Each command module has ``add(sub)`` (its argparse spec), ``run(args)`` (one call of
the Python API and the printed result, returning the exit status); this module
turns arguments into what the API takes.
"""
import argparse
import math
import sys

from hybridsim.errors import InputError
from hybridsim.format.yamlio import parse_value


def _whole(text, many="", one=""):
    """``text`` as a whole number >= 1, else argparse's error ("of processes", "process")."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a whole number{many}, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expects at least 1{one}, got {n}")
    return n


def jobs(text):
    """A number of processes (argparse type): a whole number >= 1."""
    return _whole(text, " of processes", " process")


def count(text):
    """A whole number >= 1 (argparse type)."""
    return _whole(text)


def seconds(text):
    """A time >= 0 s (argparse type)."""
    try:
        t = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a time in seconds, got {text!r}") from None
    if not (math.isfinite(t) and t >= 0):
        raise argparse.ArgumentTypeError(f"expects a finite time >= 0 s, got {text!r}")
    return t


def add_diagram(parser):
    """The DIAGRAM argument and ``--set PATH=VALUE``."""
    parser.add_argument("diagram", help="YAML diagram file (see diagrams/)")
    parser.add_argument("--set", action="append", metavar="PATH=VALUE",
                        help="override a parameter or setting: k=2, g.K=3, g.K[1]=3, simulation.t_end=5 "
                             "(t_end=5 where no parameter is named t_end); repeatable")


def add_at(parser):
    """The operating point option of analyze and report."""
    parser.add_argument("--at", type=seconds, metavar="T",
                        help="linearize about the state at T s of simulation (default: the diagram's "
                             "'analysis: at', else its initial state)")


def add_runner(parser, what="processes"):
    """``-j``, ``--dask``, ``-q``, ``--compiled`` and ``--force`` of the commands that run many points."""
    parser.add_argument("-j", "--jobs", type=jobs, help=f"local {what} (default: one per core)")
    parser.add_argument("--dask", metavar="ADDRESS", help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--compiled", action="store_true",
                        help="run every point compiled with numba (compiled once, then loaded from the cache)")


def overrides(items):
    """``{path: value}`` of ``--set PATH=VALUE`` options (VALUE read as YAML)."""
    out = {}
    for item in items or []:
        if "=" not in item:
            raise InputError(f"--set expects PATH=VALUE, got {item!r}")
        key, val = item.split("=", 1)
        if not key.strip():
            raise InputError(f"--set expects PATH=VALUE, got {item!r} (no PATH)")
        out[key.strip()] = parse_value(val, f"--set {key.strip()}")
    return out


def path(given):
    """The file a command reads: ``given``, or the shipped one it names (with a note on stderr)."""
    from hybridsim.shipped import find_diagram

    found, note = find_diagram(given)
    if note:
        print(note, file=sys.stderr)
    return found


def diagram(args, extra=()):
    """The :class:`~hybridsim.format.DiagramFile` of ``args.diagram`` with its ``--set`` (and ``extra``
    ``PATH=VALUE`` items) applied."""
    from hybridsim.format import DiagramFile

    return DiagramFile(path(args.diagram), overrides(list(args.set or []) + list(extra)))


def note(text):
    """A note on stderr (None: nothing)."""
    if text:
        print(text, file=sys.stderr)
