"""The lift law named on the command line (``design law|check|profile``, ``grind``).

A YAML file holds a ``lift_law:`` mapping (or is the mapping itself), a tabulated lift
``{alpha, h}`` (also under ``lift:``), and optionally ``base_radius`` [m]; or it is a
scene, and ``--lobe ID`` picks one of its lobes (default: the first).
"""
from __future__ import annotations

import argparse
from typing import Any


def load_yaml(path: str) -> Any:
    """Parse a YAML file; InputError naming the file if it is not valid YAML."""
    import yaml

    from cam_design.errors import InputError
    from cam_metrology.inputs.files import read_text_file

    text = read_text_file(path, 'YAML file', key=path)
    try:
        from cam_metrology.inputs.yaml_input import load_yaml, syntax_error_text
        return load_yaml(text, path)
    except yaml.YAMLError as exc:
        raise InputError(path, 'invalid YAML',
                         f'a YAML document ({syntax_error_text(exc, text)})') from None


def law_spec(doc: Any, path: str, lobe: str | None = None) -> tuple[Any, str]:
    """(lift_law mapping, key) from a YAML document: ``lift_law: {...}``, the mapping
    itself, or a scene (``lobes: [...]``; ``lobe`` selects one by id, default the first)."""
    from cam_design.errors import InputError

    if isinstance(doc, dict) and isinstance(doc.get('lobes'), list) and doc['lobes']:
        ids = [lb.get('id') if isinstance(lb, dict) else None for lb in doc['lobes']]
        i = ids.index(lobe) if lobe in ids else 0
        if lobe is not None and lobe not in ids:
            raise InputError('--lobe', lobe, 'one of ' + ', '.join(map(str, ids)))
        item = doc['lobes'][i]
        if isinstance(item, dict) and 'lift_law' in item:
            return item['lift_law'], f'lobes[{i}].lift_law'
        if isinstance(item, dict) and isinstance(item.get('lift'), dict):
            # a tabulated lobe (lift: {alpha, h}) is the `table` family
            return dict(item['lift'], family='table'), f'lobes[{i}].lift'
        raise InputError(f'lobes[{i}]', ids[i], 'a lobe with a lift_law mapping or a lift '
                                                'table {alpha, h}')
    if isinstance(doc, dict) and 'lift_law' in doc:
        return doc['lift_law'], 'lift_law'
    if isinstance(doc, dict) and 'family' in doc:
        return doc, 'lift_law'
    raise InputError(path, type(doc).__name__, 'a mapping with lift_law: {family: ...}')


def load_law(doc: Any, path: str) -> Any:
    """The lift law of the file: a table (``alpha``/``h``, at the top or under ``lift``:
    its lobe law, as on every route) or a lift_law spec."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_design.lift_laws import from_spec

    if isinstance(doc, dict):
        table = doc.get('lift', doc)
        if isinstance(table, dict) and 'alpha' in table and 'h' in table:
            key = 'lift' if table is not doc else path
            values = {}
            for name in ('alpha', 'h'):
                try:
                    values[name] = np.asarray(table[name], dtype=float).tolist()
                except (TypeError, ValueError):
                    raise InputError(f'{key}.{name}', table[name],
                                     'a list of numbers (rad for alpha, m for h)') from None
            return from_spec(dict(values, family='table'), key)
    if not isinstance(doc, dict):
        raise InputError(path, type(doc).__name__, 'a mapping with lift_law: or alpha/h')
    spec, key = law_spec(doc, path)
    return from_spec(spec, key)


def scene_lobe(args: argparse.Namespace) -> tuple[Any, Any, float]:
    """(lift law, design follower, base radius) of a lobe of the scene file ``args.file``:
    ``args.lobe``, else the first lobe (``args.lobe`` is then set to its id)."""
    from cam_design.errors import InputError
    from cam_metrology.scene.parse import load_scene

    scene = load_scene(args.file)
    ids = [lobe.id for lobe in scene.lobes]
    lobe_id = args.lobe if args.lobe is not None else ids[0]
    if lobe_id not in ids:
        raise InputError('--lobe', args.lobe, 'one of ' + ', '.join(ids))
    args.lobe = lobe_id
    lobe = scene.lobe(lobe_id)
    return lobe.lift, lobe.follower, scene.base_circle_radius


def base_radius_of(args: argparse.Namespace, doc: Any) -> float:
    """Base-circle radius [m]: ``--base-radius``, else ``base_radius`` of the file."""
    from cam_design.errors import InputError, require_length
    from cam_design.lift_laws.params import MAX_RADIUS_M

    if args.base_radius is not None:
        return require_length('--base-radius', args.base_radius, MAX_RADIUS_M, what='a radius')
    if isinstance(doc, dict) and 'base_radius' in doc:
        return require_length('base_radius', doc['base_radius'], MAX_RADIUS_M, what='a radius')
    raise InputError('--base-radius', None, 'a base-circle radius [m] (or base_radius: in '
                     'the file)')
