"""Mutated YAML diagrams and the invariants every entry point keeps on them.

Shared by the bounded fuzz test (``tests/format/test_fuzz.py``) and the longer run
(``benchmarks/fuzz_entry_points.py``). A case is a valid diagram with one to
three mutations (a number scaled; a value replaced by a wrong type, width,
reference or number; a key removed or added; a value wrapped in a list; a
character inserted into the text). The invariants, for ``hybridsim check`` then (when
check passes) ``hybridsim run``: an exit code in {0, 2, 3, 4}, never 70 and
never a traceback; no file written outside the output folder; nothing that
existed before deleted or changed; and check OK implies run does not exit 2.
"""
import copy
import io
import os
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import yaml
from hypothesis import strategies as st

from hybridsim.app.cli import main
from hybridsim.format import NumberLoader

ROOT = Path(__file__).resolve().parents[1]

SMALL = """\
name: small
params: {k: 2.0, rate: 100}
blocks:
  src:  {type: step, initial: 0.0, final: 1.0, time: 0.01}
  g:    {type: gain, K: $k}
  zoh:  {type: zoh, rate: $rate}
  ss:   {type: state_space, A: [[-10.0]], B: [[10.0]], C: [[1.0]]}
  lp:   {type: lowpass, cutoff: 12.0}
  d:    {type: delay, rate: 50, initial: 0.0}
  s:    {type: sum, signs: "+-"}
wires: [src.y -> g.u, g.y -> zoh.u, zoh.y -> ss.u, ss.y -> s.u1, d.y -> s.u2, s.y -> lp.u, lp.y -> d.u]
simulation: {t_end: 0.05, log_period: 1.0e-3}
log: [zoh.y, lp.y]
signals: {force: 'lp.y[0]', force_desired: 'src.y[0]'}
metrics: {step_time: 0.01, ss_window: 0.01}
"""

BASES = [yaml.load(SMALL, Loader=NumberLoader),
         yaml.load((ROOT / "diagrams" / "hybrid_controller.yaml").read_text(), Loader=NumberLoader),
         yaml.load((ROOT / "diagrams" / "bouncing_ball.yaml").read_text(), Loader=NumberLoader)]
BASES[1]["simulation"]["t_end"] = 0.05
# the copy is written to a temporary folder: point it at the shipped controller subsystem
BASES[1]["blocks"]["ctrl"]["file"] = str(ROOT / "diagrams" / "subsystems" / "fig6_controller.yaml")

NUMBERS = [2.5, 1, 3, 1e-3, 1e3, 0, -1, 1e12, -1e-15, float("nan"), float("inf"), 1e308]
VALUES = st.one_of(
    st.sampled_from(NUMBERS),
    st.sampled_from([None, True, False, "abc", "", "$nope", "$k", "$rate", "x.y[9]", "g.y[0]", "../../evil",
                     "src.y -> zoh.u", "zoh.y -> g.u", "lp.y[-1]", "rk4", "radau", "..", "a/b"]),
    st.lists(st.sampled_from(NUMBERS), max_size=4),
    st.dictionaries(st.sampled_from(["type", "a", "rate", "K"]), st.sampled_from(NUMBERS + ["gain"]), max_size=2),
)
KEYS = st.sampled_from(["type", "rate", "width", "K", "nope", "t_end", "step", "name", "extends",
                        "blocks", "x", "period", "log_period", "signs", "initial"])
SNIPPETS = st.sampled_from(["\t", "\x00", "&a ", "*a", "<<: ", "[", "}", ": ", "\n  - ", "!!python/object ",
                            "\ufeff", "%YAML 1.2\n", "'", "#"])


def _paths(node, prefix=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield prefix + (k,)
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield prefix + (i,)
            yield from _paths(v, prefix + (i,))


def _parent(doc, path):
    node = doc
    for k in path[:-1]:
        node = node[k]
    return node


@st.composite
def mutated_diagrams(draw):
    """YAML text of a valid diagram with one to three mutations."""
    doc = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(doc))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, key = _parent(doc, path), path[-1]
        op = draw(st.sampled_from(["nudge", "replace", "replace", "delete", "add", "wrap"]))
        value = parent[key]
        if op == "nudge" and isinstance(value, (int, float)) and not isinstance(value, bool):
            parent[key] = value * draw(st.sampled_from([2, 0.5, -1, 10, 1e-3, 1e3, 0]))
        elif op == "nudge":
            continue
        elif op == "replace":
            parent[key] = draw(VALUES)
        elif op == "delete":
            del parent[key]
        elif op == "add" and isinstance(parent[key], dict):
            parent[key][draw(KEYS)] = draw(VALUES)
        else:
            parent[key] = [parent[key]]
    text = yaml.safe_dump(doc, sort_keys=False)
    if draw(st.integers(0, 4)) == 0:
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(SNIPPETS) + text[at:]
    return text


def _snapshot(folder, skip):
    out = {}
    for root, dirs, files in os.walk(folder):
        if Path(root) == skip:
            dirs[:] = []
            continue
        for n in files:
            p = Path(root) / n
            out[str(p.relative_to(folder))] = p.read_bytes()
    return out


def _cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue() + err.getvalue()


def check_invariants(text):
    """Run ``check`` and (when it passes) ``run`` on ``text``; assert the invariants."""
    with tempfile.TemporaryDirectory(prefix="hybridsim-fuzz-") as work:
        work = Path(work)
        (work / "user.txt").write_text("mine")
        out = work / "out"
        out.mkdir()
        (out / "keep.txt").write_text("mine too")
        diagram = work / "d.yaml"
        diagram.write_text(text)
        before = _snapshot(work, out)
        code, said = _cli("check", diagram)
        assert code in (0, 2, 3, 4, 5, 6), (code, said)
        assert "Traceback" not in said and "internal error" not in said, said
        if code == 0:
            code, said = _cli("run", diagram, "-q", "-o", out, "--set", "simulation.t_end=0.02")
            assert code in (0, 3, 4), (code, said)  # check OK: never a bad-input 2
            assert "Traceback" not in said and "internal error" not in said, said
        assert _snapshot(work, out) == before, "a file outside the output folder changed"
        assert (out / "keep.txt").read_text() == "mine too"
        assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
        return code
