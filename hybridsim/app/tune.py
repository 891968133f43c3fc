"""``hybridsim tune``: search a diagram's parameters for objectives under constraints, resumable."""
from pathlib import Path

from hybridsim.app import options


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("tune", help="search parameters for objectives under constraints (resumable)",
                       description="Search the parameters a tune file names (bounds, log scale, integer or "
                                   "choice) for its objectives (run metrics, step responses, loop margins, "
                                   "largest |z|) under its constraints, with a seeded optimiser, on all local "
                                   "cores or a Dask cluster. Writes best.yaml (a diagram that extends the "
                                   "tuned one), best.json, evaluations.csv, convergence.png and, for two "
                                   "objectives, pareto.png. Run it again to resume (evaluations.jsonl).")
    p.add_argument("tune", help="tune file (see diagrams/tune/)")
    p.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/tune_<name>)")
    options.add_runner(p)
    p.add_argument("--force", action="store_true",
                   help="when OUTDIR holds the points of a different search, discard them and start afresh")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.files import output_dir, safe_name
    from hybridsim.tune import run_tune
    from hybridsim.tune.report import summary_lines

    out, _ = output_dir(args.output, Path("out") / ("tune_" + safe_name(Path(args.tune).stem)))
    res = run_tune(options.path(args.tune), out, jobs=args.jobs, dask=args.dask, progress=not args.quiet,
                   restart=args.force, compiled=args.compiled)
    print("\n".join(summary_lines(res)))
    return 0
