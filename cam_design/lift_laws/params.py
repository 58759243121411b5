"""Parameter access for lift-law specs: every error names ``key.param``."""
from __future__ import annotations

import math
from typing import Any, Mapping, Sequence, TypeVar

from cam_design.errors import InputError, require_finite, require_length, require_positive

MISSING = object()
T = TypeVar('T')


def mapping(spec: Any, key: str) -> Mapping:
    """``spec`` as a mapping, or InputError naming ``key``."""
    if not isinstance(spec, Mapping):
        raise InputError(key, spec, 'a mapping of parameters')
    return spec


def get(spec: Mapping, key: str, name: str, default: Any = MISSING) -> Any:
    """Raw parameter ``name`` (InputError if it is missing and has no default)."""
    if name in spec and spec[name] is not None:
        return spec[name]
    if default is MISSING:
        raise InputError(f'{key}.{name}', None, 'a value (required parameter)')
    return default


def positive(spec: Mapping, key: str, name: str, default: Any = MISSING, *,
             allow_zero: bool = False) -> float:
    """A finite number > 0 (>= 0 with ``allow_zero``)."""
    return require_positive(f'{key}.{name}', get(spec, key, name, default),
                            allow_zero=allow_zero)


#: largest plausible cam lift [m]: a larger value is almost always millimetres
MAX_LIFT_M = 0.25


def lift(spec: Mapping, key: str, name: str, default: Any = MISSING) -> float:
    """A lift or height [m], > 0 and at most ``MAX_LIFT_M`` (the error of a value given
    in mm or um names the unit it looks like)."""
    return require_length(f'{key}.{name}', get(spec, key, name, default), MAX_LIFT_M,
                          what='a lift')


#: largest plausible cam radius [m] (base circle, roller, tappet): a larger value is
#: almost always millimetres
MAX_RADIUS_M = 0.5


def radius(spec: Mapping, key: str, name: str, default: Any = MISSING) -> float:
    """A cam-size radius [m], > 0 and at most ``MAX_RADIUS_M`` (a value given in mm
    names the unit it looks like: 16.5 -> 'looks like millimetres: write 0.0165')."""
    return require_length(f'{key}.{name}', get(spec, key, name, default), MAX_RADIUS_M,
                          what='a radius')


def angle(spec: Mapping, key: str, name: str, default: Any = MISSING, *,
          allow_zero: bool = False, limit: float = math.pi) -> float:
    """An angle [rad] in (0, limit] ([0, limit] with ``allow_zero``); default limit pi."""
    out = positive(spec, key, name, default, allow_zero=allow_zero)
    if out > limit:
        hint = (f'; {out:g} looks like degrees: write {math.radians(out):.6g}'
                if math.radians(out) <= limit else '')
        raise InputError(f'{key}.{name}', out, f'an angle <= {limit:.6g} rad{hint}')
    return out


def finite(spec: Mapping, key: str, name: str, default: Any = MISSING) -> float:
    """A finite real number."""
    return require_finite(f'{key}.{name}', get(spec, key, name, default))


def integers(spec: Mapping, key: str, name: str, default: Any = MISSING, *,
             minimum: int = 0) -> list[int]:
    """A list of distinct, strictly increasing integers >= ``minimum``."""
    raw = get(spec, key, name, default)
    if isinstance(raw, (str, bytes)) or not isinstance(raw, Sequence):
        raise InputError(f'{key}.{name}', raw, 'a list of integers')
    out = []
    for v in raw:
        if isinstance(v, bool) or not (isinstance(v, int) or (isinstance(v, float)
                                                              and v.is_integer())):
            raise InputError(f'{key}.{name}', raw, 'a list of integers')
        out.append(int(v))
    if any(v < minimum for v in out):
        raise InputError(f'{key}.{name}', raw, f'integers >= {minimum}')
    if any(b <= a for a, b in zip(out, out[1:])):
        raise InputError(f'{key}.{name}', raw, 'strictly increasing integers')
    return out


def numbers(spec: Mapping, key: str, name: str, default: Any = MISSING) -> list[float]:
    """A list of finite numbers."""
    raw = get(spec, key, name, default)
    if isinstance(raw, (str, bytes)) or not isinstance(raw, Sequence):
        raise InputError(f'{key}.{name}', raw, 'a list of numbers')
    return [require_finite(f'{key}.{name}[{i}]', v) for i, v in enumerate(raw)]


def choice(spec: Mapping, key: str, name: str, options: Sequence[T],
           default: Any = MISSING) -> T:
    """One of ``options``."""
    raw = get(spec, key, name, default)
    if not any(raw == o and type(raw) is type(o) for o in options):
        raise InputError(f'{key}.{name}', raw, 'one of ' + ', '.join(map(str, options)))
    return raw


def reject_unknown(spec: Mapping, key: str, allowed: Sequence[str]) -> None:
    """InputError for any parameter not in ``allowed`` (catches typos)."""
    for name in spec:
        if name not in allowed:
            raise InputError(f'{key}.{name}', spec[name],
                             'one of the parameters ' + ', '.join(sorted(allowed)))
