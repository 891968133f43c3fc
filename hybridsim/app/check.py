"""``hybridsim check``: validate every variant of a diagram without running it."""
from hybridsim.app import options


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("check", help="validate a diagram without running it",
                       description="Build every variant of a diagram as a run would (blocks, wires, rates, "
                                   "settings, the sizes of the run) without running it: a diagram that passes "
                                   "cannot fail 'run' for a reason this could have seen.")
    options.add_diagram(p)
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim import api

    f = options.diagram(args)
    info = api.check(f)
    print(f"{f.path}: OK - {info['blocks']} blocks, {info['states']} continuous states, "
          f"rates {', '.join(f'{r:g} Hz' for r in info['rates']) or 'none'}, "
          f"{info['runs']} run(s)")
    return 0
