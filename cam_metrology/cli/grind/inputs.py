"""The inputs every ``grind`` sub-command shares: the file (lift law + ``grinding:``
section, or a scene with ``--lobe``), the machine section, wheel, angle step, probe,
and the ``--csv``/``--json`` of the table.

FILE holds a lift law (as ``design profile``: ``lift_law:`` or an ``alpha``/``h``
table, ``base_radius``) and a ``grinding:`` section (docs/grinding.md), or it is a scene
(``--lobe`` picks the lobe; the ``grinding:`` section then comes from ``--machine``).
"""
from __future__ import annotations

import argparse
import math
from typing import Any


def add_file(p: argparse.ArgumentParser) -> None:
    """The positional FILE and ``--machine``."""
    p.add_argument('file', metavar='FILE',
                   help='YAML: lift law + base_radius + grinding: section, or a scene')
    p.add_argument('--machine', metavar='YAML',
                   help='a file whose grinding: section replaces the one of FILE')


def add_outputs(p: argparse.ArgumentParser) -> None:
    """``--csv`` and ``--json`` of the table."""
    p.add_argument('--csv', metavar='FILE|-',
                   help='write the table as CSV (- for standard output)')
    p.add_argument('--json', metavar='FILE|-',
                   help='write summary and table as JSON (- for standard output)')


def add_lobe_base(p: argparse.ArgumentParser) -> None:
    """``--lobe`` (a scene's lobe) and ``--base-radius``."""
    p.add_argument('--lobe', metavar='ID', help='FILE is a scene: use this lobe (default: '
                                                'the first)')
    p.add_argument('--base-radius', type=float, metavar='M',
                   help='base-circle radius [m] (default: base_radius in the file)')


def add_wheel_step(p: argparse.ArgumentParser) -> None:
    """One ``--wheel-radius`` and ``--step-deg``."""
    p.add_argument('--wheel-radius', type=float, metavar='M',
                   help='wheel radius [m] (default: the first grinding.wheel_radius)')
    p.add_argument('--step-deg', type=float, metavar='DEG',
                   help='angle step [deg] (default: grinding.step_deg, else 0.5)')


def add_probe(p: argparse.ArgumentParser) -> None:
    """``--probe`` and ``--probe-radius``: the follower whose lift is measured."""
    p.add_argument('--probe', choices=('flat', 'roller', 'knife'),
                   help='the follower whose lift is measured (default: the design follower)')
    p.add_argument('--probe-radius', type=float, default=0.0, metavar='M',
                   help='probe roller radius [m] (default 0)')


def load(args: argparse.Namespace) -> tuple[Any, float, Any, dict[str, Any]]:
    """(lift law, base radius [m], Design, grinding section) of the arguments."""
    from cam_design.errors import InputError
    from cam_design.grinding import spec as gs
    from cam_design.grinding.wheel_path import Design
    from cam_metrology.cli.law_input import base_radius_of, load_law, load_yaml, scene_lobe

    doc = load_yaml(args.file)
    if args.machine:
        machine = load_yaml(args.machine)
        if not isinstance(machine, dict) or 'grinding' not in machine:
            raise InputError('--machine', args.machine, 'a YAML file with a grinding: section')
        section = dict(gs.section(machine))
    else:
        section = dict(gs.section(doc))
    if isinstance(doc, dict) and 'lobes' in doc:
        law, follower, base = scene_lobe(args)
        if args.base_radius is not None:
            raise InputError('--base-radius', args.base_radius,
                             'no value with a scene (its base_circle_radius is used)')
        if 'design' in section:
            raise InputError('grinding.design', section['design'],
                             'no design with a scene (the lobe\'s follower is used)')
        design = Design(follower.kind, follower.radius if follower.kind == 'roller' else 0.0)
    else:
        if args.lobe is not None:
            raise InputError('--lobe', args.lobe, 'a scene file (with lobes:)')
        law = load_law(doc, args.file)
        base = base_radius_of(args, doc)
        design = gs.design(section.get('design', 'flat'))
    return law, base, design, section


def write_columns(args: argparse.Namespace, columns: dict[str, Any], summary: dict[str, Any]
                  ) -> bool:
    """CSV (15 significant digits) and/or JSON of ``columns`` with ``summary``; True if
    anything was written."""
    import numpy as np

    from cam_metrology.cli.table_out import write_table

    names = list(columns)
    table = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
    return write_table(args.csv, args.json, names, table, summary, digits=15)


def probe_follower(args: argparse.Namespace) -> Any:
    """The ``--probe`` follower (kind, radius [m]), or None for the design follower."""
    from cam_design.errors import InputError, require_positive
    from cam_design.follower import Follower

    if args.probe is None:
        return None
    r = require_positive('--probe-radius', args.probe_radius, allow_zero=True)
    if (args.probe == 'roller') != (r > 0):
        raise InputError('--probe-radius', r, 'a radius > 0 for --probe roller, 0 otherwise')
    return Follower(args.probe, r)


def machine_of(path: Any, section: dict[str, Any]) -> tuple[Any, Any]:
    """(cradle or None, master or None) of the grinding section."""
    from cam_design.grinding.master_cam import master_from_section

    if 'cradle' not in section:
        return None, None
    master = master_from_section(path, section)
    return master.cradle, master


def angle_grid(step: float) -> Any:
    """The angles [rad] of one turn from -pi in steps of about ``step`` [rad] (a whole
    number of them)."""
    import numpy as np

    n = int(round(2 * math.pi / step))
    return -math.pi + 2 * math.pi * np.arange(n) / n


def warn_bridged(rw: float, bridged: list[tuple[float, float]]) -> None:
    """One stderr line when the wheel cannot enter a hollow of the design."""
    import sys

    if bridged:
        spans = ', '.join(f'{math.degrees(a):.3f} .. {math.degrees(b):.3f} deg'
                          for a, b in bridged)
        print(f'WARNING: wheel {rw * 1e3:.4f} mm bridges concave flanks of radius below its '
              f'own at {spans}: the ground cam is not the design there', file=sys.stderr)


def one_wheel(args: argparse.Namespace, section: dict[str, Any]) -> float:
    """The wheel radius [m]: ``--wheel-radius``, else the first grinding.wheel_radius."""
    from cam_design.errors import InputError
    from cam_design.grinding import spec as gs

    if args.wheel_radius is not None:
        return gs.wheel_radii(args.wheel_radius, '--wheel-radius')[0]
    if 'wheel_radius' not in section:
        raise InputError('--wheel-radius', None, 'a wheel radius [m] (or grinding.wheel_'
                                                 'radius in the file)')
    return gs.wheel_radii(section['wheel_radius'])[0]


def step_of(args: argparse.Namespace, section: dict[str, Any]) -> float:
    """The angle step [rad]: ``--step-deg``, else grinding.step_deg, else 0.5 deg."""
    from cam_design.grinding import spec as gs

    if args.step_deg is not None:
        return gs.step_rad(args.step_deg, '--step-deg')
    return gs.step_rad(section.get('step_deg', 0.5))
