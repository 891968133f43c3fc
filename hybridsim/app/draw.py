"""``hybridsim draw``: a picture of a diagram, one colour per rate."""
from hybridsim.app import options


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("draw", help="render the diagram as a picture (one colour per rate)",
                       description="Draw a diagram (its first variant): the forward path left to right, "
                                   "feedback routed around it (Graphviz's dot where it is installed, else "
                                   "dependency layers), one colour per rate.")
    options.add_diagram(p)
    p.add_argument("-o", "--output", metavar="FILE",
                   help="image file, its suffix the format (.png, .svg, .pdf, .jpg or another matplotlib writes; default NAME.png, never replacing a file hybridsim "
                        "did not write: then NAME-2.png, ...)")
    p.add_argument("--expand", action="store_true",
                   help="draw every block inside subsystems (default: a subsystem is one box)")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.report.picture import write_picture

    out, note = write_picture(options.diagram(args), args.output, expand=args.expand)
    options.note(note)
    print(f"wrote {out}")
    return 0
