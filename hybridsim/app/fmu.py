"""``hybridsim fmu build`` and ``hybridsim fmu export``: FMUs of the plant and of any diagram."""


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    fm = sub.add_parser("fmu", help="FMU tools: 'hybridsim fmu build' exports the plant",
                        description="Build the plant FMU, or export a diagram as an FMU.")
    fsub = fm.add_subparsers(dest="fmu_command", metavar="FMU_COMMAND")
    fb = fsub.add_parser("build", help="compile the plant (fmus/) into an FMI 2.0 or 3.0 FMU",
                         description="Generate modelDescription.xml and the C variable table from "
                                     "fmus/plant_model.py, compile the plant (fmus/plant_core.h behind "
                                     "fmus/plant.c for FMI 2.0, fmus/plant3.c for FMI 3.0) with the "
                                     "system C compiler (cc or gcc, or $CC) against fmpy's FMI headers, "
                                     "and pack the FMU (Model Exchange and Co-Simulation) with its sources.")
    fb.add_argument("-o", "--output", metavar="FILE",
                    help="the FMU to write (default plant.fmu; a plant.fmu hybridsim did not write is kept "
                         "and the next free name plant-2.fmu, ... is used)")
    fb.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                    help="FMI version: 2 (FMI 2.0, the default) or 3 (FMI 3.0)")
    fb.set_defaults(func=build)
    fe = fsub.add_parser("export", help="a diagram or subsystem as a Co-Simulation FMU (FMI 2.0 or 3.0)",
                         description="Wrap a diagram file as a Co-Simulation FMU with pythonfmu (FMI 2.0) or "
                                     "pythonfmu3 (FMI 3.0). A subsystem's inputs and outputs become the FMU's, "
                                     "its params the FMU's parameters; inside, the diagram runs with its own "
                                     "solver and rates. The FMU needs a Python with hybridsim installed.")
    fe.add_argument("diagram", help="the diagram or subsystem file (.yaml)")
    fe.add_argument("-o", "--output", metavar="FILE",
                    help="the FMU to write (default: the diagram file's name with .fmu, in the current folder; "
                         "a file of that name hybridsim did not write is kept and NAME-2.fmu, ... is used)")
    fe.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version: 2 (the default) or 3")
    fe.set_defaults(func=export)
    fm.set_defaults(func=lambda a: (fm.print_help(), 2)[1])


def build(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.app.options import note
    from hybridsim.fmus.build import write_plant_fmu

    out, why = write_plant_fmu(args.output, fmi=args.fmi)
    note(why)
    print(f"wrote {out} (FMI {args.fmi}.0, Co-Simulation and Model Exchange, sources included)")
    return 0


def export(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.fmi.export import export_fmu

    from pathlib import Path

    from hybridsim.app.options import note
    from hybridsim.files import default_output_file

    target = args.output
    if target is None:  # the diagram's own name, stepping aside from a file hybridsim did not write
        target, why = default_output_file(f"{Path(args.diagram).stem}.fmu")
        note(why)
    out = export_fmu(args.diagram, target, fmi=args.fmi)
    print(f"wrote {out} (FMI {args.fmi}.0 Co-Simulation; it runs the diagram with hybridsim, "
          "which the importing Python must have installed)")
    return 0
