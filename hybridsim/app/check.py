"""``hybridsim check``: validate every variant of a diagram without running it."""
from hybridsim.app import options


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("check", help="validate a diagram (or a sweep or tune file) without running it",
                       description="Build every variant of a diagram as a run would (blocks, wires, rates, "
                                   "settings, the sizes of the run) without running it: a diagram that passes "
                                   "cannot fail 'run' for a reason this could have seen. Given a sweep or tune "
                                   "file, check it as 'hybridsim sweep' / 'hybridsim tune' would before their "
                                   "first run: the file, its diagram with 'set', and every swept value (both ends "
                                   "of each tuned parameter). A subsystem file (one with 'inputs:') is checked "
                                   "as a diagram that uses it would run it, its inputs held at 0, its "
                                   "'simulation:' section as an exported FMU's solver.")
    options.add_diagram(p)
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.checking import check_file

    info = check_file(options.path(args.diagram), **options.overrides(args.set or []))
    if info["kind"] == "sweep":
        print(f"{args.diagram}: OK - a sweep of {info['diagram']}, {info['points']} point(s)")
    elif info["kind"] == "tune":
        print(f"{args.diagram}: OK - a tune file for {info['diagram']}, {info['parameters']} parameter(s), "
              f"method {info['method']}")
    elif info["kind"] == "subsystem":
        ports = lambda ps: ", ".join(f"{n} ({w})" for n, w in ps) or "none"  # noqa: E731
        print(f"{args.diagram}: OK - a subsystem of {info['blocks']} blocks, {_states(info)}, "
              f"rates {', '.join(f'{r:g} Hz' for r in info['rates']) or 'none'}; inputs {ports(info['inputs'])}, "
              f"outputs {ports(info['outputs'])} (checked with its inputs held at 0)")
    else:
        print(f"{args.diagram}: OK - {info['blocks']} blocks, {_states(info)}, "
              f"rates {', '.join(f'{r:g} Hz' for r in info['rates']) or 'none'}, {info['runs']} run(s)")
    return 0


def _states(info):
    held = info.get("held_states", 0)
    return f"{info['states']} continuous states" + (f" ({held} of them modes or counts, held between events)"
                                                    if held else "")
