"""One CLI convention, checked on every command's parser (no command is run).

Walks ``cam-bench``'s parser tree and asserts, per command: the arguments in ``--help``
in the order positional, inputs, outputs, options, debug; positional arguments
named in capitals; no notion with two visible
spellings (the old ones are hidden aliases that still parse); the lift-table unit
options on every command whose handler reads a lift table; every default shown; units
of numeric options in brackets (or in the option's name).
"""
from __future__ import annotations

import argparse
import inspect
import re
import sys
from typing import Iterator

import pytest

from cam_metrology.cli import build_parser
from cam_metrology.cli.conventions import HELP_ORDER, help_group

#: old spelling -> the one shown in --help
ALIASES = {'--feature': '--lobe', '--compress': '--compression', '--html': '--report'}
#: commands whose --feature filters any feature of a batch table (lobes, datum, journals),
#: not only lobes: there --feature is the right word
FEATURE_FILTERS = {'spc'}
#: the calls that read a lift table (CSV or gauge file) in a handler's module
TABLE_READERS = ('read_table_file(', 'table_input(')
#: option-name endings that carry the unit
UNIT_SUFFIXES = ('-deg', '-mm', '-um', '-rpm', '-m', '-s')


def _commands(parser: argparse.ArgumentParser, words: tuple[str, ...] = ()
              ) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """(command words, parser) of every command that has a handler of its own."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield ' '.join(words), parser
        return
    for name, child in subs[0].choices.items():
        yield from _commands(child, words + (name,))


COMMANDS = dict(_commands(build_parser()))


def _visible(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions
            if a.help != argparse.SUPPRESS and not isinstance(a, argparse._HelpAction)]


def _handler_source(parser: argparse.ArgumentParser) -> str:
    func = parser.get_default('func')
    return inspect.getsource(sys.modules[func.__module__])


def test_every_command_is_walked() -> None:
    """The walk reaches the groups' sub-commands (a broken walk would pass vacuously)."""
    for name in ('analyze', 'design law', 'grind correct', 'bag check', 'scene check',
                 'rig calibrate', 'record', 'card'):
        assert name in COMMANDS
    assert len(COMMANDS) >= 28


@pytest.mark.parametrize('name', sorted(COMMANDS))
def test_help_order(name: str) -> None:
    """Positional arguments, then inputs, outputs, the command's options, debug."""
    groups = [help_group(a) for a in _visible(COMMANDS[name])]
    ranks = [HELP_ORDER.index(g) for g in groups]
    assert ranks == sorted(ranks), list(zip(
        [a.option_strings or [a.dest] for a in _visible(COMMANDS[name])], groups))


@pytest.mark.parametrize('name', sorted(COMMANDS))
def test_one_visible_spelling(name: str) -> None:
    """An old spelling is never shown; where it is accepted, the new one is shown."""
    parser = COMMANDS[name]
    shown = {s for a in _visible(parser) for s in a.option_strings}
    accepted = {s for a in parser._actions for s in a.option_strings}
    for old, new in ALIASES.items():
        if old == '--feature' and name in FEATURE_FILTERS:
            continue
        assert old not in shown
        if old in accepted:
            assert new in shown


@pytest.mark.parametrize('name', sorted(COMMANDS))
def test_table_readers_take_the_unit_options(name: str) -> None:
    parser = COMMANDS[name]
    if not any(call in _handler_source(parser) for call in TABLE_READERS):
        return
    shown = {s for a in _visible(parser) for s in a.option_strings}
    assert {'--angle-unit', '--length-unit'} <= shown


@pytest.mark.parametrize('name', sorted(COMMANDS))
def test_defaults_shown_and_units_in_brackets(name: str) -> None:
    for action in _visible(COMMANDS[name]):
        if not action.option_strings:
            continue
        text = action.help or ''
        default = action.default
        unset = default is None or default is False or default == [] or \
            default is argparse.SUPPRESS    # (0 and 0.0 are defaults to show)
        if not unset and not isinstance(action, argparse.BooleanOptionalAction):
            assert 'default' in text, (action.option_strings, default, text)
        if action.type is float:
            long = max(action.option_strings, key=len)
            assert long.endswith(UNIT_SUFFIXES) or re.search(r'\[[^\]]+\]', text), \
                (action.option_strings, text)


@pytest.mark.parametrize('name', sorted(COMMANDS))
def test_positionals_are_named_in_capitals(name: str) -> None:
    """``cam-bench card SCENE|TABLE|BAG``: what the user types is named in capitals (a
    fixed set of words, e.g. ``run NODE``'s node names, is listed instead)."""
    for action in _visible(COMMANDS[name]):
        if not action.option_strings and not action.choices:
            shown = action.metavar or action.dest
            assert isinstance(shown, str) and shown == shown.upper(), (name, shown)


@pytest.mark.parametrize('name', sorted(COMMANDS))
def test_standard_output_said_one_way(name: str) -> None:
    """An output that may be ``-`` (metavar ``FILE|-``) says so in the same words."""
    for action in _visible(COMMANDS[name]):
        if str(action.metavar).endswith('|-'):
            assert '(- for standard output)' in (action.help or ''), action.option_strings


def test_hidden_aliases_still_parse() -> None:
    """The old spellings keep working and land where the new ones do."""
    parser = build_parser()
    args = parser.parse_args(['simulate', 'out', '--no-compress'])
    assert args.compression is False
    assert parser.parse_args(['simulate', 'out']).compression is True
    assert parser.parse_args(['reconstruct', 't.csv', '--feature', 'in1']).feature == 'in1'
    args = parser.parse_args(['rig', 'analyze', 'r.csv', '--html', 'x.html'])
    assert args.report == 'x.html'
