"""Benchmark of the hydraulic valve gear over ONE FULL REVOLUTION: the product's method of
characteristics (MOC, trapezoidal chambers and valve) at several pipe resolutions
against an independent solution of the same equations (Chebyshev collocation of the
pipe + scipy Radau with the valve and check-valve switches as events,
``benchmarks/hydraulic_reference.py``): CPU time and error.

Case: the preset flat_tappet_intake lobe driving a 20 mm plunger, a 1 m x 6 mm pipe
(Darcy f = 0.02) and a 20 mm actuator; valve 0.1 kg, 2e4 N/m, 300 N preload; 300 rpm;
pure oil; one revolution from 10 deg before the lobe (360 deg, 0.2 s): the opening, the
seat impact, the bounce it excites and the pipe ringing on the base circle with the check
valve refilling. Reference: Chebyshev collocation of degree 128 (Radau rtol 1e-10); its
own error is shown by degrees 64 and 96 (spatial), by rtol 1e-11 at degree 64 (time)
and by the MOC's Richardson extrapolation, which is independent of it. Errors are the
largest differences at the 16-reach MOC's time points (a subset of every finer run's, so
nothing is interpolated): valve lift / peak lift over the revolution; pump pressure /
peak pump pressure up to the first seat impact and over the revolution (after the impact
the pipe rings with kinks that the reference resolves less well). Times are CPU seconds
(``time.process_time``) of one run.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_hydraulic``
(about 10 CPU minutes; writes benchmarks/results/hydraulic.md).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.hydraulic_reference import solve_mol
from benchmarks.machine import report
from cam_design.hydraulic.actuation import simulate_hydraulic
from cam_design.hydraulic.run import hydraulic_params
from cam_design.lift_laws import from_spec

RESULT = Path(__file__).resolve().parent / 'results' / 'hydraulic.md'
LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lobe')
BLOCK = {'plunger_diameter': 0.02, 'actuator_diameter': 0.02, 'pipe_length': 1.0,
         'pipe_diameter': 0.006}
RPM = 300.0
LO = LAW.support[0] - math.radians(10)
WINDOW = (LO, LO + 2.0 * math.pi)
REACHES = (16, 32, 64, 128, 256, 512, 1024)
REF_DEGREES = (64, 96, 128)
REF_RTOL = 1e-10
GOAL = 1e-6


def _params(reaches: int):
    return hydraulic_params(dict(BLOCK, reaches=reaches), mass=0.1, spring_rate=2e4,
                            spring_preload=300.0)


def _moc(reaches: int):
    """(CPU s, lift, pump pressure, alpha) of the product at ``reaches``, recorded at the
    16-reach time points."""
    t0 = time.process_time()
    res = simulate_hydraulic(LAW, _params(reaches), RPM, alpha_range=WINDOW,
                             record_every=reaches // REACHES[0])
    sec = time.process_time() - t0
    if res.cavitation:
        raise RuntimeError('the case cavitates; the reference does not model it')
    return sec, res.valve_lift, res.pump_pressure, res.alpha


def _err(a, b, scale: float) -> float:
    n = min(a.size, b.size)
    return float(np.abs(a[:n] - b[:n]).max() / scale)


def _row(name: str, steps: object, sec: float, lift, pump, best, seat: int) -> str:
    """One table row: errors against the reference ``best`` over the revolution (lift,
    pump pressure) and up to the sample ``seat`` (pump pressure)."""
    peak_y, peak_p = float(best.lift.max()), float(best.pump.max())
    if lift is best.lift:
        errors = '0 | 0 | 0'
    else:
        errors = (f'{_err(lift, best.lift, peak_y):.2e} | '
                  f'{_err(pump[:seat], best.pump[:seat], peak_p):.2e} | '
                  f'{_err(pump, best.pump, peak_p):.2e}')
    return f'| {name} | {steps} | {sec:.2f} | {lift.max() * 1e3:.7f} | {errors} |'


def run() -> list[str]:
    moc = {}
    for reaches in REACHES:
        moc[reaches] = _moc(reaches)
        print(f'MOC {reaches}: {moc[reaches][0]:.1f} s', flush=True)
    alpha = moc[REACHES[0]][3]
    for reaches in REACHES[1:]:           # the finer runs' records are the same points
        n = min(alpha.size, moc[reaches][3].size)
        assert np.allclose(moc[reaches][3][:n], alpha[:n], rtol=0, atol=1e-12)
    ref = {}
    for degree in REF_DEGREES:
        t0 = time.process_time()
        ref[degree] = (solve_mol(LAW, _params(4), RPM, degree, alpha, rtol=REF_RTOL),
                       time.process_time() - t0)
        print(f'reference {degree}: {ref[degree][1]:.1f} s', flush=True)
    fine, coarse = REF_DEGREES[-1], REF_DEGREES[0]
    t0 = time.process_time()
    tight = solve_mol(LAW, _params(4), RPM, coarse, alpha, rtol=REF_RTOL / 10)
    tight_sec = time.process_time() - t0
    best = ref[fine][0]
    assert best.peak_pump < _params(4).relief_pressure     # the relief valve stays shut
    t_seat = next(t for t, what in best.events if what == 'seat')
    seat = int(np.searchsorted(alpha, LO + RPM * math.pi / 30 * t_seat))
    rows = ['| solver | steps | CPU time [s] | peak lift [mm] | lift error / peak lift, '
            'revolution | pump-pressure error / peak, to the seat impact | '
            'pump-pressure error / peak, revolution |', '|---|---|---|---|---|---|---|']
    first = None
    prev = None
    ratios = []
    for reaches, (sec, y, p, a) in moc.items():
        e_y = _err(y, best.lift, float(best.lift.max()))
        name = f'MOC, {reaches} reaches'
        if first is None and e_y < GOAL:
            first, name = reaches, name + ' **(first < 1e-6)**'
        rows.append(_row(name, (a.size - 1) * reaches // REACHES[0], sec, y, p, best, seat))
        if prev is not None:
            ratios.append(f'{prev / e_y:.2f}')
        prev = e_y
    (s_a, y_a, p_a, _), (s_b, y_b, p_b, _) = moc[REACHES[-2]], moc[REACHES[-1]]
    n = min(y_a.size, y_b.size)
    rows.append(_row(f'MOC {REACHES[-2]}+{REACHES[-1]} Richardson, (4 y_fine - y_coarse)/3',
                     '-', s_a + s_b, (4 * y_b[:n] - y_a[:n]) / 3, (4 * p_b[:n] - p_a[:n]) / 3,
                     best, seat))
    for degree, (r, sec) in ref.items():
        rows.append(_row(f'reference, Chebyshev degree {degree}, Radau rtol {REF_RTOL:g}',
                         r.steps, sec, r.lift, r.pump, best, seat))
    rows.append(_row(f'reference, Chebyshev degree {coarse}, Radau rtol {REF_RTOL / 10:g}',
                     tight.steps, tight_sec, tight.lift, tight.pump, best, seat))
    r_coarse = ref[coarse][0]
    peak_y, peak_p = float(best.lift.max()), float(best.pump.max())
    events = ', '.join(f'{math.degrees(LO + RPM * math.pi / 30 * t):.2f} deg {what}'
                       for t, what in best.events[:6])
    rows += ['',
             'Error ratio per halving of the MOC step (lift): ' + ', '.join(ratios)
             + ' (second order: 4).',
             f'First MOC resolution below {GOAL:g} of the peak lift over the revolution: '
             + (f'{first} reaches.' if first else 'none.'),
             f'Reference events (degree {fine}, first 6 of {len(best.events)}): {events}; '
             f'the seat impact is sample {seat} of {alpha.size}.',
             f'Time-integration part of the reference error (degree {coarse}, rtol '
             f'{REF_RTOL:g} against {REF_RTOL / 10:g}): lift '
             f'{_err(tight.lift, r_coarse.lift, peak_y):.2e}, pump pressure '
             f'{_err(tight.pump, r_coarse.pump, peak_p):.2e}.']
    return rows


def main() -> None:
    """Run and write the results table."""
    report('Hydraulic valve gear benchmark', __doc__, run(), RESULT)


if __name__ == '__main__':
    main()
