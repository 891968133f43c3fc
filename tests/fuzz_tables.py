"""Fuzz cases generated from the format's tables, and the invariants every entry point keeps.

Shared by the bounded test (``tests/format/test_fuzz_tables.py``) and the long run
(``benchmarks/fuzz_tables.py``). Strategies are derived from each section's
table (:mod:`hybridsim.format.tables`): for every key of every section a good
value of its kind, a value of another kind or out of range, or a misspelt key;
``--set`` paths and YAML values (aliases included); sweep files from the sweep
table; trees of subsystem files with random ports and references. The
invariant: ``hybridsim`` ends with a documented exit status (never 70, never
a traceback), within a bounded time, and changes no file outside its output.
"""
import io
import math
import string
import tempfile
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import yaml
from hypothesis import strategies as st

from hybridsim.app.cli import main
from hybridsim.format import tables
from hybridsim.format.tables import Record
from hybridsim.format.kinds import (Bool, Choice, Either, Kind, ListOf, MapOf, Number, PathText, Signal,
                                    Text)

#: the exit statuses hybridsim documents (hybridsim/errors.py)
DOCUMENTED = {0, 2, 3, 4, 5, 6}
#: seconds one case may take
TIME_LIMIT_S = 30

BASE = {
    "name": "small",
    "params": {"k": 2.0, "rate": 100},
    "blocks": {
        "src": {"type": "step", "initial": 0.0, "final": 1.0, "time": 0.01},
        "g": {"type": "gain", "K": "$k"},
        "zoh": {"type": "zoh", "rate": "$rate"},
        "ss": {"type": "state_space", "A": [[-10.0]], "B": [[10.0]], "C": [[1.0]]},
    },
    "wires": ["src.y -> g.u", "g.y -> zoh.u", "zoh.y -> ss.u"],
    "simulation": {"t_end": 0.02, "log_period": 1.0e-3},
    "log": ["zoh.y", "ss.y"],
    "signals": {"force": "ss.y[0]", "force_desired": "src.y[0]"},
}
SIGNALS = ["ss.y[0]", "zoh.y", "g.y[0]", "src.y[0]", "ss.y[3]", "nope.y", "g.nope", "g", "a b.c", "ss.y[-1]"]
PATHS = ["k", "params.k", "rate", "g.K", "blocks.g.K", "zoh.rate", "simulation.t_end", "simulation.stepp",
         "nope", "g.nope", "sub.g.K", "g.K[0]", "g.K[9]", "a..b", "", "ss.A", "simulation.solver"]
ODD = st.sampled_from([None, True, "abc", "", "$nope", "$k", -1, 0, 1e308, math.nan, math.inf, -math.inf,
                       [], [1, "x"], {}, {"a": 1}, [[1, 2], [3]], "1e400", 10**30])


def good(kind):
    """A strategy of values ``kind`` accepts (often; the tables' kinds are simple)."""
    if isinstance(kind, Number):
        lo = kind.low if kind.low is not None else -1e3
        hi = kind.high if kind.high is not None else max(lo + 1.0, 1e3)
        if kind.integer:
            return st.integers(int(math.ceil(lo)) + (1 if kind.low_open else 0), int(min(hi, 1e6)))
        return st.floats(lo, hi, allow_nan=False, allow_infinity=False, exclude_min=kind.low_open)
    if isinstance(kind, Bool):
        return st.booleans()
    if isinstance(kind, Choice):
        return st.sampled_from(kind.options)
    if isinstance(kind, Signal):
        return st.sampled_from(SIGNALS)
    if isinstance(kind, PathText):
        return st.sampled_from(PATHS)
    if isinstance(kind, Text):
        return st.text(string.ascii_letters + " $_{}^\\", max_size=12)
    if isinstance(kind, ListOf):
        n = kind.exact or None
        return st.lists(good(kind.item), min_size=n or kind.min_len, max_size=n or 3)
    if isinstance(kind, Either):
        return st.one_of(*(good(k) for k in kind.kinds))
    if isinstance(kind, MapOf):
        keys = st.sampled_from(PATHS) if kind.keys is not None else st.sampled_from(["a", "force", "b2"])
        return st.dictionaries(keys, good(kind.value), max_size=2)
    if isinstance(kind, Record):
        return section(kind.table)
    return st.one_of(ODD, st.floats(-10, 10))


def value(kind):
    """A good value most of the time, otherwise anything (wrong kind, out of range)."""
    return st.one_of(good(kind), good(kind), ODD)


def section(table):
    """A mapping of some of ``table``'s keys (now and then a misspelt or unknown one)."""
    entries = [st.tuples(st.just(s.key), value(s.kind)) for s in table]
    wrong = st.tuples(st.sampled_from([s.key + "x" for s in table] + ["nope"]), ODD)
    return st.lists(st.one_of(*entries, wrong), max_size=4).map(dict)


@st.composite
def diagrams(draw):
    """A diagram: the base with its sections drawn from their tables."""
    doc = yaml.safe_load(yaml.safe_dump(BASE))
    for name in ("simulation", "metrics", "plot", "analysis"):
        if draw(st.booleans()):
            got = draw(section(tables.SECTIONS[name]))
            if name == "simulation":
                got = {**doc["simulation"], **got}
                got["t_end"] = got.get("t_end") if not isinstance(got.get("t_end"), float) else min(got["t_end"], 0.05)
            doc[name] = got
    if draw(st.integers(0, 3)) == 0:
        doc["variants"] = {draw(st.sampled_from(["k", "rate", "nope"])): draw(st.lists(ODD | st.floats(1, 3),
                                                                                    max_size=3))}
    if draw(st.integers(0, 3)) == 0:
        doc["signals"] = draw(st.dictionaries(st.sampled_from(tables.keys(tables.SIGNALS) + ["forse"]),
                                              st.sampled_from(SIGNALS) | ODD, max_size=3))
    return doc


SET_VALUES = st.one_of(
    st.sampled_from(["1", "0.5", "-1", "[1, 2]", "true", "rk4", "radau", ".nan", ".inf", "", "{a: 1}",
                     "&a [*a]", "[&a [1,1,1,1,1,1,1,1], [*a,*a,*a,*a,*a,*a,*a,*a]]", "[" * 80 + "]" * 80,
                     "!!python/object:os.system", "{a: 1, a: 2}", "1e-12", "1e12", "'$k'", "x" * 50]),
    st.text(string.printable, max_size=20),
)


@st.composite
def set_options(draw):
    """A few ``--set PATH=VALUE`` options."""
    out = []
    for _ in range(draw(st.integers(1, 3))):
        out += ["--set", f"{draw(st.sampled_from(PATHS))}={draw(SET_VALUES)}"]
    return out


@st.composite
def sweep_files(draw):
    """A sweep file's mapping from the sweep table (the diagram is the base)."""
    doc = draw(section(tables.SWEEP))
    doc["diagram"] = draw(st.sampled_from(["d.yaml", "d.yaml", "missing.yaml", "", 5]))
    for key in ("grid", "scale"):
        if isinstance(doc.get(key), dict):
            doc[key] = {k: (v[:2] if isinstance(v, list) else v) for k, v in list(doc[key].items())[:2]}
    if isinstance(doc.get("random"), dict) and isinstance(doc["random"].get("n"), int):
        doc["random"]["n"] = min(doc["random"]["n"], 2)
    doc.pop("traces", None)
    doc["stability"] = False
    return doc


@st.composite
def subsystem_trees(draw):
    """{file name: mapping}: a top diagram and subsystem files that use each other (cycles possible)."""
    n = draw(st.integers(1, 4))
    names = [f"s{i}.yaml" for i in range(n)]
    out = {}
    for i, name in enumerate(names):
        blocks = {"g": {"type": "gain", "K": draw(st.sampled_from([1.0, "$k", "x"]))}}
        uses = draw(st.lists(st.sampled_from(names + ["missing.yaml", "d.txt"]), max_size=2))
        prev = "g"
        wires = []
        for j, use in enumerate(uses):
            blocks[f"u{j}"] = {"type": "subsystem", "file": use}
            if draw(st.booleans()):
                blocks[f"u{j}"][draw(st.sampled_from(["k", "g.K", "nope", "g.nope"]))] = draw(ODD | st.floats(0, 2))
            wires.append(f"{prev}.y -> u{j}.{draw(st.sampled_from(['u', 'v']))}")
            prev = f"u{j}"
        out[name] = {"params": {"k": 1.0}, "inputs": {"u": draw(st.sampled_from(["g.u", "g.x", "q.u"]))},
                     "outputs": {"y": f"{prev}.{draw(st.sampled_from(['y', 'y', 'z']))}"},
                     "blocks": blocks, "wires": wires}
    top = {"blocks": {"c": {"type": "constant", "value": 1.0}, "t": {"type": "subsystem", "file": names[0]}},
           "wires": ["c.y -> t.u"], "simulation": {"t_end": 0.01}, "log": [draw(st.sampled_from(["t.y", "t.g.y"]))]}
    return top, out


def _cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    t0 = time.perf_counter()
    with redirect_stdout(out), redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue() + err.getvalue(), time.perf_counter() - t0


def _snapshot(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in Path(folder).rglob("*") if p.is_file()}


def check_case(command, doc=None, extra_files=None, options=(), sweep=None):
    """Run ``hybridsim COMMAND`` on the case; assert the invariants; return the exit status."""
    with tempfile.TemporaryDirectory(prefix="hybridsim-fuzz-") as work:
        work = Path(work)
        (work / "d.yaml").write_text(yaml.safe_dump(doc if doc is not None else BASE, sort_keys=False))
        for name, data in (extra_files or {}).items():
            (work / name).write_text(yaml.safe_dump(data, sort_keys=False))
        target = work / "d.yaml"
        if sweep is not None:
            (work / "s.yaml").write_text(yaml.safe_dump(sweep, sort_keys=False))
            target = work / "s.yaml"
        (work / "user.txt").write_text("mine")
        before = _snapshot(work)
        argv = [command, target, *options]
        if command in ("run", "sweep"):
            argv += ["-q", "-o", work / "out"]
        if command == "sweep":
            argv += ["-j", "1"]
        code, said, took = _cli(*argv)
        assert code in DOCUMENTED, (code, said)
        assert "Traceback" not in said and "internal error" not in said, said
        assert took < TIME_LIMIT_S, (took, said)
        after = {k: v for k, v in _snapshot(work).items() if not k.startswith("out/")}
        assert after == before, "a file outside the output folder changed"
        return code
