"""Every benchmark's figures go into benchmarks/RESULTS.md, one dated section per run.

A benchmark script runs its ``main`` inside :func:`recorded`: what it prints still goes to the
terminal, and once it finishes without an error the same text is appended to RESULTS.md under
a heading with the date (UTC), the command line and the machine. Nothing earlier in the file is
changed. ``HYBRIDSIM_BENCH_NO_RECORD=1`` runs a benchmark without recording it;
``HYBRIDSIM_BENCH_RESULTS=FILE`` records into another file.
"""
import contextlib
import datetime
import io
import os
import platform
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().with_name("RESULTS.md")


def machine():
    """One line about where the figures were measured (cores, CPU architecture, Python)."""
    return f"{os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}"


def append_section(title, body, command=None, date=None, path=RESULTS):
    """Append a dated section ``title`` with ``body`` (text, kept verbatim) to ``path``.

    Parameters
    ----------
    title : str
        What was measured, e.g. "Fig 9 run time by path".
    body : str
        The benchmark's output.
    command : str, optional
        The command line that produced it (default: this process's).
    date : str, optional
        ISO date (default: today, UTC).
    path : Path
        The results file (default: benchmarks/RESULTS.md).
    """
    date = date or datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    command = command or "python " + " ".join([Path(sys.argv[0]).as_posix(), *sys.argv[1:]])
    section = (f"\n## {date}: {title}\n\n`{command}` ({machine()})\n\n"
               f"```text\n{body.rstrip()}\n```\n")
    path = Path(path)
    if not path.exists():
        path.write_text("# Benchmark results\n\nDated sections, appended by the benchmark scripts "
                        "(benchmarks/results.py); newest last.\n")
    with path.open("a") as fh:
        fh.write(section)
    return section


class _Tee(io.TextIOBase):
    def __init__(self, *streams):
        self.streams = streams

    def write(self, s):
        for st in self.streams:
            st.write(s)
        return len(s)

    def flush(self):
        for st in self.streams:
            st.flush()


@contextlib.contextmanager
def recorded(title, path=None):
    """Run the ``with`` body printing as usual; if it ends without an error, append what it
    printed to ``path`` (default: ``$HYBRIDSIM_BENCH_RESULTS``, else RESULTS.md) as a dated
    section (unless ``HYBRIDSIM_BENCH_NO_RECORD`` is set)."""
    path = Path(path or os.environ.get("HYBRIDSIM_BENCH_RESULTS") or RESULTS)
    buf = io.StringIO()
    with contextlib.redirect_stdout(_Tee(sys.stdout, buf)):
        yield
    if os.environ.get("HYBRIDSIM_BENCH_NO_RECORD") or not buf.getvalue().strip():
        return
    append_section(title, buf.getvalue(), path=path)
    print(f"(appended to {path})")
