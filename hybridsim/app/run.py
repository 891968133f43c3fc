"""``hybridsim run``: simulate every variant; write CSV, the figure and metrics.json."""
from pathlib import Path
import sys

from hybridsim.app import options

HELP = "simulate every variant; write CSV, plots and metrics.json"
DESCRIPTION = ("Simulate a diagram (all its variants) and write, atomically, a CSV per run, a figure "
               "(PNG and SVG; laid out for the diagram's signal roles, else one panel per logged signal) "
               "and metrics.json into OUTDIR.")


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("run", help=HELP, description=DESCRIPTION)
    options.add_diagram(p)
    p.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/<name>)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.add_argument("--compiled", action="store_true",
                   help="run the whole loop compiled with numba (RK4; every block needs kernels). "
                        "The first run of a diagram compiles it, later runs load it "
                        "from the cache ($HYBRIDSIM_CACHE or ~/.cache/hybridsim)")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim import api

    def announce(f):
        n = len(f.variants())
        print(f"running {f.name} ({n} run{'s' if n > 1 else ''}) ...", file=sys.stderr)

    f = options.diagram(args, ["simulation.compiled=true"] if args.compiled else [])
    done = api.run(f, args.output, progress=not args.quiet, announce=announce)
    show(done)
    return 0


def show(done):
    """One line per run (its metrics' phrases and wall time), a note where a block ended it, the folder."""
    from hybridsim.analysis.metrics import describe
    from hybridsim.files import safe_name

    f = done["file"]
    for r in done["runs"]:
        head = r["label"] or f.name
        parts = describe(r["metrics"]) + [f"{r['metrics']['wall_time_s']:.2f} s wall"]
        print(f"  {head}: " + ", ".join(parts))
        for note in r["result"].meta.get("metric_notes", []):
            print(f"  {head}: note: {note}")
        stopped = r["result"].meta.get("stopped")
        if stopped:
            print(f"  {head}: note: block {stopped['block']!r} ended the run at t={stopped['t']:.6g} s "
                  f"({stopped['reason']}); the results go up to then")
    figure = f", {safe_name(f.name)}.png/.svg" if (Path(done["outdir"]) / f"{safe_name(f.name)}.png").exists() else ""
    print(f"wrote {done['outdir']}/ (CSV{figure}, metrics.json)")
