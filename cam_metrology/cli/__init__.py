"""`cam-bench` entry point.

One argparse parser; each subcommand group lives in its own module of this package
and exposes ``register(subparsers)``, which adds its parsers and sets
``func=<callable(args) -> int>``. Modules import their heavy dependencies (numpy
solvers, rclpy) inside the handlers, so ``--help`` stays fast and numeric commands
never load ROS.
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
from typing import Sequence  # noqa: E402
from cam_design.errors import CliError  # noqa: E402,F401 (the CLI's sentence error)

# Order here is the order in `cam-bench --help`.
COMMAND_MODULES = (
    'cam_metrology.cli.ros_cmds',      # demo, record, replay, run
    'cam_metrology.cli.analyze',       # analyze
    'cam_metrology.cli.golden',        # golden
    'cam_metrology.cli.batch',         # batch
    'cam_metrology.cli.spc',           # spc
    'cam_metrology.cli.reconstruct',   # reconstruct
    'cam_metrology.cli.dynamics',      # dynamics
    'cam_metrology.cli.rig',           # rig analyze|calibrate|simulate
    'cam_metrology.cli.design',        # design law|profile|check|rocker
    'cam_metrology.cli.grind',         # grind table|master|errors|correct
    'cam_metrology.cli.scene_cmds',    # scene check, simulate
    'cam_metrology.cli.card',          # card
)

EPILOG = """\
Units: SI in files and messages (m, rad, kg, N, s); reports add _deg, _um, _mm, _rpm
fields. Bad input exits with code 2 and a message naming the key, the value and what
was expected. See docs/contract.md for the topics and the report schema,
docs/scene.md for the scene file."""


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
    sub = parser.add_subparsers(dest='command', metavar='COMMAND')
    register_modules(sub, COMMAND_MODULES)
    return parser


def register_modules(sub: argparse._SubParsersAction, module_names: Sequence[str]) -> None:
    """Call ``register(sub)`` of each command module."""
    for name in module_names:
        importlib.import_module(name).register(sub)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the process exit code."""
    from cam_design.errors import InputError

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, 'func', None):
        parser.print_help()
        return 0 if args.command is None else 2
    name = command_name(args)
    try:
        return int(args.func(args) or 0)
    except (InputError, CliError, FileNotFoundError) as exc:
        print(f'cam-bench {name}: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'cam-bench {name}: interrupted', file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (`cam-bench ... | head`): not an error of ours; point
        # stdout at /dev/null so the interpreter's final flush does not raise again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


def command_name(args: argparse.Namespace) -> str:
    """The command as typed, e.g. ``design law`` (group plus ``*_command`` sub-choices)."""
    parts = [args.command] + [value for key, value in sorted(vars(args).items())
                              if key.endswith('_command') and isinstance(value, str)]
    return ' '.join(p for p in parts if p)


if __name__ == '__main__':
    sys.exit(main())
