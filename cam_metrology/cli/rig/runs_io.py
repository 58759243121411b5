"""Inputs and outputs shared by ``rig analyze`` and ``rig calibrate``: the RUN
arguments and the scene, and the JSON, plots, HTML report and summary of a result."""
from __future__ import annotations

import argparse
import sys
from typing import Any

from cam_metrology.cli.conventions import add_report


def add_runs(q: argparse.ArgumentParser) -> None:
    """The RUN positionals and ``--scene`` (inputs), then ``--json``, ``--plot`` and
    ``--report`` (outputs)."""
    q.add_argument('runs', nargs='+', metavar='RUN',
                   help='CSV file (time_s,cam_angle_rad,valve_lift_m[,...]) or bag with '
                        '/rig/joint_states or /rig/joint_trajectory')
    q.add_argument('--scene', metavar='SCENE',
                   help='scene YAML with lobes, valve_train and rig: {lobe, '
                        'nose_angle_deg} (default: the scene recorded in the bag)')
    q.add_argument('--json', metavar='FILE|-',
                   help='write the JSON result (- for standard output)')
    q.add_argument('--plot', metavar='DIR',
                   help='write <run>.png (overlay and residual) to DIR')
    add_report(q, 'write an HTML report with the plots', aliases=('--html',))


def add_no_jump(q: argparse.ArgumentParser) -> None:
    """``--no-jump``."""
    q.add_argument('--no-jump', action='store_true',
                   help='skip the jump-speed sweeps (faster)')


def scene_and_runs(args: argparse.Namespace) -> tuple[Any, list[Any]]:
    """The scene (``--scene``, else the one recorded in the bag) and the runs of RUN."""
    from cam_design.errors import InputError
    from cam_metrology.rig.runs import read_runs
    from cam_metrology.scene.parse import load_scene, parse_scene

    runs, bag_scene = read_runs(args.runs)
    if args.scene:
        scene = load_scene(args.scene)
    elif bag_scene is not None:
        scene = parse_scene(bag_scene, 'the bag /bench/scene')
    else:
        raise InputError('--scene', None, 'a scene YAML with a rig block (the runs carry '
                                          'no scene)')
    return scene, runs


def emit(outcome: Any, args: argparse.Namespace, title: str) -> None:
    """Write the result as the outputs ask; warnings to stderr; the summary unless the
    JSON goes to standard output."""
    from cam_metrology.inputs.files import write_output

    result = outcome.result
    if args.plot:
        from cam_metrology.rig.report import write_plots
        write_plots(outcome.curves, args.plot)
    if args.report:
        from cam_metrology.rig.report import html_report
        write_output(args.report, html_report(result, outcome.curves, title), '--report')
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, result, '--json')
    for w in result.get('warnings', []):
        print(f'warning: {w}', file=sys.stderr)
    if args.json == '-':
        return
    from cam_metrology.rig.report import summary_lines
    for line in summary_lines(result):
        print(line)
