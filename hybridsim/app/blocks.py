"""``hybridsim blocks``: the block library by group."""


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("blocks", help="list the block types",
                       description="Every registered block type (the library's and the plugins') by group, "
                                   "with its one-line description; -v adds parameters with their defaults, "
                                   "ports with their widths, rate and continuous states.")
    p.add_argument("types", nargs="*", metavar="TYPE",
                   help="only these block types (e.g. integrator relay), with their parameters and ports")
    p.add_argument("-v", "--verbose", action="store_true", help="with their parameters")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.format.catalog import catalog

    groups = catalog()
    if args.types:
        from hybridsim.engine.registry import closest
        from hybridsim.errors import InputError

        known = {b.type_name: b for infos in groups.values() for b in infos}
        for t in args.types:
            if t not in known:
                raise InputError(f"no block type {t!r}{closest(t, list(known))}; 'hybridsim blocks' lists them")
        for t in args.types:
            print("\n".join(lines(known[t], True)))
        return 0
    for k, (group, infos) in enumerate(groups.items()):
        print(f"\n{group}:" if k else f"{group}:")
        for b in infos:
            print("\n".join(lines(b, args.verbose)))
    return 0


def lines(b, verbose):
    """One block type's lines: its name and description; with ``verbose`` its parameters and ports."""
    out = [f"  {b.type_name:26s} {b.doc}"]
    if not verbose:
        return out
    shown = list(b.required) + [f"{p}={v!r}" for p, v in b.defaults.items()]
    out.append(f"  {'':26s} parameters: {', '.join(shown) or 'none'}")
    if b.inputs is not None:
        port = lambda p: f"{p[0]}[{p[1]}]"  # noqa: E731
        out.append(f"  {'':26s} inputs: {', '.join(map(port, b.inputs)) or 'none'}; "
                   f"outputs: {', '.join(map(port, b.outputs)) or 'none'}"
                   + (f"; rate {b.rate_hz:g} Hz" if b.rate_hz else "")
                   + (f"; {b.states} continuous states" if b.states else "")
                   + (f" ({b.held} of them modes or counts, held between events)" if b.held else ""))
    return out
