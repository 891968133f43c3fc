"""The generic layers do not speak the paper's language: force control lives in hybridsim.forcecontrol.

The engine, the file format, the FMU bridge, the analysis, the reports, the runs and the
output files (:data:`SCANNED`) are read token by token (Python's ``tokenize``) for two
lists of words:

* the paper's own words, wrong anywhere in the generic layers - in code, strings,
  docstrings and comments - except on a comment or docstring line that cites an
  equation (``eq 17``, ``eqs 9-11``: a model's equations may be named by number where
  a generic method reproduces them): ``raibert``, ``craig``, ``paper``, ``wrist``,
  ``hand`` (not "right-hand side"; "hands" is a verb too), ``appendix``, a figure number
  (``fig 9``, ``fig9``, ``figure 6``) and, outside such comments, an equation number;
* the vocabulary of force control, wrong in code - identifiers and string literals,
  where it would couple a generic layer to force control - and allowed in prose, where
  contact or a surface may be an example (a friction or contact discontinuity, an
  event's switching surface): ``force``, ``contact``, ``surface``, ``oscillation``.

Words are matched whole, on the parts of an identifier (``ss_force_error`` has
``force``; ``forced_response`` and "forces" do not). The roles, metrics, figure and
hand mode that use these words are registered from :mod:`hybridsim.forcecontrol`.
"""
import ast
import io
import re
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: the generic layers: the engine, the file format, the FMU bridge, analysis, reports, runs, output files
SCANNED = ["hybridsim/engine", "hybridsim/format", "hybridsim/fmi", "hybridsim/analysis", "hybridsim/report",
           "hybridsim/runs", "hybridsim/files", "hybridsim/errors.py", "hybridsim/limits.py"]

PAPER_WORDS = {"raibert", "craig", "paper", "papers", "wrist", "wrists", "hand", "appendix"}
FORCE_WORDS = {"force", "contact", "contacts", "surface", "surfaces", "oscillation"}
FIGURE = re.compile(r"\bfig(?:ure)?s?\.?\s*\d+", re.I)
EQUATION = re.compile(r"\beqs?\.?\s*\(?\d+", re.I)
PHRASES = re.compile(r"\b(?:right|left)-hand\b|--force\b", re.I)  # "the right-hand side" is mathematics;
#: a command's --force option (start afresh) is English, not force control

#: hits known and being removed: (file, line text stripped) -> why it is here. An entry whose line is
#: gone fails the test, so the list only shrinks.
PENDING = {}


def words(text):
    """The lower-case words of ``text`` (identifier parts split at '_' and case changes)."""
    text = re.sub(r"([a-z])([A-Z])", r"\1 \2", PHRASES.sub(" ", text))
    return {w.lower() for w in re.split(r"[^A-Za-z]+", text) if w}


def docstring_lines(tree):
    """Line numbers covered by docstrings (module, class, function)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                    and isinstance(first.value.value, str):
                out.update(range(first.lineno, first.end_lineno + 1))
    return out


def hits(path):
    """[(line number, line text, what)] of the words a generic module should not have."""
    text = path.read_text()
    prose_lines = docstring_lines(ast.parse(text))
    lines = text.splitlines()
    out = []
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type not in (tokenize.NAME, tokenize.STRING, tokenize.COMMENT):
            continue
        prose = tok.type == tokenize.COMMENT or (tok.type == tokenize.STRING and tok.start[0] in prose_lines)
        for k, line in enumerate(tok.string.splitlines() or [""]):
            number = tok.start[0] + k
            if prose and EQUATION.search(line):
                continue  # a comment or docstring line that cites an equation
            found = words(line) & (PAPER_WORDS if prose else PAPER_WORDS | FORCE_WORDS)
            if FIGURE.search(line):
                found.add("figure number")
            if not prose and tok.type == tokenize.STRING and EQUATION.search(line):
                found.add("equation number")
            if found:
                out.append((number, lines[number - 1].strip(), ", ".join(sorted(found))))
    return out


def scan():
    found = {}
    for folder in SCANNED:
        top = ROOT / folder
        for path in sorted(top.rglob("*.py")) if top.is_dir() else [top]:
            for number, line, what in hits(path):
                found[(str(path.relative_to(ROOT)), line)] = (number, what)
    return found


def test_the_scanner_tells_code_from_prose(tmp_path):
    p = tmp_path / "m.py"
    p.write_text('"""Solves the right-hand side; contact is an example here."""\n'
                 "def f(forced, x):  # eq 18: the hand's mode\n"
                 "    return x['force_desired']  # Fig 9\n"
                 "y = ss_force_error = 'nearest eq 18'\n")
    got = {(n, what) for n, _, what in hits(p)}
    assert got == {(3, "force"), (3, "figure number"), (4, "force"), (4, "equation number")}


def test_no_paper_words_in_the_generic_layers():
    found = scan()
    new = [f"{f}:{n}: {what}: {line}" for (f, line), (n, what) in sorted(found.items()) if (f, line) not in PENDING]
    assert not new, "force-control or paper words in a generic layer (move it to hybridsim/forcecontrol, " \
                    "or register it from there):\n" + "\n".join(new)
    gone = [key for key in PENDING if key not in found]
    assert not gone, f"gone from the code: delete from PENDING: {gone}"
