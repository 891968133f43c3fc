"""``hybridsim sweep``: a parameter sweep on all cores or a Dask cluster, resumable."""
from pathlib import Path

from hybridsim.app import options


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("sweep", help="run a parameter sweep in parallel (resumable)",
                       description="Run every point of a sweep file (grid, scaled gains, seeded random) "
                                   "on all local cores or a Dask cluster, reduce each run to metrics, "
                                   "and write sweep.csv, sweep.parquet and heatmap.png. Run it again to "
                                   "resume: finished points (points.jsonl) are skipped.")
    p.add_argument("sweep", help="sweep file (see diagrams/sweeps/)")
    p.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/<sweep name>)")
    options.add_runner(p)
    p.add_argument("--force", action="store_true",
                   help="when OUTDIR holds points of a different sweep (another diagram, set, "
                        "solver or hybridsim's version or code), discard them and start afresh")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.files import output_dir, safe_name
    from hybridsim.runs.sweep import run_sweep

    out, _ = output_dir(args.output, Path("out") / safe_name(Path(args.sweep).stem))
    rows = run_sweep(options.path(args.sweep), out, jobs=args.jobs, dask=args.dask, progress=not args.quiet,
                     compiled=args.compiled, restart=args.force)
    failed = [r for r in rows if r["status"] != "ok"]
    wrote = [n for n in ("sweep.csv", "sweep.parquet", "heatmap.png", "points.jsonl") if (Path(out) / n).exists()]
    print(f"{len(rows)} rows ({len(failed)} failed) -> {out}/{', '.join(wrote)}")  # heatmap: two axes or more
    for r in failed[:5]:
        print(f"  failed {r['key']}: {r['message']}")
    return 0
