"""The option spellings shared by commands, one home each.

Every command that reads a lift table takes ``--angle-unit``/``--length-unit``
(:func:`add_table_units`); every command that writes a bag takes
``--compression/--no-compression`` (:func:`add_compression`; the older
``--compress/--no-compress`` is a hidden alias); the HTML report option is ``--report``
(``--html`` a hidden alias where it was spelled so). ``--help`` lists a command's
arguments in the order of :data:`HELP_ORDER` (test/test_cli_conventions.py walks every
command and checks it).
"""
from __future__ import annotations

import argparse

#: units a gauge table may be written in (the values: SI factors live in
#: ``cam_design.lift_table.samples``; the choices here are the same names)
ANGLE_UNIT_CHOICES = ('deg', 'rad')
LENGTH_UNIT_CHOICES = ('mm', 'um', 'm')

#: where an option stands in ``--help``: positional arguments, then inputs, outputs,
#: the command's own options, and last the debugging/verbosity switches
HELP_ORDER = ('positional', 'input', 'output', 'option', 'debug')
INPUT_OPTIONS = frozenset({
    '--scene', '--params', '--valve-train', '--machine', '--measured', '--topics',
    '--angle-unit', '--length-unit'})
OUTPUT_OPTIONS = frozenset({
    '--out', '--out-bag', '--json', '--csv', '--dfq', '--plot', '--report', '--nominal',
    '--scene-out', '--profile-csv'})
DEBUG_OPTIONS = frozenset({'--quiet', '--keep-logs', '--debug'})


def help_group(action: argparse.Action) -> str:
    """The :data:`HELP_ORDER` group of a parser argument."""
    if not action.option_strings:
        return 'positional'
    names = set(action.option_strings)
    for group, members in (('input', INPUT_OPTIONS), ('output', OUTPUT_OPTIONS),
                           ('debug', DEBUG_OPTIONS)):
        if names & members:
            return group
    return 'option'


def add_table_units(parser: argparse.ArgumentParser, what: str = 'a gauge TABLE') -> None:
    """``--angle-unit deg|rad`` and ``--length-unit mm|um|m`` of the lift table read
    (gauge files; a CSV names its units in its column names)."""
    parser.add_argument('--angle-unit', choices=ANGLE_UNIT_CHOICES,
                        help=f'angle unit of {what} (default deg)')
    parser.add_argument('--length-unit', choices=LENGTH_UNIT_CHOICES,
                        help=f'length unit of {what} (default mm)')


def table_units(args: argparse.Namespace) -> dict[str, str]:
    """The ``angle_unit``/``length_unit`` keywords of the table readers (defaults deg, mm)."""
    return {'angle_unit': getattr(args, 'angle_unit', None) or 'deg',
            'length_unit': getattr(args, 'length_unit', None) or 'mm'}


def add_compression(parser: argparse.ArgumentParser) -> None:
    """``--compression/--no-compression`` (zstd chunks of the bag written; default on),
    with the older ``--compress/--no-compress`` as a hidden alias."""
    parser.add_argument('--compression', action=argparse.BooleanOptionalAction, default=True,
                        help='zstd chunk compression of the bag (default on; '
                             '--no-compression: plain chunks)')
    parser.add_argument('--compress', dest='compression', action=argparse.BooleanOptionalAction,
                        default=argparse.SUPPRESS, help=argparse.SUPPRESS)


def add_report(parser: argparse.ArgumentParser, help_text: str,
               aliases: tuple[str, ...] = ()) -> None:
    """``--report FILE.html`` (a self-contained HTML report); ``aliases``: older
    spellings kept, hidden."""
    parser.add_argument('--report', metavar='FILE.html', help=help_text)
    for alias in aliases:
        parser.add_argument(alias, dest='report', metavar='FILE.html', help=argparse.SUPPRESS)
