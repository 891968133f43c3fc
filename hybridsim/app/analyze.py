"""``hybridsim analyze`` and ``hybridsim report``: the linearized closed loop, printed or as a page."""
import sys

from hybridsim.app import options
from hybridsim.format import tables


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    a = sub.add_parser("analyze", help="linearize: closed-loop poles, margins, rate and gain sweeps",
                       description="Linearize the diagram about its initial state (or the state at --at "
                                   "seconds) and print the closed-loop poles (sampled-data, exact at the "
                                   "servo period; continuous where nothing is sampled), loop margins at the "
                                   "analysis points, and stability against servo rate and gain scaling. "
                                   "Settings: the diagram's 'analysis' section ("
                                   + tables.help_text(tables.ANALYSIS) + ").")
    options.add_diagram(a)
    options.add_at(a)
    a.add_argument("-o", "--output", metavar="OUTDIR", help="also write OUTDIR/analysis.json")
    a.set_defaults(func=analyze)
    r = sub.add_parser("report", help="HTML stability report with Bode, root locus, pole map, sweeps",
                       description="Analyse every variant (and each 'analysis: compare' setting) and write "
                                   "one self-contained report.html with PNG/SVG figures and analysis.json.")
    options.add_diagram(r)
    options.add_at(r)
    r.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/<name>_report)")
    r.set_defaults(func=report)


def analyze(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.analysis.stability import summary_lines
    from hybridsim.report.stability import write_analysis

    res = write_analysis(options.diagram(args), args.output, at=args.at)
    print("\n".join(summary_lines(res)))
    if args.output:
        print(f"wrote {args.output}/analysis.json")
    return 0


def report(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.report.stability import write_report

    f = options.diagram(args)
    print(f"analysing {f.name} ...", file=sys.stderr)
    data = write_report(f, args.output, at=args.at)
    for c in data["configurations"]:
        print(f"  {c['label'] or f.name}: {c.get('growth_label', 'largest |z|')} {c['growth']:.4g} "
              f"({'stable' if c['stable'] else 'not stable'}), least damping {_num(c['least_damping'])}")
    print(f"wrote {data['outdir']}/report.html (+ PNG and SVG figures, analysis.json)")
    return 0


def _num(v):
    """A number for people: 4 significant digits (or 'n/a')."""
    return f"{v:.4g}" if isinstance(v, (int, float)) else "n/a"
