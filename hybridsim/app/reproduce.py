"""``hybridsim reproduce``: every experiment of the paper, claim by claim, in one HTML report."""
import sys
from pathlib import Path

from hybridsim.app import options


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("reproduce", help="run every experiment of the paper and check its claims",
                       description="Run Figs 7-10 and eq 18 as printed, check each of the paper's claims, "
                                   "search the smallest damping that reproduces what fails, explain it with "
                                   "the stability analysis, and run sensitivities. Writes one self-contained "
                                   "HTML report.")
    p.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/reproduce)")
    p.add_argument("-j", "--jobs", type=options.jobs, help="parallel processes (default: one per core)")
    p.add_argument("--compiled", action="store_true",
                   help="every simulation on the compiled path (numba): the first time compiles "
                        "each diagram structure it uses, later runs load them from the cache")
    p.add_argument("--quick", action="store_true",
                   help="eq 18 only, one damping trial, no sensitivities: a smoke test")
    p.add_argument("--joint-search", type=options.count, metavar="N",
                   help="also search every unstated assumption jointly (Optuna TPE, seeded), judging N models "
                        "at 60, 80 and 120 Hz; each model is ten experiment runs")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.files import check_output_dir
    from hybridsim.paper.reproduce import reproduce

    out = check_output_dir(Path(args.output or "out/reproduce"))
    quick = dict(experiments=["eq 18"], grid=[16.0], bisections=1, sensitivities=[], hinges=False) \
        if args.quick else {}
    report = reproduce(out, jobs=args.jobs, progress=lambda m: print(f"  {m} ...", file=sys.stderr),
                       compiled=args.compiled, joint=args.joint_search or 0, **quick)
    show(report, out)
    return 0


def show(report, out):
    """Each claim with its verdict, what the failing ones hinge on, the best models, the folder."""
    from hybridsim.paper.reproduce import summary_rows

    for exp, claim, ours, ok in summary_rows(report):
        print(f"  {'✓' if ok else '✗'} {exp}: {claim} - ours: {ours}")
    h = report.get("hinges")
    if h:
        for r in h["rows"]:
            if r["as_printed"] != "holds":
                print(f"  {r['experiment']}: {r['claim']} ({r['as_printed']} as printed): {r['hinges_on'][0]}")
        if h["best"]:
            model = " + ".join(f"{a} {v:.3g}" for a, v in h["best"]["model"])
            held = ", ".join(f"{k}/{n} at {rate} Hz" for rate, (k, n) in h["best"]["held"].items())
            print(f"  best stated model: {model}: {held}")
    js = report.get("joint_search")
    if js:
        from hybridsim.paper.joint_search import model_text

        model = model_text(js["best"]["model"])
        held = ", ".join(f"{k}/{js['best']['total'][r]} at {r} Hz" for r, k in js["best"]["held"].items())
        print(f"  joint search ({js['evaluations']} models, {js['wall_time_s']:.0f} s): best "
              f"{model}: {held}, penalty {js['best']['penalty']:.2f}")
    print(f"wrote {out}/reproduce.html (+ figures, metrics.csv, reproduce.json) "
          f"in {report['wall_time_s']:.0f} s")
