"""``hybridsim examples``: copy the shipped diagrams into a folder to edit."""
from pathlib import Path


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("examples", help="copy the shipped diagrams into a folder you can edit",
                       description="Copy every shipped diagram (the paper's figures, the Fig 6 "
                                   "controller subsystem, the examples and the sweeps) into a folder. "
                                   "Files that exist there are left as they are.")
    p.add_argument("-o", "--output", default="hybridsim-diagrams", metavar="DIR",
                   help="the folder to copy into (default hybridsim-diagrams)")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.shipped import copy_examples

    written, kept = copy_examples(args.output)
    for f in kept:
        print(f"kept {f} (it exists; hybridsim does not replace it)")
    yaml = sum(Path(f).suffix.lower() in (".yaml", ".yml") for f in written)
    other = f" and {len(written) - yaml} file(s) they read (robot models)" if len(written) > yaml else ""
    print(f"wrote {yaml} diagram file(s){other} into {args.output}/: try "
          f"'hybridsim run {Path(args.output) / 'fig9_force_and_position.yaml'}'")
    return 0
