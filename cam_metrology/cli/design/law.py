"""`cam-bench design law FILE`: a lift law evaluated on a grid.

The law (``lift_law:`` mapping, the mapping itself, or a scene lobe with ``--lobe``)
gives the table alpha [deg], h [mm], h' [mm/rad], h'' [mm/rad^2], h''' [mm/rad^3],
printed or written as CSV/JSON, plotted, or written as a gauge nominal-profile file.
"""
from __future__ import annotations

import argparse
import math
from typing import Any

from cam_metrology.cli.law_input import law_spec, load_yaml
from cam_metrology.cli.table_out import write_table

COLUMNS = ('alpha_deg', 'h_mm', 'h1_mm_per_rad', 'h2_mm_per_rad2', 'h3_mm_per_rad3')


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``law`` to the ``design`` group."""
    p = sub.add_parser('law', help='evaluate a lift law from a YAML file',
                       description='Evaluate a lift law (YAML: a `lift_law:` mapping or the '
                                   'mapping itself, see docs/lift_laws.md) and print a table '
                                   'of alpha [deg], h [mm], h\' [mm/rad], h\'\' [mm/rad^2], '
                                   'h\'\'\' [mm/rad^3].')
    p.add_argument('file', metavar='FILE', help='YAML file with the lift law (or a scene file)')
    p.add_argument('--csv', metavar='FILE|-',
                   help='write the table as CSV (- for standard output)')
    p.add_argument('--json', metavar='FILE|-',
                   help='write summary and table as JSON (- for standard output)')
    p.add_argument('--plot', metavar='PNG', help='plot h, h\', h\'\' and h\'\'\' to a PNG')
    p.add_argument('--nominal', metavar='FILE', help='write a gauge nominal-profile file '
                   '(-180..180 deg every --nominal-step-deg; with a scene: the lift as seen '
                   'by its probe, whose radius heads the file)')
    p.add_argument('--lobe', metavar='ID', help='with a scene file: the lobe id (default '
                                                'the first lobe)')
    p.add_argument('--step-deg', type=float, default=1.0, help='angle step [deg] (default 1)')
    p.add_argument('--nominal-step-deg', type=float, default=0.5,
                   help='angle step of --nominal [deg] (default 0.5)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench design law``: the law evaluated on a grid, printed or
    written (0; 2 for bad input)."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_design.lift_laws import from_spec

    spec, key = law_spec(load_yaml(args.file), args.file, args.lobe)
    law = from_spec(spec, key)
    step = args.step_deg
    if not (math.isfinite(step) and 1e-4 <= step <= 90):
        raise InputError('--step-deg', step, 'a step in [1e-4, 90] deg')
    lo, hi = law.support
    n = int(math.floor((hi - lo) / math.radians(step) + 1e-9)) + 1
    alpha = lo + np.arange(n) * math.radians(step)
    if alpha[-1] < hi - 1e-12:
        alpha = np.append(alpha, hi)
    d = law.derivatives(alpha)
    table = np.column_stack([np.degrees(alpha), d.T * 1e3])
    summary = {'family': spec.get('family'), 'support_deg': [math.degrees(lo), math.degrees(hi)],
               'max_lift_mm': max(float(d[0].max()), law.max_lift()) * 1e3,
               'continuity_order': int(law.continuity_order),
               'junctions_deg': [math.degrees(j) for j in law.junctions]}
    wrote = write_table(args.csv, args.json, COLUMNS, table, summary)
    if getattr(args, 'nominal', None):
        write_nominal(args, law, key)
        wrote = True
    if args.plot:
        _plot(args.plot, table, str(spec.get('family')))
    if not wrote:
        print(f"{summary['family']}: support {summary['support_deg'][0]:.4f} .. "
              f"{summary['support_deg'][1]:.4f} deg, max lift {summary['max_lift_mm']:.6f} mm, "
              f"continuous to order {summary['continuity_order']}")
        print(' '.join(f'{c:>16}' for c in COLUMNS))
        for row in table:
            print(' '.join(f'{v:16.9g}' for v in row))
    return 0


def write_nominal(args: argparse.Namespace, law: Any, key: str) -> None:
    """``--nominal``: the gauge file of the law; for a scene lobe, converted to the
    scene's probe (the gauge measures with it), else the law's own lift with probe
    radius 0 and a comment naming that."""
    from cam_metrology.inputs.files import write_output
    from cam_metrology.report.nominal_file import law_gauge_text

    doc = load_yaml(args.file)
    radius, notes = 0.0, [f'nominal lift of {args.file} ({key}), deg and mm']
    if isinstance(doc, dict) and isinstance(doc.get('lobes'), list) and 'probe' in doc:
        from cam_metrology.metrology.analysis import seen_lift
        from cam_metrology.scene.parse import load_scene

        scene = load_scene(args.file)
        lobe = scene.lobe(args.lobe) if args.lobe else scene.lobes[0]
        law = seen_lift(lobe, scene.probe, scene.base_circle_radius, tabulate_step=None)
        radius = scene.probe.radius if scene.probe.kind == 'roller' else 0.0
        notes.append(f'as seen by the scene probe ({scene.probe.kind}); lobe {lobe.id} '
                     f'designed for a {lobe.follower.kind} follower')
    else:
        notes.append('lift of the law as written (probe radius 0: not converted)')
    write_output(args.nominal, law_gauge_text(law, args.nominal_step_deg, radius, notes),
                 '--nominal')


def _plot(path: str, table: Any, title: str) -> None:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(7, 9))
    labels = ('h [mm]', "h' [mm/rad]", "h'' [mm/rad²]", "h''' [mm/rad³]")
    for i, ax in enumerate(axes):
        ax.plot(table[:, 0], table[:, i + 1], lw=1)
        ax.set_ylabel(labels[i])
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel('alpha [deg] (rise flank < 0)')
    axes[0].set_title(title)
    fig.tight_layout()
    from cam_metrology.inputs.files import save_figure
    try:
        save_figure(fig, path, '--plot', dpi=110)
    finally:
        plt.close(fig)
