"""The ``hybridsim`` command: a thin layer over :mod:`hybridsim.api`.

Exit status by origin (the table in :mod:`hybridsim.errors`): 0 success; 2 bad
input; 3 the model diverged or its solver failed; 4 an FMU; 5 the environment
(disk full, permission, a missing package); 6 a plugin's fault; 70 an internal
error (please report it, with ``--debug``).
"""
import argparse
import json
import logging
import math
import signal
import sys
from pathlib import Path

from hybridsim.errors import HybridsimError, InputError
from hybridsim.files import check_default_dir, check_output_dir, check_output_file, default_output_file, safe_name
from hybridsim.format import tables
from hybridsim.format.yamlio import parse_value

EPILOG = """\
examples:
  hybridsim run diagrams/fig9_force_and_position.yaml            # 60/80/120 Hz, plots + CSV
  hybridsim run diagrams/fig7_force_steps.yaml --set force=10 --set rate=120
  hybridsim run diagrams/fig9_force_and_position.yaml --set arm.damping=[5,50]
  hybridsim check diagrams/fig8_receding_surface.yaml
  hybridsim draw diagrams/hybrid_controller.yaml -o fig6.png
  hybridsim analyze diagrams/hybrid_controller.yaml --set rate=120
  hybridsim report diagrams/fig9_force_and_position.yaml -o out/fig9_report
  hybridsim fmu build -o plant.fmu && hybridsim run diagrams/fig9_fmu_cs.yaml
  hybridsim sweep diagrams/sweeps/fig7_force_gains.yaml          # 5 x 5 gains, resumable
  hybridsim tune diagrams/tune/msd_pid.yaml                      # PID gains: fastest settling, <= 5 % overshoot
  hybridsim run diagrams/fig9_force_and_position.yaml --set ctrl.fpi.Ki=[100,100]  # inside the Fig 6 subsystem
  hybridsim run diagrams/examples/msd_pid.yaml                   # a PID loop from library blocks
  hybridsim examples -o mydiagrams                               # the diagrams, to edit
  hybridsim blocks                                               # the block library

--set PATH=VALUE: PATH is a name in the diagram's 'params', a block
parameter 'block.param' ('sub.block.param' inside a subsystem, 'block.param[i]'
for one element), or 'simulation.key' ({sim}).
VALUE is read as YAML: 10, 1e-4, [5, 50], true.
A --set of a parameter that 'variants' sweeps fixes it to one run.
Every setting of every section: docs/settings.md. Limits checked before a
run (steps, log size, blocks, sweep points) are raised with environment
variables, e.g. HYBRIDSIM_MAX_STEPS=1e9.

exit status: 0 ok, 2 bad input, 3 the model diverged, 4 an FMU, 5 the
environment (disk, permission, a missing package), 6 a plugin's fault.
""".format(sim=tables.help_text(tables.SIMULATION))


def _overrides(items):
    out = {}
    for item in items or []:
        if "=" not in item:
            raise InputError(f"--set expects PATH=VALUE, got {item!r}")
        key, val = item.split("=", 1)
        if not key.strip():
            raise InputError(f"--set expects PATH=VALUE, got {item!r} (no PATH)")
        out[key.strip()] = parse_value(val, f"--set {key.strip()}")
    return out


def _load(path, sets):
    from hybridsim.format import DiagramFile

    return DiagramFile(_find_diagram(path), _overrides(sets))


def _find_diagram(path):
    """``path``, or the shipped diagram it names when it does not exist here.

    ``diagrams/fig9_force_and_position.yaml`` (or just the file name) then works
    from any folder, as in docs/getting-started.md, with a note saying which file ran.
    """
    p = Path(path)
    if p.exists():
        return p
    from hybridsim.app.examples import diagrams_folder

    parts = p.parts[1:] if p.parts[:1] == ("diagrams",) else p.parts
    if parts and not p.is_absolute() and ".." not in parts:
        shipped = diagrams_folder().joinpath(*parts)
        if shipped.is_file():
            print(f"note: {path} is not here; using the shipped {shipped} "
                  "('hybridsim examples' copies them to edit)", file=sys.stderr)
            return shipped
    return p


def cmd_run(args):
    """`hybridsim run`: every variant of a diagram, then CSV, figures and metrics. Returns the exit status."""
    from hybridsim import api

    f = _load(args.diagram, list(args.set or []) + (["simulation.compiled=true"] if args.compiled else []))
    outdir = check_output_dir(Path(args.output) if args.output else Path("out") / safe_name(f.name))
    api.check(f)
    n = len(f.variants())
    print(f"running {f.name} ({n} run{'s' if n > 1 else ''}) ...", file=sys.stderr)
    f, runs, settings = api.run_experiment(f, progress=not args.quiet)
    api.write_outputs(f, runs, settings, outdir, only_ours=not args.output)
    for r in runs:
        m = r["metrics"]
        head = r["label"] or f.name
        parts = []
        lost = m.get("contact_lost")
        for key, fmt in (("rise_time_s", "rise {:.3f} s"), ("overshoot_pct", "overshoot {:.0f} %"),
                         ("ss_force_error_filtered_N", "steady error {:.2f} N"),
                         ("force_error_max_filtered_N", "max force error {:.2f} N"),
                         ("max_position_error_m", "max position error {:.2f} mm"),
                         ("oscillation_hz", "oscillation {:.1f} Hz")):
            v = m.get(key)
            if lost and key in ("rise_time_s", "overshoot_pct"):
                continue  # a bouncing hand has no meaningful step response (metrics.json keeps them)
            if v is not None:
                parts.append(fmt.format(v * 1000 if key.endswith("_m") else v))
        if "contact_lost" in m:
            parts.append(f"contact LOST at {m['first_loss_s']:.3f} s (the force metrics then describe "
                         "a bouncing hand, not the force loop)" if m["contact_lost"] else "contact kept")
        parts.append(f"{m['wall_time_s']:.2f} s wall")
        print(f"  {head}: " + ", ".join(parts))
        stopped = r["result"].meta.get("stopped")
        if stopped:
            print(f"  {head}: note: block {stopped['block']!r} ended the run at t={stopped['t']:.6g} s "
                  f"({stopped['reason']}); the results go up to then")
    print(f"wrote {outdir}/ (CSV, {safe_name(f.name)}.png/.svg, metrics.json)")
    return 0


def cmd_check(args):
    """`hybridsim check`: validate every variant without running. Returns the exit status."""
    from hybridsim import api

    f = _load(args.diagram, args.set)
    info = api.check(f)
    print(f"{f.path}: OK - {info['blocks']} blocks, {info['states']} continuous states, "
          f"rates {', '.join(f'{r:g} Hz' for r in info['rates']) or 'none'}, "
          f"{info['runs']} run(s)")
    return 0


def cmd_draw(args):
    """`hybridsim draw`: a picture of the diagram. Returns the exit status."""
    from hybridsim.report.picture import draw_diagram
    from hybridsim.files import atomic_file

    f = _load(args.diagram, args.set)
    out = check_output_file(args.output or f"{safe_name(f.name)}.png", _image_formats())
    if not args.output:
        out, note = default_output_file(out)
        if note:
            print(note, file=sys.stderr)
    diagram, _ = f.build(f.variants()[0][1])
    system = diagram.build()
    fig = draw_diagram(system, f.description or f.name, expand=args.expand)
    with atomic_file(out, "wb") as fh:
        fig.savefig(fh, format=out.suffix.lstrip(".") or "png", dpi=120)
    print(f"wrote {out}")
    return 0


def _image_formats():
    from matplotlib.figure import Figure

    return sorted(Figure().canvas.get_supported_filetypes())


def cmd_analyze(args):
    """`hybridsim analyze`: linearize, poles, margins, rate and gain sweeps. Returns the exit status."""
    from hybridsim.analysis import stability as analysis

    f = _load(args.diagram, args.set)
    if args.output:
        check_output_dir(args.output)
    ov = _overrides(args.set)
    res = analysis.analyze(f.path, at=args.at, **ov)
    res.pop("_objects")
    print("\n".join(analysis.summary_lines(res)))
    if args.output:
        from hybridsim.files import atomic_file
        from hybridsim.report.stability import _json

        out = Path(args.output) / "analysis.json"
        with atomic_file(out) as fh:
            fh.write(json.dumps(res, indent=2, default=_json) + "\n")
        print(f"wrote {out}")
    return 0


def cmd_report(args):
    """`hybridsim report`: the HTML stability report. Returns the exit status."""
    from hybridsim.report.stability import write_report

    f = _load(args.diagram, args.set)
    out = check_output_dir(Path(args.output or Path("out") / f"{safe_name(f.name)}_report"))
    if not args.output:
        check_default_dir(out)
    print(f"analysing {f.name} ...", file=sys.stderr)
    data = write_report(f.path, out, at=args.at, **_overrides(args.set))
    for c in data["configurations"]:
        print(f"  {c['label'] or f.name}: {c.get('growth_label', 'largest |z|')} {c['growth']:.4g} "
              f"({'stable' if c['stable'] else 'not stable'}), least damping {_num(c['least_damping'])}")
    print(f"wrote {out}/report.html (+ PNG and SVG figures, analysis.json)")
    return 0


def cmd_reproduce(args):
    """`hybridsim reproduce`: the paper's claims, one by one. Returns the exit status."""
    from hybridsim.paper.reproduce import reproduce, summary_rows

    out = check_output_dir(Path(args.output or "out/reproduce"))
    quick = dict(experiments=["eq 18"], grid=[16.0], bisections=1, sensitivities=[], hinges=False) \
        if args.quick else {}
    report = reproduce(out, jobs=args.jobs, progress=lambda m: print(f"  {m} ...", file=sys.stderr),
                       compiled=args.compiled, joint=args.joint_search or 0, **quick)
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
        from hybridsim.paper.joint_search import _fmt_model

        held = ", ".join(f"{k}/{js['best']['total'][r]} at {r} Hz" for r, k in js["best"]["held"].items())
        print(f"  joint search ({js['evaluations']} models, {js['wall_time_s']:.0f} s): best "
              f"{_fmt_model(js['best']['model'])}: {held}, penalty {js['best']['penalty']:.2f}")
    print(f"wrote {out}/reproduce.html (+ figures, metrics.csv, reproduce.json) "
          f"in {report['wall_time_s']:.0f} s")
    return 0


def cmd_examples(args):
    """`hybridsim examples`: copy the shipped diagrams into a folder. Returns the exit status."""
    from hybridsim.app.examples import copy_examples

    written, kept = copy_examples(args.output)
    for f in kept:
        print(f"kept {f} (it exists; hybridsim does not replace it)")
    print(f"wrote {len(written)} diagram file(s) into {args.output}/: try "
          f"'hybridsim run {Path(args.output) / 'fig9_force_and_position.yaml'}'")
    return 0


def cmd_schema(args):
    """`hybridsim schema`: the JSON Schema of the diagram format, for editors. Returns the exit status."""
    from hybridsim.files import atomic_file
    from hybridsim.format.schema import diagram_schema

    text = json.dumps(diagram_schema(), indent=1) + "\n"
    if not args.output:
        sys.stdout.write(text)
        return 0
    out = check_output_file(args.output, ["json"])
    with atomic_file(out, "w") as fh:
        fh.write(text)
    print(f"wrote {out}: attach it with the first line of a diagram\n"
          f"  # yaml-language-server: $schema={out}")
    return 0


def cmd_fmu_build(args):
    """`hybridsim fmu build`: export the plant FMU (FMI 2.0 or 3.0). Returns the exit status."""
    from hybridsim.fmus.build import build_plant_fmu

    from hybridsim.files import _record

    out = check_output_file(args.output or "plant.fmu", ["fmu"])
    if not args.output:
        out, note = default_output_file(out)
        if note:
            print(note, file=sys.stderr)
    out = build_plant_fmu(out, fmi=args.fmi)
    _record(Path(out).parent, [Path(out).name])
    print(f"wrote {out} (FMI {args.fmi}.0, Co-Simulation and Model Exchange, sources included)")
    return 0


def cmd_fmu_export(args):
    """`hybridsim fmu export`: a diagram or subsystem as a Co-Simulation FMU. Returns the exit status."""
    from hybridsim.fmi.export import export_fmu

    out = export_fmu(args.diagram, check_output_file(args.output, ["fmu"]), fmi=args.fmi)
    print(f"wrote {out} (FMI {args.fmi}.0 Co-Simulation; it runs the diagram with hybridsim, "
          "which the importing Python must have installed)")
    return 0


def cmd_sweep(args):
    """`hybridsim sweep`: a resumable parameter sweep. Returns the exit status."""
    from hybridsim.runs.sweep import run_sweep

    out = check_output_dir(Path(args.output or Path("out") / safe_name(Path(args.sweep).stem)))
    if not args.output:
        check_default_dir(out)
    rows = run_sweep(_find_diagram(args.sweep), out, jobs=args.jobs, dask=args.dask, progress=not args.quiet,
                     compiled=args.compiled, force=args.force)
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"{len(rows)} rows ({len(failed)} failed) -> {out}/sweep.csv, sweep.parquet, heatmap.png, points.jsonl")
    for r in failed[:5]:
        print(f"  failed {r['key']}: {r['message']}")
    return 0


def cmd_tune(args):
    """`hybridsim tune`: search a diagram's parameters against objectives and constraints. Returns the exit status."""
    from hybridsim.tune import run_tune
    from hybridsim.tune.report import summary_lines

    out = check_output_dir(Path(args.output or Path("out") / ("tune_" + safe_name(Path(args.tune).stem))))
    if not args.output:
        check_default_dir(out)
    res = run_tune(_find_diagram(args.tune), out, jobs=args.jobs, dask=args.dask, progress=not args.quiet,
                   force=args.force, compiled=args.compiled)
    print("\n".join(summary_lines(res)))
    return 0


def _num(v):
    """A number for people: 4 significant digits (or 'n/a')."""
    return f"{v:.4g}" if isinstance(v, (int, float)) else "n/a"


def cmd_blocks(args):
    """`hybridsim blocks`: the block library by group. Returns the exit status."""
    from hybridsim.engine.registry import GROUP_ORDER, group, lookup, parameters, types

    by_group = {}
    for name in types():
        by_group.setdefault(group(lookup(name)), []).append(name)
    order = [g for g in GROUP_ORDER if g in by_group] + sorted(set(by_group) - set(GROUP_ORDER))
    for g in order:
        print(f"\n{g}:" if g != order[0] else f"{g}:")
        for name in by_group[g]:
            _describe(name, lookup(name), args.verbose)
    return 0


def _describe(name, cls, verbose):
    """One block type's lines of `hybridsim blocks`."""
    import inspect

    from hybridsim.engine.registry import parameters

    req, opt = parameters(cls)
    lines = (cls.__doc__ or "").strip().splitlines()
    doc = lines[0] if lines else f"(no description: {cls.__module__}.{cls.__qualname__} has no docstring)"
    print(f"  {name:26s} {doc}")
    if not verbose:
        return
    sig = inspect.signature(cls.__init__).parameters
    shown = [p if p in req else f"{p}={sig[p].default!r}" for p in req + opt]
    print(f"  {'':26s} parameters: {', '.join(shown) or 'none'}")
    try:  # the ports of a block with its defaults (a block that needs a file has none to show)
        blk = cls(name="b")
    except Exception:  # noqa: BLE001 - only for showing
        return
    port = lambda p: f"{p.name}[{p.width}]"  # noqa: E731
    print(f"  {'':26s} inputs: {', '.join(map(port, blk.inputs)) or 'none'}; "
          f"outputs: {', '.join(map(port, blk.outputs)) or 'none'}"
          + (f"; rate {float(1 / blk.period):g} Hz" if blk.period else "")
          + (f"; {blk.n_continuous} continuous states" if blk.n_continuous else ""))


class _Stderr(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is at the time (tests and tools replace it)."""

    stream = property(lambda self: sys.stderr, lambda self, value: None)


_notes = _Stderr()
_notes.setFormatter(logging.Formatter("  %(message)s"))


def _show_notes():
    """hybridsim's INFO messages (e.g. "compiling ... with numba") on stderr."""
    log = logging.getLogger("hybridsim")
    if _notes not in log.handlers:
        log.addHandler(_notes)
        log.setLevel(logging.INFO)


def _jobs(text):
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a whole number of processes, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expects at least 1 process, got {n}")
    return n


def _count(text):
    """A whole number >= 1 (argparse type)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a whole number, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expects at least 1, got {n}")
    return n


def _seconds(text):
    try:
        t = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expects a time in seconds, got {text!r}") from None
    if not (math.isfinite(t) and t >= 0):
        raise argparse.ArgumentTypeError(f"expects a finite time >= 0 s, got {text!r}")
    return t


class Terminated(BaseException):
    """SIGTERM, raised like Ctrl-C so temporary files are removed on the way out."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _at_option(parser):
    """The operating point option of analyze and report."""
    parser.add_argument("--at", type=_seconds, metavar="T",
                        help="linearize about the state at T s of simulation (default: the diagram's "
                             "'analysis: at', else its initial state)")


def build_parser():
    """The argparse parser of the ``hybridsim`` command and its subcommands."""
    p = argparse.ArgumentParser(
        prog="hybridsim",
        description="Simulate block diagrams of robot force control (Raibert & Craig's hybrid "
                    "position/force controller) from YAML files.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--debug", action="store_true", help="show a traceback on internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    def with_diagram(sp):
        sp.add_argument("diagram", help="YAML diagram file (see diagrams/)")
        sp.add_argument("--set", action="append", metavar="PATH=VALUE",
                        help="override a parameter (repeatable)")

    r = sub.add_parser("run", help="simulate every variant; write CSV, plots and metrics.json",
                       description="Simulate a diagram (all its variants) and write, atomically, "
                                   "a CSV per run, a figure in the paper's layout (PNG and SVG) "
                                   "and metrics.json into OUTDIR.")
    with_diagram(r)
    r.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/<name>)")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    r.add_argument("--compiled", action="store_true",
                   help="run the whole loop compiled with numba (RK4; every block needs kernels). "
                        "The first run of a diagram compiles it, later runs load it "
                        "from the cache ($HYBRIDSIM_CACHE or ~/.cache/hybridsim)")
    r.set_defaults(func=cmd_run)
    c = sub.add_parser("check", help="validate a diagram without running it")
    with_diagram(c)
    c.set_defaults(func=cmd_check)
    d = sub.add_parser("draw", help="render the diagram as a picture (one colour per rate)")
    with_diagram(d)
    d.add_argument("-o", "--output", metavar="FILE",
                   help="image file (.png, .svg, .pdf; default NAME.png, never replacing a file hybridsim "
                        "did not write: then NAME-2.png, ...)")
    d.add_argument("--expand", action="store_true",
                   help="draw every block inside subsystems (default: a subsystem is one box)")
    d.set_defaults(func=cmd_draw)
    a = sub.add_parser("analyze", help="linearize: closed-loop poles, margins, rate and gain sweeps",
                       description="Linearize the diagram about its initial state (or the state at "
                                   "--at seconds) and print the sampled-data closed-loop poles, loop "
                                   "margins at the analysis points, and stability against servo rate "
                                   "and gain scaling (settings: the diagram's 'analysis' section).")
    with_diagram(a)
    _at_option(a)
    a.add_argument("-o", "--output", metavar="OUTDIR", help="also write OUTDIR/analysis.json")
    a.set_defaults(func=cmd_analyze)
    rp = sub.add_parser("report", help="HTML stability report with Bode, root locus, pole map, sweeps",
                        description="Analyse every variant (and each 'analysis.compare' setting) and "
                                    "write one self-contained report.html with PNG/SVG figures.")
    with_diagram(rp)
    _at_option(rp)
    rp.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/<name>_report)")
    rp.set_defaults(func=cmd_report)
    rr = sub.add_parser("reproduce", help="run every experiment of the paper and check its claims",
                        description="Run Figs 7-10 and eq 18 as printed, check each of the paper's "
                                    "claims, search the smallest damping that reproduces what fails, "
                                    "explain it with the stability analysis, and run sensitivities. "
                                    "Writes one self-contained HTML report.")
    rr.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/reproduce)")
    rr.add_argument("-j", "--jobs", type=_jobs, help="parallel processes (default: one per core)")
    rr.add_argument("--compiled", action="store_true",
                    help="every simulation on the compiled path (numba): the first time compiles "
                         "each diagram structure it uses, later runs load them from the cache")
    rr.add_argument("--quick", action="store_true",
                    help="eq 18 only, one damping trial, no sensitivities: a smoke test in seconds")
    rr.add_argument("--joint-search", type=_count, metavar="N",
                    help="also search every unstated assumption jointly (Optuna TPE, seeded), judging N models "
                         "at 60, 80 and 120 Hz; each model is ten experiment runs")
    rr.set_defaults(func=cmd_reproduce)
    ex = sub.add_parser("examples", help="copy the shipped diagrams into a folder you can edit",
                        description="Copy every shipped diagram (the paper's figures, the Fig 6 "
                                    "controller subsystem, the examples and the sweeps) into a folder. "
                                    "Files that exist there are left as they are.")
    ex.add_argument("-o", "--output", default="hybridsim-diagrams", metavar="DIR",
                    help="the folder to copy into (default hybridsim-diagrams)")
    ex.set_defaults(func=cmd_examples)
    sc = sub.add_parser("schema", help="write a JSON Schema of the diagram format (for editors)",
                        description="Generate a JSON Schema of the diagram format from the block registry "
                                    "(every block type with its parameters and defaults, plugins included, "
                                    "the simulation keys, signal roles). A YAML language server uses it to "
                                    "complete names and flag mistakes; attach it to a diagram with the line "
                                    "'# yaml-language-server: $schema=PATH'.")
    sc.add_argument("-o", "--output", metavar="FILE", help="the .json file to write (default: standard output)")
    sc.set_defaults(func=cmd_schema)
    fm = sub.add_parser("fmu", help="FMU tools: 'hybridsim fmu build' exports the plant")
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
    fb.set_defaults(func=cmd_fmu_build)
    fe = fsub.add_parser("export", help="a diagram or subsystem as a Co-Simulation FMU (FMI 2.0 or 3.0)",
                         description="Wrap a diagram file as a Co-Simulation FMU with pythonfmu (FMI 2.0) or "
                                     "pythonfmu3 (FMI 3.0). A subsystem's inputs and outputs become the FMU's, "
                                     "its params the FMU's parameters; inside, the diagram runs with its own "
                                     "solver and rates. The FMU needs a Python with hybridsim installed.")
    fe.add_argument("diagram", help="the diagram or subsystem file (.yaml)")
    fe.add_argument("-o", "--output", default="diagram.fmu", metavar="FILE",
                    help="the FMU to write (default diagram.fmu)")
    fe.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version: 2 (the default) or 3")
    fe.set_defaults(func=cmd_fmu_export)
    fm.set_defaults(func=lambda a: (fm.print_help(), 2)[1])
    sw = sub.add_parser("sweep", help="run a parameter sweep in parallel (resumable)",
                        description="Run every point of a sweep file (grid, scaled gains, seeded random) "
                                    "on all local cores or a Dask cluster, reduce each run to metrics, "
                                    "and write sweep.csv, sweep.parquet and heatmap.png. Run it again to "
                                    "resume: finished points (points.jsonl) are skipped.")
    sw.add_argument("sweep", help="sweep file (see diagrams/sweeps/)")
    sw.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/<sweep name>)")
    sw.add_argument("-j", "--jobs", type=_jobs, help="local processes (default: one per core)")
    sw.add_argument("--dask", metavar="ADDRESS", help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    sw.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    sw.add_argument("--compiled", action="store_true",
                    help="run every point compiled with numba (compiles once, then cached)")
    sw.add_argument("--force", action="store_true",
                    help="when OUTDIR holds points of a different sweep (another diagram, set, "
                         "solver or hybridsim version), discard them and start afresh")
    sw.set_defaults(func=cmd_sweep)
    tu = sub.add_parser("tune", help="search parameters for objectives under constraints (resumable)",
                        description="Search the parameters a tune file names (bounds, log scale, integer or "
                                    "choice) for its objectives (run metrics, step responses, loop margins, "
                                    "largest |z|) under its constraints, with a seeded optimiser, on all local "
                                    "cores or a Dask cluster. Writes best.yaml (a diagram that extends the "
                                    "tuned one), best.json, evaluations.csv, convergence.png and, for two "
                                    "objectives, pareto.png. Run it again to resume (evaluations.jsonl).")
    tu.add_argument("tune", help="tune file (see diagrams/tune/)")
    tu.add_argument("-o", "--output", metavar="OUTDIR", help="output folder (default out/tune_<name>)")
    tu.add_argument("-j", "--jobs", type=_jobs, help="local processes (default: one per core)")
    tu.add_argument("--dask", metavar="ADDRESS", help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    tu.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    tu.add_argument("--compiled", action="store_true", help="run every point compiled with numba")
    tu.add_argument("--force", action="store_true",
                    help="when OUTDIR holds the points of a different search, discard them and start afresh")
    tu.set_defaults(func=cmd_tune)
    b = sub.add_parser("blocks", help="list the block types")
    b.add_argument("-v", "--verbose", action="store_true", help="with their parameters")
    b.set_defaults(func=cmd_blocks)
    for sp in sub.choices.values():
        sp.add_argument("--plugin", action="append", metavar="MODULE", dest="plugins",
                        help="import MODULE first, for the blocks it registers (repeatable); installed "
                             "plugins (entry-point group hybridsim.blocks) load by themselves")
    return p


def _report(exc):
    """Print a HybridsimError as one message; its family's exit status."""
    print(f"error: {exc}", file=sys.stderr)
    return exc.exit_code


def _warn_replaced():
    """The warning every command gives while a plugin replaces a block type."""
    from hybridsim.engine.registry import _load_libraries, replacement_warnings

    _load_libraries()
    for line in replacement_warnings():
        print(line, file=sys.stderr)


def _origin(exc):
    """The HybridsimError that says where ``exc`` came from: a plugin's code (exit 6), the
    environment (exit 5: an OSError, no memory, a missing package), or None (a bug: exit 70)."""
    from hybridsim.errors import EnvironmentProblem, from_os_error, missing_dependency
    from hybridsim.engine.registry import plugin_fault

    fault = plugin_fault(exc)
    if fault is not None:
        return fault
    if isinstance(exc, SystemExit):
        return None
    if isinstance(exc, ImportError):
        return missing_dependency(exc)
    if isinstance(exc, OSError) and exc.errno:
        return from_os_error(exc)
    if type(exc).__name__ == "LinAlgError":  # numpy's: a model whose matrices are not finite
        from hybridsim.errors import SimulationError

        return SimulationError(f"the linearized model has no finite solution ({exc}): the model, or a "
                               "setting of the analysis (a rate, a gain scale), makes it overflow")
    if isinstance(exc, MemoryError):
        return EnvironmentProblem("out of memory (the machine refused an allocation); lower the "
                                  "run's size or free memory")
    return None


def main(argv=None):
    """Run the ``hybridsim`` command with ``argv`` (default: sys.argv); returns the exit status (docs/getting-started.md, "Exit status")."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _show_notes()
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave signals alone
        previous = None
    try:
        for module in getattr(args, "plugins", None) or []:
            from hybridsim.engine.registry import load_plugin

            load_plugin(module)
        _warn_replaced()
        return args.func(args)
    except HybridsimError as exc:
        return _report(exc)
    except KeyboardInterrupt:
        print("interrupted; earlier results left as they were", file=sys.stderr)
        return 130
    except Terminated:
        print("terminated; earlier results left as they were", file=sys.stderr)
        return 143
    except SystemExit as exc:  # a plugin's code called sys.exit: not the command's status
        fault = _origin(exc)
        if fault is None:
            raise
        return _report(fault)
    except Exception as exc:  # noqa: BLE001 - last line of defence, see --debug
        if args.debug:
            raise
        fault = _origin(exc)
        if fault is not None:
            return _report(fault)
        print(f"internal error: {type(exc).__name__}: {exc}\n"
              "(this is a bug in hybridsim; run again with --debug for the traceback)", file=sys.stderr)
        return 70
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


