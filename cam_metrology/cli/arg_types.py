"""argparse value types shared by the commands (each refusal names the value typed and
what was expected; argparse turns it into the one-line usage error, exit 2)."""
from __future__ import annotations

import argparse


def non_negative(text: str) -> float:
    """argparse type: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        value = float('nan')
    if not 0.0 <= value < float('inf'):
        raise argparse.ArgumentTypeError(f'got {text!r}; expected a finite number >= 0')
    return value


def count(text: str) -> int:
    """argparse type: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f'got {text!r}; expected an integer >= 0')
    return value
