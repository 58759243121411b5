"""`cam-bench rig calibrate RUN... --scene SCENE --fit NAME[,NAME...]`: weighted
least squares of the named parameters over all runs through the same dynamics solver;
values with standard uncertainties, correlation matrix, residual before/after,
identifiability warnings, jump speed nominal vs calibrated; ``--scene-out`` writes the
scene with the calibrated values."""
from __future__ import annotations

import argparse

from cam_metrology.cli.rig.runs_io import add_no_jump, add_runs, emit, scene_and_runs

HELP = 'fit valve-train parameters to the runs by weighted least squares through the ' \
       'dynamics solver'
FIT_HELP = ('comma-separated parameters to fit: stiffness, damping, mass, spring_rate, '
            'spring_preload, lash, valve_damping, seat_stiffness, seat_damping, nose_angle')


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``calibrate`` to the ``rig`` group."""
    q = sub.add_parser('calibrate', help=HELP, description=HELP)
    add_runs(q)
    q.add_argument('--scene-out', metavar='FILE',
                   help='write the scene with the calibrated values')
    q.add_argument('--fit', required=True, metavar='NAME[,NAME...]', help=FIT_HELP)
    add_no_jump(q)
    return q


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench rig calibrate`` (0; 2 for bad input)."""
    from cam_metrology.rig.model import parse_fit_names
    from cam_metrology.rig.session import calibrate_runs

    names = parse_fit_names(args.fit)
    scene, runs = scene_and_runs(args)
    outcome, fit = calibrate_runs(scene, runs, names, jump=not args.no_jump)
    if args.scene_out:
        from cam_metrology.inputs.files import write_output
        from cam_metrology.rig.scene_out import calibrated_scene_text
        write_output(args.scene_out, calibrated_scene_text(scene.text, fit), '--scene-out')
    emit(outcome, args, 'cam-bench rig calibrate')
    return 0
