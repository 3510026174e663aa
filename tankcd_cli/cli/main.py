"""The ``tankcd`` group: wiring only (version, -v/-q, exit codes, lazy commands)."""

from __future__ import annotations

import atexit
import importlib
import os
import signal
import sys
import threading
import traceback
import warnings

import click

from tankcd_cli import __version__
from tankcd_cli.cli.options import QUIET_HELP, VERBOSE_HELP, set_verbosity, strict_option
from tankcd_cli.cli.report import Reporter
from tankcd_cli.errors import InputError, SetupWarning, printable
from tankcd_cli.io.exit_guard import guard_termination

# command name -> (module, short help); modules are imported only when run
COMMANDS = {
    "classify": ("tankcd_cli.cli.classify", "Classify a terrain: mean curvature and region classes into an HDF5 store."),
    "info": ("tankcd_cli.cli.info", "Describe any file tankcd reads or writes (stores, terrains, outputs)."),
    "bvh": ("tankcd_cli.cli.bvh", "Build a serialized bounding-volume tree of a model or a scene's obstacles."),
    "collide": ("tankcd_cli.cli.collide", "Test the vehicle at given poses against the scene's obstacles."),
    "demo": ("tankcd_cli.cli.demo", "Run the whole pipeline on the bundled sample battlefield."),
    "export": ("tankcd_cli.cli.export", "Write a trajectory (CSV, GPX, DIS capture) as the CSV replay reads."),
    "envelope": ("tankcd_cli.cli.envelope", "Lowest safe gun elevation per turret azimuth (the rear fuel drums)."),
    "replay": ("tankcd_cli.cli.replay", "Replay a trajectory over a terrain: one pose per row."),
    "report": ("tankcd_cli.cli.review_command", "A replay's poses and events as a page, GeoJSON, CZML or a capture "
                                                "with Collision PDUs."),
    "tradeoff": ("tankcd_cli.cli.tradeoff", "Measure what accuracy costs in time: tables, CSV and plots."),
}

from tankcd_cli.names import EXIT_BAD_INPUT, EXIT_DONE, EXIT_INTERNAL  # noqa: E402


class LazyGroup(click.Group):
    """Loads a command's module only when that command runs, so --help is instant,
    and maps exceptions onto the exit codes (``names``; README "Exit codes")."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module = importlib.import_module(COMMANDS[name][0])
        return getattr(module, name)

    def format_commands(self, ctx, formatter):
        rows = [(name, COMMANDS[name][1]) for name in self.list_commands(ctx)]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def invoke(self, ctx):
        with warnings.catch_warnings():
            # warnings print as one line each; --strict (a callback) turns them into errors
            warnings.simplefilter("error" if ctx.meta.get("tankcd.strict") else "always", SetupWarning)
            warnings.showwarning = _show_warning
            return self._invoke_mapped(ctx)

    def _invoke_mapped(self, ctx):
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.exceptions.Abort, click.ClickException):
            raise
        except InputError as exc:
            click.echo(f"tankcd: error: {exc.one_line()}", err=True)
            _traceback_if_verbose(ctx)
            ctx.exit(EXIT_BAD_INPUT)
        except SetupWarning as exc:  # raised under --strict
            click.echo(f"tankcd: error: {exc.one_line()} (--strict)", err=True)
            _traceback_if_verbose(ctx)
            ctx.exit(EXIT_BAD_INPUT)
        except BrokenPipeError:
            _quiet_broken_pipe()
            ctx.exit(EXIT_DONE)
        except (KeyboardInterrupt, SystemError) as exc:
            # a signal that lands inside a compiled kernel surfaces as SystemError wrapping it
            inner = exc
            for _ in range(20):
                if not isinstance(inner, SystemError):
                    break
                inner = inner.__cause__ or inner.__context__
            if isinstance(inner, KeyboardInterrupt):
                _signal_exit(ctx, isinstance(inner, Terminated))
            self._internal_error(ctx, exc)
        except Exception as exc:  # a bug: say so, ask for a report
            self._internal_error(ctx, exc)

    @staticmethod
    def _internal_error(ctx, exc):
        if _SIGNALLED:  # a signal that surfaced as some other error (a library callback swallowed it)
            _signal_exit(ctx, _SIGNALLED[-1] == "term")

        first = str(exc).splitlines()[0] if str(exc) else ""
        click.echo(printable(f"tankcd: internal error: {type(exc).__name__}: {first} ")
                   + "(this is a bug; please report it with the command and input; -v shows the traceback)", err=True)
        _traceback_if_verbose(ctx)
        ctx.exit(EXIT_INTERNAL)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    ctx = click.get_current_context(silent=True)
    reporter = ctx.find_object(Reporter) if ctx is not None else None
    if reporter is not None and reporter.verbosity < 0:
        return  # -q: errors only (under --strict a warning is one)
    text = message.one_line() if isinstance(message, SetupWarning) else f"{category.__name__}: {message}"
    if isinstance(message, SetupWarning) or issubclass(category, SetupWarning):
        click.echo(f"tankcd: warning: {text}", err=True)
    else:  # a library's own warning: keep Python's usual line
        sys.stderr.write(warnings_format(message, category, filename, lineno, line))


def warnings_format(message, category, filename, lineno, line=None) -> str:
    return warnings.formatwarning(message, category, filename, lineno, line)


def _signal_exit(ctx, terminated: bool) -> None:
    click.echo("tankcd: terminated" if terminated else "tankcd: interrupted", err=True)
    ctx.exit(143 if terminated else 130)


def _traceback_if_verbose(ctx) -> None:
    reporter = ctx.find_object(Reporter)
    if reporter is not None and reporter.verbosity >= 1:
        traceback.print_exc(file=sys.stderr)


def _quiet_broken_pipe() -> None:
    # the reader went away (``| head``): stop quietly, and keep Python from
    # complaining again when it flushes stdout at exit
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="tankcd")
@click.option("-v", "--verbose", count=True, help=VERBOSE_HELP)
@click.option("-q", "--quiet", is_flag=True, help=QUIET_HELP)
@strict_option
@click.pass_context
def cli(ctx, verbose, quiet):
    """tankcd: place a tank on real terrain and tell when it collides.

    Data goes to stdout or to files, messages and progress to stderr; -q keeps
    only errors (set-up warnings too go unsaid: --strict makes them errors),
    before or after the command name.
    Exit codes: 0 done, 1 collision with --fail-on-collision, 2 usage error,
    3 bad input data, 4 internal error.
    """
    ctx.obj = Reporter(0)
    set_verbosity(ctx, verbose, quiet)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Python runs next so that every ``finally`` (temporary outputs) runs."""


# which signals have come in: a signal raised inside a C callback (a library calling back into
# Python) is swallowed there and surfaces as an unrelated error; this record lets the exit say what happened
_SIGNALLED: list = []


def _on_sigterm(signum, frame):
    _SIGNALLED.append("term")
    raise Terminated()


def _on_sigint(signum, frame):
    _SIGNALLED.append("int")
    raise KeyboardInterrupt()


def main(argv=None):
    """Console-script entry point."""
    signal.signal(signal.SIGTERM, _on_sigterm)
    signal.signal(signal.SIGINT, _on_sigint)

    guard_termination()  # a SIGTERM that Python cannot answer (a long compiled call) ends the run in 1 s
    try:
        cli.main(args=argv, prog_name="tankcd")
    except BrokenPipeError:
        _quiet_broken_pipe()
        sys.exit(EXIT_DONE)


def console(argv=None):
    """Console-script entry point: ``main``, then an exit that skips tearing the interpreter down.

    Unloading numpy, h5py and the kernels module by module costs about 20 ms, a sixth of a short
    command's whole run, and frees nothing the operating system would not. Outputs are complete
    by then (every writer closes and renames its file before the command returns); Python's
    exit handlers still run and the standard streams are flushed. With other Python threads
    still alive, the ordinary exit joins them.
    """
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = exc.code
    atomic = sys.modules.get("tankcd_cli.io.atomic")
    if atomic is not None:  # a signal may have cut a writer short of its own clean-up
        atomic.remove_pending()
    code = 0 if code is None else code
    if not isinstance(code, int):
        raise SystemExit(code)
    _exit_quickly(code)


def _exit_quickly(code: int) -> None:
    if threading.active_count() > 1:
        sys.exit(code)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except BrokenPipeError:
            _quiet_broken_pipe()
        except (OSError, ValueError):
            pass
    atexit._run_exitfuncs()
    os._exit(code)

