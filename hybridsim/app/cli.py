"""The ``hybridsim`` command: a thin layer over the Python API.

Each command is a module of this package with its argparse spec (``add``) and a
``run(args)`` that makes one call of the Python API and prints the result
(``hybridsim.app.run``, ``check``, ``draw``, ``analyze`` (analyze, report), ``sweep``,
``tune``, ``reproduce``, ``fmu`` (build, export), ``examples``, ``blocks``, ``schema``);
this module assembles them (:data:`COMMANDS`) and turns every failure into its message
and exit status.

Exit status by origin (the table in :mod:`hybridsim.errors`): 0 success; 2 bad
input; 3 the model diverged or its solver failed; 4 an FMU; 5 the environment
(disk full, permission, a missing package); 6 a plugin's fault; 70 an internal
error (please report it, with ``--debug``).
"""
import argparse
import logging
import os
import signal
import sys

from hybridsim.app import analyze, blocks, check, draw, examples, fmu, reproduce, run, schema, sweep, tune
from hybridsim.errors import EXIT_CODES, HybridsimError
from hybridsim.format import tables
from hybridsim.format.overrides import overrides_from

#: the commands in the order ``hybridsim --help`` lists them
COMMANDS = [run, check, draw, analyze, reproduce, examples, schema, fmu, sweep, tune, blocks]

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
for one element), 'simulation.key' ({sim}), or 'metrics.key' ({metrics}).
A bare simulation key (t_end=5) is that setting unless 'params' has the name.
VALUE is read as YAML: 10, 1e-4, [5, 50], true.
A --set of a parameter that 'variants' sweeps fixes it to one run.
Every setting of every section: docs/settings.md. Limits checked before a
run (steps, log size, blocks, sweep points) are raised with environment
variables, e.g. HYBRIDSIM_MAX_STEPS=1e9.

exit status: {codes}.
""".format(sim=tables.help_text(tables.SIMULATION), metrics=tables.help_text(tables.METRICS),
           codes="; ".join(f"{code} {origin}" for code, origin, _ in EXIT_CODES))


def build_parser():
    """The argparse parser of the ``hybridsim`` command and its subcommands."""
    p = argparse.ArgumentParser(
        prog="hybridsim",
        description="Simulate block diagrams of robot force control (Raibert & Craig's hybrid "
                    "position/force controller) from YAML files.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--debug", action="store_true", help="show a traceback on internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.add(sub)
    for sp in sub.choices.values():
        sp.add_argument("--plugin", action="append", metavar="MODULE", dest="plugins",
                        help="import MODULE first, for the blocks it registers (repeatable); installed "
                             "plugins (entry-point group hybridsim.blocks) load by themselves")
    return p


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


class Terminated(BaseException):
    """SIGTERM, raised like Ctrl-C so temporary files are removed on the way out."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _report(exc):
    """Print a HybridsimError as one message; its family's exit status."""
    print(f"error: {exc}", file=sys.stderr)
    return exc.exit_code


def _warn_replaced():
    """The warning every command gives while a plugin replaces a block type."""
    from hybridsim.engine.registry import replacement_warnings, types

    types()  # the library and the installed plugins, loaded
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


class _Stdout:
    """stdout that goes quiet once its reader has gone (``hybridsim analyze ... | head -1``): the
    command still finishes its work and its files."""

    def __init__(self, stream):
        self._stream, self.gone = stream, False

    def write(self, text):
        if not self.gone:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._went()
        return len(text)

    def flush(self):
        if not self.gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._went()

    def _went(self):
        self.gone = True
        try:  # what is still buffered, and the flush at exit, go nowhere instead of failing
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)
        except (OSError, ValueError, AttributeError):
            pass

    def __getattr__(self, name):
        return getattr(self._stream, name)


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
    stdout = sys.stdout
    sys.stdout = _Stdout(stdout)
    try:
        for module in getattr(args, "plugins", None) or []:
            from hybridsim.engine.registry import load_plugin

            load_plugin(module)
        _warn_replaced()
        with overrides_from("--set"):  # the command line's overrides are its --set options
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
        sys.stdout = stdout
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


