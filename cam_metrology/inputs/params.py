"""Validation of ROS parameters before rclpy sees them (no rclpy import here).

rclpy turns a malformed ``--params-file`` into an ``RCLError`` traceback at ``rclpy.init``
and a wrong-typed value into an ``InvalidParameterTypeException`` traceback at
``declare_parameter``. These helpers check the same things first and raise
``InputError(key, value, expected)`` (one line, exit 2 in the CLI).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml

from cam_design.errors import InputError

#: parameters every rclpy node declares by itself
BUILTIN_PARAMETERS = ('use_sim_time', 'start_type_description_service')


PARAMS_LAYOUT = '`<node name>: {ros__parameters: {name: value}}`'


class _RosYamlLoader(yaml.SafeLoader):
    """SafeLoader that reads ``1e-6`` as a float, as rcl's parameter parser does."""


_RosYamlLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'''^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                    |\.[0-9_]+(?:[eE][-+][0-9]+)?
                    |[-+]?\.(?:inf|Inf|INF)
                    |\.(?:nan|NaN|NAN))$''', re.X),
    list('-+0123456789.'))


def expected_type(default: Any) -> str | None:
    """What a parameter with this default accepts, in words (None: any type)."""
    if isinstance(default, bool):
        return 'true or false'
    if isinstance(default, int):
        return 'an integer'
    if isinstance(default, float):
        return 'a number (integer or float)'
    if isinstance(default, str):
        return 'a string'
    if isinstance(default, (list, tuple)) and default:
        return f'a list like {list(default)!r}'
    return None


def check_value(key: str, value: Any, default: Any) -> Any:
    """``value`` for a parameter whose default is ``default``; ints become floats for a
    float parameter; InputError(key, value, expected type) otherwise."""
    expected = expected_type(default)
    if expected is None:
        return value
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(default, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        value = float(value) if ok else value
    elif isinstance(default, str):
        ok = isinstance(value, str)
    else:   # rclpy may hand arrays back as array.array
        ok = not isinstance(value, (str, bytes)) and hasattr(value, '__len__')
    if not ok:
        raise InputError(key, value, expected)
    return value


def _flatten(prefix: str, section: Mapping[str, Any]) -> dict[str, Any]:
    """Nested parameter mappings -> dotted names (as rcl reads them)."""
    out: dict[str, Any] = {}
    for name, value in section.items():
        full = f'{prefix}{name}'
        if isinstance(value, Mapping):
            out.update(_flatten(full + '.', value))
        else:
            out[full] = value
    return out


def load_params_doc(path: str | Path) -> Mapping[str, Any]:
    """The top-level mapping of a ROS parameter YAML, parsed with rcl's typing;
    InputError('--params', ...) on an unreadable, malformed or empty file. Shared by
    ``cam-bench run`` and ``cam-bench analyze --params``."""
    path = Path(path)
    if path.is_dir():
        raise InputError('--params', str(path), 'a ROS parameter YAML file, not a directory')
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise InputError('--params', str(path), 'an existing ROS parameter YAML file') from None
    except UnicodeDecodeError:
        raise InputError('--params', str(path), 'a UTF-8 YAML text file') from None
    try:
        from cam_metrology.inputs.yaml_input import load_yaml
        doc = load_yaml(text, '--params', _RosYamlLoader)
    except yaml.YAMLError as exc:
        where = getattr(exc, 'problem_mark', None)
        line = f' (line {where.line + 1})' if where is not None else ''
        raise InputError('--params', str(path),
                         f'valid YAML{line}: {getattr(exc, "problem", exc)}') from None
    if not isinstance(doc, Mapping):
        raise InputError('--params', str(path), f'a mapping {PARAMS_LAYOUT}')
    return doc


def section_values(doc: Mapping[str, Any], path: str | Path, node_name: str) -> dict[str, Any]:
    """The parameters ``doc`` sets for ``node_name``: its own section (with or without
    a leading ``/``) and ``/**``, flattened."""
    values: dict[str, Any] = {}
    for key, section in doc.items():
        name = str(key).lstrip('/')
        if name != node_name and name != '**':
            continue   # another node's section (rcl ignores it too)
        if not isinstance(section, Mapping) or not isinstance(
                section.get('ros__parameters'), Mapping):
            raise InputError(f'--params {path}: {key}', section, PARAMS_LAYOUT)
        values.update(_flatten('', section['ros__parameters']))
    return values


def read_params_file(path: str | Path, node_name: str) -> dict[str, Any]:
    """The parameters a ROS parameter YAML sets for ``node_name`` (its own section and
    ``/**``), flattened; InputError('--params', ...) on an unreadable or malformed file."""
    return section_values(load_params_doc(path), path, node_name)


def check_params(node_name: str, values: Mapping[str, Any],
                 table: Mapping[str, tuple[Any, str]]) -> dict[str, Any]:
    """Check ``{name: value}`` against the node's ``{name: (default, description)}``:
    unknown names and wrong types raise InputError naming ``node.name``."""
    out: dict[str, Any] = {}
    for name, value in values.items():
        if name in BUILTIN_PARAMETERS:
            continue
        if name not in table:
            raise InputError(f'{node_name}.{name}', value,
                             f'a parameter of {node_name}: {", ".join(sorted(table))}')
        out[name] = check_value(f'{node_name}.{name}', value, table[name][0])
    return out


def parse_assignments(items: Iterable[str], node_name: str,
                      table: Mapping[str, tuple[Any, str]], key: str) -> dict[str, Any]:
    """``['NAME:=VALUE', ...]`` (values in YAML, as ``-p``) checked against ``table``;
    InputError(key, item, ...) on a malformed item or an unknown name."""
    values: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition(':=')
        if not sep or not name:
            raise InputError(key, item, f'NAME:=VALUE (a {node_name} parameter)')
        if name not in table:
            raise InputError(key, name, f'a {node_name} parameter: {", ".join(sorted(table))}')
        try:
            from cam_metrology.inputs.yaml_input import load_yaml
            value = load_yaml(text, f'{key} {name}', _RosYamlLoader) if text else ''
        except yaml.YAMLError:
            value = text
        values[name] = check_value(f'{key} {name}', value, table[name][0])
    return values
