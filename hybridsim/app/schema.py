"""``hybridsim schema``: the JSON Schema of the diagram format, for editors."""
import json
import sys


def add(sub):
    """The argparse spec of this module\'s command(s), added to ``sub`` (the subcommands)."""
    p = sub.add_parser("schema", help="write a JSON Schema of the diagram format (for editors)",
                       description="Generate a JSON Schema of the diagram format from the block registry "
                                   "(every block type with its parameters and defaults, plugins included) and "
                                   "the tables of every section (simulation keys, signal roles, settings). A YAML "
                                   "language server uses it to complete names and flag mistakes; attach it to a "
                                   "diagram with the line '# yaml-language-server: $schema=PATH'.")
    p.add_argument("-o", "--output", metavar="FILE", help="the .json file to write (default: standard output)")
    p.set_defaults(func=run)


def run(args):
    """Do the command: one call of the Python API, its result printed; returns the exit status."""
    from hybridsim.format.schema import diagram_schema, write_schema

    if not args.output:
        sys.stdout.write(json.dumps(diagram_schema(), indent=1) + "\n")
        return 0
    out = write_schema(args.output)
    print(f"wrote {out}: attach it with the first line of a diagram\n"
          f"  # yaml-language-server: $schema={out}")
    return 0
