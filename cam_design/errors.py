"""Errors for bad input: every message names the key, the value and what was expected."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any


class InputError(ValueError):
    """Invalid input value.

    Raised by every parser, law constructor and solver entry point of cam-bench when
    a parameter is out of its domain. The CLI turns it into a one-line error and a
    non-zero exit code, never a traceback.

    Attributes:
        key: dotted path of the offending parameter, e.g. ``lobes[0].lift.alpha``.
        value: the offending value (shortened in the message if long).
        expected: what would have been valid, in words.
    """

    def __init__(self, key: str, value: Any, expected: str) -> None:
        self.key = key
        self.value = value
        self.expected = expected
        super().__init__(f'{key}: got {_short(value)}; expected {expected}')


class CliError(Exception):
    """A user-facing error that is a whole sentence rather than a key and a value (the
    command line prints it in one line and exits 2)."""


def _short(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters; a file path (``os.PathLike``) is
    shown as its text, whole up to 1000 characters, so the message names a usable path."""
    import os

    if isinstance(value, os.PathLike):
        text, limit = repr(os.fspath(value)), max(limit, 1000)
    else:
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + '...'


def require_finite(key: str, value: Any) -> float:
    """Return ``value`` as float, or raise InputError if it is not a finite real number."""
    import math

    if isinstance(value, bool):
        raise InputError(key, value, 'a finite real number')
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InputError(key, value, 'a finite real number') from None
    if not math.isfinite(out):
        raise InputError(key, value, 'a finite real number')
    return out


def unit_slip(value: float, limit: float, floor: float = 0.0) -> tuple[str, float] | None:
    """(unit, factor to metres) when ``value``, meant in metres but implausible there,
    reads as millimetres or micrometres: the first of the two that brings it within
    [``floor``, ``limit``] m; None when neither does."""
    for unit, scale in (('millimetres', 1e-3), ('micrometres', 1e-6)):
        if floor <= value * scale <= limit:
            return unit, scale
    return None


def require_length(key: str, value: Any, limit: float, *, allow_zero: bool = False,
                   what: str = 'a length') -> float:
    """``value`` [m] as float if it is finite, > 0 (>= 0 with ``allow_zero``) and at most
    ``limit`` [m]; above it the message names the unit the number looks like (a radius
    of 16.5 given for 16.5 mm) and the value in metres."""
    out = require_positive(key, value, allow_zero=allow_zero)
    if out > limit:
        slip = unit_slip(out, limit)
        hint = '' if slip is None else (f'; {out:g} looks like {slip[0]}: write '
                                        f'{out * slip[1]:.6g}')
        raise InputError(key, value, f'{what} in metres (at most {limit:g} m){hint}')
    return out


def require_positive(key: str, value: Any, *, allow_zero: bool = False) -> float:
    """Return ``value`` as float if it is finite and > 0 (>= 0 with ``allow_zero``)."""
    out = require_finite(key, value)
    if out < 0 or (out == 0 and not allow_zero):
        raise InputError(key, value, 'a number >= 0' if allow_zero else 'a number > 0')
    return out


def require_mapping(value: Any, key: str, known: Sequence[str]) -> Mapping[str, Any]:
    """``value`` if it is a mapping whose keys are all in ``known``; else InputError
    naming ``key`` (not a mapping) or ``key.<first unknown key>`` (a typo)."""
    if not isinstance(value, Mapping):
        raise InputError(key, value, 'a mapping with keys ' + ', '.join(known))
    for k in value:
        if k not in known:
            raise InputError(f'{key}.{k}', value[k], 'one of ' + ', '.join(known))
    return value
