"""Benchmark of ``cam_design.optimize``: time to an optimum per family, and the gain in
fullness over the worked polynomial cam (2-6-10-14, H = 8 mm, 50 deg base half-angle on
the 0.3 mm ramp) at equal constraints (its own peak +/- acceleration and lift).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_optimization``
(writes benchmarks/results/optimization.md).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.machine import describe, save_results
from cam_design.checks import fullness
from cam_design.lift_laws import from_spec
from cam_design.optimize import optimize, parse_spec

RESULT = Path(__file__).resolve().parent / 'results' / 'optimization.md'
RAMP = {'kind': 'constant_acceleration_velocity', 'height': 3.0e-4,
        'velocity': 8.594366926962348e-4, 'angle': math.radians(30)}
BASE = {'family': 'polynomial', 'rise': 8.0e-3, 'half_angle': math.radians(50),
        'ramp': RAMP, 'exponents': [2, 6, 10, 14]}


def _reference() -> dict[str, float]:
    law = from_spec(BASE, 'reference')
    a = np.linspace(*law.support, 40001)
    h, h2 = law(a, 0), law(a, 2)
    return {'fullness': float(fullness(a, h)), 'a_pos': float(h2.max()),
            'a_neg': float(-h2.min()), 'max_lift': float(h.max())}


def cases(ref: dict[str, float]) -> list[tuple[str, dict]]:
    cons = {'max_positive_acceleration': ref['a_pos'],
            'max_negative_acceleration': ref['a_neg']}
    fixed_total = {'max_lift': ref['max_lift'], 'half_duration_deg': 80, 'ramp': RAMP}
    return [
        ('polynomial, exponents 2..4 free (DE, integers)',
         {'family': 'polynomial', 'fixed': {'rise': 8.0e-3, 'half_angle': math.radians(50),
                                            'ramp': RAMP}, 'constraints': cons}),
        ('constant acceleration, positive width free (SLSQP)',
         {'family': 'constant_acceleration', 'fixed': fixed_total, 'constraints': cons}),
        ('composite + dwell, two widths free (SLSQP)',
         {'family': 'composite', 'fixed': fixed_total, 'constraints': cons}),
        ('harmonic, order free (DE, integers)',
         {'family': 'harmonic', 'fixed': {'max_lift': ref['max_lift'],
                                          'half_duration_deg': 80, 'ramp': RAMP},
          'constraints': cons, 'generations': 10}),
        ('polydyne at 1500 rpm, exponents 1..4 free (DE, integers)',
         {'family': 'polydyne', 'generations': 6, 'constraints': cons,
          'fixed': {'rocker_ratio': 1.0, 'lash': 0.0, 'mass': 0.12, 'stiffness': 1.2e7,
                    'spring_rate': 3e4, 'spring_preload': 250.0,
                    'design_cam_speed_rpm': 1500, 'valve_lift': ref['max_lift'],
                    'half_angle': math.radians(80)}}),
        ('dual peak, connection point lift free (SLSQP)',
         {'family': 'dual_peak', 'starts': 3, 'constraints': cons,
          'fixed': {'ramp': RAMP, 'rise': 8.0e-3, 'half_angle': math.radians(50),
                    'connection': {'start': math.radians(5), 'angle': math.radians(40),
                                   'point_angle': math.radians(20), 'point_lift': 1e-4},
                    'secondary': {'rise': 1.5e-3, 'half_angle': math.radians(20),
                                  'ramp': {'height': 2.5e-4,
                                           'velocity': 0.0125e-3 / math.radians(1),
                                           'angle': math.radians(30)}}}}),
    ]


def run() -> list[str]:
    ref = _reference()
    rows = ['| family and search | evaluations | wall time [s] | fullness | gain over '
            'reference | status |', '|---|---|---|---|---|---|']
    for name, doc in cases(ref):
        t0 = time.perf_counter()
        res = optimize(parse_spec(doc))
        wall = time.perf_counter() - t0
        f = res.metrics['fullness']
        rows.append(f'| {name} | {res.evaluations} | {wall:.2f} | {f:.4f} | '
                    f'{(f / ref["fullness"] - 1) * 100:+.1f} % | {res.status} |')
    head = [f'Reference: polynomial 2-6-10-14 on the CA+CV ramp, fullness '
            f'{ref["fullness"]:.4f}, peak h\'\' +{ref["a_pos"]:.4f} / -{ref["a_neg"]:.4f} '
            'm/rad^2 (the constraints of every row), total lift '
            f'{ref["max_lift"] * 1e3:.3f} mm, 80 deg from lobe start to nose, the same ramp '
            'in every row. Fullness over the whole lobe, ramps included (the base section '
            'alone of the reference has 0.494). The polydyne row has no ramp (the '
            'family has none); the dual-peak row carries a second (EGR) lift, so its '
            'fullness is not comparable with the others.', '']
    return head + rows


def main() -> None:
    """Run and write the results table."""
    lines = ['# Optimisation benchmark', '', describe(), ''] + run()
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
