"""`cam-bench grind errors FILE`: machining-error sensitivities of the lift against the
design angle (with ``grinding.errors`` also the predicted and the simulated lift error).
"""
from __future__ import annotations

import argparse
from typing import Any

from cam_metrology.cli.grind.inputs import (add_file, add_lobe_base, add_outputs, add_probe,
                                            add_wheel_step, angle_grid, load, machine_of,
                                            one_wheel, probe_follower, step_of, warn_bridged,
                                            write_columns)


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``errors`` to the ``grind`` group."""
    p = sub.add_parser('errors', help='machining-error sensitivities of the lift vs angle',
                       description='Lift error of the design follower (or --probe) per unit '
                                   'of each machining error (wheel radius, centre distance, '
                                   'index, run-out x/y, master-roller radius with a cradle) '
                                   'against the design angle; with grinding.errors also the '
                                   'predicted (linear) and the exactly simulated lift error.')
    add_file(p)
    add_outputs(p)
    add_lobe_base(p)
    add_wheel_step(p)
    add_probe(p)
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench grind errors``: the sensitivity table (and the
    predicted / simulated error with grinding.errors; 0, or 2 for bad input)."""
    import numpy as np

    from cam_design.errors import require_mapping
    from cam_design.follower import convert_lift
    from cam_design.grinding import spec as gs
    from cam_design.grinding.machining_error import (UNITS, GroundCam, MachineErrors,
                                                     sensitivities)
    from cam_design.grinding.wheel_path import WheelPath

    law, base, design, section = load(args)
    path = WheelPath(law, base, design, one_wheel(args, section), key=args.file)
    warn_bridged(path.wheel_radius, path.bridged)
    probe = probe_follower(args)
    cradle, master = machine_of(path, section)
    alpha = angle_grid(step_of(args, section))
    sens = sensitivities(path, alpha, cradle=cradle, master=master, probe=probe)
    ref = path.design_law if probe is None else convert_lift(
        path.design_law, base, path.design_follower, probe, key='--probe')
    cols: dict[str, Any] = {'alpha_rad': alpha, 'lift_m': ref(alpha)}
    unit = {'m': 'm_per_m', 'rad': 'm_per_rad'}
    for name, value in sens.items():
        cols[f'{name}_{unit[UNITS[name]]}'] = value
    summary: dict[str, Any] = {
        'design': design.kind, 'wheel_radius_m': path.wheel_radius,
        'probe': None if probe is None else {'kind': probe.kind, 'radius_m': probe.radius},
        'machine': 'cradle' if cradle is not None else 'cnc',
        'reproduces_design': not path.bridged,
        'max_abs_sensitivity': {n: float(np.max(np.abs(v))) for n, v in sens.items()}}
    if 'errors' in section:
        spec = require_mapping(section['errors'], 'grinding.errors', gs.ERROR_KEYS)
        errors = MachineErrors(**gs.floats(spec, 'grinding.errors', gs.ERROR_KEYS))
        pred = sum(getattr(errors, n) * v for n, v in sens.items())
        sim = GroundCam(path, errors, cradle=cradle, probe=probe).lift(alpha)[0] - ref(alpha)
        if errors.master_follower_radius:
            summary['note'] = ('master_follower_radius enters the prediction only; the exact '
                               'simulation leaves it out')
        cols['predicted_error_m'] = pred
        cols['simulated_error_m'] = sim
        summary.update(errors={n: getattr(errors, n) for n in gs.ERROR_KEYS},
                       predicted_error_max_m=float(np.max(np.abs(pred))),
                       simulated_error_max_m=float(np.max(np.abs(sim))),
                       linearisation_error_max_m=float(np.max(np.abs(pred - sim))))
    if not write_columns(args, cols, summary):
        for n, v in summary['max_abs_sensitivity'].items():
            print(f'{n}: max |d lift / d {n}| = {v:.6g} {unit[UNITS[n]].replace("_", " ")}')
        if 'errors' in summary:
            print(f"lift error: predicted max {summary['predicted_error_max_m'] * 1e6:.4f} µm, "
                  f"simulated max {summary['simulated_error_max_m'] * 1e6:.4f} µm")
    return 0
