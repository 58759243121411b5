"""`cam-bench rig analyze RUN... --scene SCENE`: per run the measured speed and
revolutions, the cycle-averaged lift with its scatter, the measured events (opening and
closing at the checking height, maximum lift, seating velocity, bounces, separation from
the cam), the prediction of the scene's valve train at the measured speed and the
residual measured - predicted."""
from __future__ import annotations

import argparse

from cam_metrology.cli.rig.runs_io import add_no_jump, add_runs, emit, scene_and_runs

HELP = 'measured events and residual against the nominal train, per run'


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``analyze`` to the ``rig`` group."""
    q = sub.add_parser('analyze', help=HELP, description=HELP)
    add_runs(q)
    add_no_jump(q)
    return q


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench rig analyze`` (0; 2 for bad input)."""
    from cam_metrology.rig.session import analyze

    scene, runs = scene_and_runs(args)
    outcome = analyze(scene, runs, jump=not args.no_jump)
    emit(outcome, args, 'cam-bench rig analyze')
    return 0
