"""Command groups (``cam-bench design law``, ``grind table``, ...): the group parser.

A group's package ``__init__`` calls :func:`add_group` from its ``register``; the
registry in ``cli/__init__.py`` adds the group's sub-commands under it.
"""
from __future__ import annotations

import argparse


def add_group(sub: argparse._SubParsersAction, name: str, help_text: str,
              description: str) -> argparse.ArgumentParser:
    """The parser of the group ``name WHAT``; without WHAT it prints its help (exit 2)."""
    parser: argparse.ArgumentParser = sub.add_parser(name, help=help_text,
                                                     description=description)

    def show_help(args: argparse.Namespace) -> int:
        parser.print_help()
        return 2

    parser.set_defaults(func=show_help)
    return parser
