"""`cam-bench` entry point.

One argparse parser built here from :data:`COMMANDS`, the one command tree. Each command
has a module of its own in this package (a sub-command group is a package with one
module per sub-command): ``register(sub) -> ArgumentParser`` adds the command's parser
and arguments, ``run(args) -> int`` is its handler (bound to the parser here, nowhere
else). Option spellings shared by commands live in ``conventions``. Modules import
their heavy dependencies (numpy solvers, rclpy) inside the handlers, so ``--help`` stays
fast and numeric commands never load ROS.
"""
from __future__ import annotations

import os

# Small dense solves (splines, 2x2..100x100 systems) dominate our numerics; the bundled
# multi-threaded OpenBLAS made them 100-1000x slower on a loaded 2-core machine. Must be
# set before numpy is first imported; a user's explicit setting wins.
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import argparse  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402
from contextlib import contextmanager  # noqa: E402
from typing import Any, Iterator, Sequence  # noqa: E402
from cam_design.errors import CliError  # noqa: E402,F401 (the CLI's sentence error)

#: The command tree in the order of ``cam-bench --help``: a module name (relative to this
#: package) is one command; a pair (group, its sub-command modules) a group whose
#: package ``register`` adds the group parser.
COMMANDS: tuple[str | tuple[str, tuple[str, ...]], ...] = (
    'demo', 'record', 'replay', 'run_node',
    'analyze', 'golden', 'batch', 'spc', 'reconstruct', 'dynamics',
    ('rig', ('rig.analyze', 'rig.calibrate', 'rig.simulate')),
    ('design', ('design.law', 'design.check', 'design.rocker', 'design.profile',
                'design.optimize')),
    ('grind', ('grind.table', 'grind.master', 'grind.errors', 'grind.correct')),
    ('scene', ('scene.check',)),
    'simulate',
    ('bag', ('bag.info', 'bag.check', 'bag.recover')),
    'card',
)

EPILOG = """\
Units: SI in files and messages (m, rad, kg, N, s); reports add _deg, _um, _mm, _rpm
fields. Bad input exits with code 2 and a message naming the key, the value and what
was expected. An unexpected failure is one line too (exit 1); `cam-bench --debug ...`
or CAM_BENCH_DEBUG=1 adds the Python traceback. Ctrl-C (SIGINT) exits 130, SIGTERM
143, each with a line saying what was kept (docs/reliability.md). See docs/contract.md
for the topics and the report schema, docs/scene.md for the scene file."""


class _Version(argparse.Action):
    """``--version``: the version and git commit (git is run only when asked)."""

    def __call__(self, parser: argparse.ArgumentParser, *_: object) -> None:
        from cam_metrology.report.provenance import version_text
        print(version_text())
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    """The full parser with every available subcommand registered."""
    parser = argparse.ArgumentParser(
        prog='cam-bench',
        description='Camshaft metrology, profile reconstruction and valve-train dynamics '
                    'on ROS 2, with MCAP recording and replay.',
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--version', action=_Version, nargs=0,
                        help='print the version (and git commit) and exit')
    parser.add_argument('--debug', action='store_true',
                        help='on an unexpected error, print the Python traceback as well '
                             f'(or set {DEBUG_ENV}=1)')
    sub = parser.add_subparsers(dest='command', metavar='COMMAND')
    register_commands(sub, COMMANDS)
    return parser


def register_commands(sub: argparse._SubParsersAction,
                      commands: Sequence[str | tuple[str, tuple[str, ...]]]) -> None:
    """Add the parsers of ``commands`` (entries of :data:`COMMANDS`) to ``sub``: each
    command module's parser with ``func=<module>.run``; a group's parser with its
    sub-commands under ``<group>_command``."""
    for entry in commands:
        if isinstance(entry, str):
            module = _command_module(entry)
            module.register(sub).set_defaults(func=module.run)
            continue
        group, children = entry
        parser = _command_module(group).register(sub)
        group_sub = parser.add_subparsers(dest=f'{group}_command', metavar='WHAT')
        register_commands(group_sub, children)


def _command_module(name: str) -> Any:
    """The module ``cam_metrology.cli.<name>``."""
    return importlib.import_module(f'{__name__}.{name}')


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the process exit code (docs/contract.md, "Command line")."""
    from cam_metrology.host.interrupts import COMPLETE, Interrupted, catch_signals, settle_signals

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, 'func', None):
        parser.print_help()
        return 0 if args.command is None else 2
    name = command_name(args)
    debug = bool(args.debug or os.environ.get(DEBUG_ENV, '').strip() not in ('', '0'))
    with catch_signals(), checked_stdout():
        try:
            code = _run_command(args, name, debug, argv)
        except Interrupted as exc:    # the command's finally clauses have run
            return _say_interrupted(name, exc)
        try:   # a signal after the outputs were complete is reported, never lost
            late = settle_signals(keep_blocked=argv is None)
        except Interrupted as exc:
            exc.add_note(COMPLETE)
            late = exc
    return code if late is None else _say_interrupted(name, late)


def _run_command(args: argparse.Namespace, name: str, debug: bool,
                 argv: Sequence[str] | None) -> int:
    """The handler's exit code, every failure turned into one line on stderr."""
    from cam_design.errors import InputError
    from cam_metrology.host.interrupts import Interrupted

    try:
        code = int(args.func(args) or 0)
        sys.stdout.flush()   # a full disk behind stdout: one line, exit 2
        return code
    except (InputError, CliError, FileNotFoundError) as exc:
        print(f'cam-bench {name}: error: {one_line(str(exc))}', file=sys.stderr)
        return 2
    except Interrupted:
        raise
    except KeyboardInterrupt as exc:   # raised by code that installed its own handler
        raise Interrupted('SIGINT', *getattr(exc, '__notes__', [])) from None
    except BrokenPipeError:
        # the reader went away (`cam-bench ... | head`): not an error of ours; point
        # stdout at /dev/null so the interpreter's final flush does not raise again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except Exception as exc:   # noqa: BLE001 -- the last resort: one line, exit 1
        if debug:
            import traceback
            traceback.print_exc()
        print(f'cam-bench {name}: unexpected error on {input_words(args, argv)}: '
              f'{describe_exception(exc)}'
              + ('' if debug else f' (run with --debug or {DEBUG_ENV}=1 for the traceback)'),
              file=sys.stderr)
        return 1


def _say_interrupted(name: str, exc: BaseException) -> int:
    """Print the interruption line (signal and what was kept); the exit code."""
    from cam_metrology.host.interrupts import exit_code

    signame = exc.args[0] if exc.args else 'SIGINT'
    notes = [one_line(n) for n in getattr(exc, '__notes__', [])]
    outcome = '; '.join(notes) or ('nothing half-written: every output is either complete '
                                   'or absent')
    print(f'cam-bench {name}: interrupted by {signame}: {outcome}', file=sys.stderr)
    return exit_code(signame)


@contextmanager
def checked_stdout() -> Iterator[None]:
    """The process's own standard output wrapped in ``files.CheckedStdout`` for the
    command (a replaced ``sys.stdout``, e.g. a test's capture, is left alone)."""
    from cam_metrology.inputs.files import CheckedStdout

    if sys.stdout is not sys.__stdout__ or sys.stdout is None:
        yield
        return
    real = sys.stdout
    sys.stdout = CheckedStdout(real)  # type: ignore[assignment]
    try:
        yield
    finally:
        sys.stdout = real


#: environment variable that turns on --debug (tracebacks of unexpected errors)
DEBUG_ENV = 'CAM_BENCH_DEBUG'


def one_line(text: str, limit: int = 600) -> str:
    """``text`` on one line (newlines as ' | '), cut to ``limit`` characters."""
    flat = ' | '.join(part.strip() for part in text.splitlines() if part.strip())
    return flat if len(flat) <= limit else flat[:limit - 3] + '...'


def describe_exception(exc: BaseException) -> str:
    """``Type: message`` of an unexpected exception; for an OSError the reason and the
    file it concerns."""
    if isinstance(exc, OSError) and exc.strerror:
        where = f' ({exc.filename})' if exc.filename else ''
        return f'{type(exc).__name__}: {exc.strerror}{where}'
    return one_line(f'{type(exc).__name__}: {exc}')


def input_words(args: argparse.Namespace, argv: Sequence[str] | None) -> str:
    """The input the command was given, for the one line of an unexpected error: the
    files among the arguments after the command words (a word naming an existing path,
    or with a file suffix, also as ``--option=FILE``), quoted and comma-separated; when
    none is a file, the arguments as typed (cut to 300 characters)."""
    words = list(sys.argv[1:] if argv is None else argv)
    skip = set(command_name(args).split()) | {'--debug'}
    while words and words[0] in skip:
        words.pop(0)
    files = [w for w in (word.split('=', 1)[-1] for word in words) if _names_a_file(w)]
    if files:
        return ', '.join(repr(f) for f in dict.fromkeys(files))
    text = ' '.join(words) or '(no arguments)'
    return repr(text if len(text) <= 300 else text[:297] + '...')


def _names_a_file(word: str) -> bool:
    """Whether a command-line word names a file: not an option nor a number, and an
    existing path or a name with a suffix (``0.5`` and ``0.5,1e-3`` are values,
    ``lobe.csv`` a file)."""
    if not word or word.startswith('-'):
        return False
    if os.path.exists(word):
        return True
    try:   # a number, or a list of them (``0.5,1e-3``)
        [float(part) for part in word.split(',')]
        return False
    except ValueError:
        return bool(os.path.splitext(word)[1][1:])


def command_name(args: argparse.Namespace) -> str:
    """The command as typed, e.g. ``design law`` (group plus ``*_command`` sub-choices)."""
    parts = [args.command] + [value for key, value in sorted(vars(args).items())
                              if key.endswith('_command') and isinstance(value, str)]
    return ' '.join(p for p in parts if p)


if __name__ == '__main__':
    sys.exit(main())
