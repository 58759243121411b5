"""Benchmark of the hydraulic valve gear over one lobe pass: the product's
method of characteristics (MOC, trapezoidal chambers and valve) at several pipe
resolutions against an independent solution of the same equations (method of lines +
scipy Radau with seat events, ``benchmarks/hydraulic_reference.py``): time and error.

Case: the preset flat_tappet_intake lobe driving a 20 mm plunger, a 1 m x 6 mm pipe
(Darcy f = 0.02) and a 20 mm actuator; valve 0.1 kg, 2e4 N/m, 300 N preload; 300 rpm;
pure oil; the product's pass from 10 deg before to 10 deg after the lobe (200 deg; a
whole revolution makes the reference's check-valve chatter after the closing cost
hours). Reference: the method of lines on 40 and 80 finite volumes (Radau, rtol 1e-9),
extrapolated to zero cell length
(Richardson, second order); its own error is estimated by the 80-volume solution's
distance to the extrapolation (upper bound). Errors: largest valve-lift difference over
the pass / peak lift, largest pump-pressure difference / peak pump pressure.
"MOC 256+512 Richardson" combines the two finest MOC runs as (4 y_512 - y_256) / 3.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_hydraulic``
(about 15 minutes: the reference is slow; writes benchmarks/results/hydraulic.md).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.hydraulic_reference import solve_mol
from benchmarks.machine import describe, save_results
from cam_design.hydraulic.actuation import simulate_hydraulic
from cam_design.hydraulic.run import hydraulic_params
from cam_design.lift_laws import from_spec

RESULT = Path(__file__).resolve().parent / 'results' / 'hydraulic.md'
LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lobe')
BLOCK = {'plunger_diameter': 0.02, 'actuator_diameter': 0.02, 'pipe_length': 1.0,
         'pipe_diameter': 0.006}
RPM = 300.0
LO = LAW.support[0] - math.radians(10)
WINDOW = (LO, LAW.support[1] + math.radians(10))
REACHES = (16, 32, 64, 128, 256, 512)
CELLS = (40, 80)
RTOL = 1e-9


def _params(reaches: int):
    return hydraulic_params(dict(BLOCK, reaches=reaches), mass=0.1, spring_rate=2e4,
                            spring_preload=300.0)


def _row(name: str, steps: str, sec: float, lift, pump, ref_lift, ref_pump) -> str:
    e_y = np.abs(lift - ref_lift).max() / ref_lift.max()
    e_p = np.abs(pump - ref_pump).max() / ref_pump.max()
    return (f'| {name} | {steps} | {sec:.2f} | {lift.max() * 1e3:.7f} | {e_y:.2e} | '
            f'{e_p:.2e} |')


def run() -> list[str]:
    grid = np.linspace(WINDOW[0], WINDOW[1], 4001)        # every 0.05 deg
    moc = {}
    for reaches in REACHES:
        t0 = time.perf_counter()
        res = simulate_hydraulic(LAW, _params(reaches), RPM, alpha_range=WINDOW)
        moc[reaches] = (time.perf_counter() - t0, res.alpha.size - 1,
                        np.interp(grid, res.alpha, res.valve_lift),
                        np.interp(grid, res.alpha, res.pump_pressure))
        print(f'MOC {reaches}: {moc[reaches][0]:.1f} s', flush=True)
    mol = {}
    for cells in CELLS:
        t0 = time.perf_counter()
        lift, pump = solve_mol(LAW, _params(4), RPM, cells, grid, rtol=RTOL)
        mol[cells] = (time.perf_counter() - t0, lift, pump)
        print(f'MOL {cells}: {mol[cells][0]:.1f} s', flush=True)
    (t1, y1, p1), (t2, y2, p2) = mol[CELLS[0]], mol[CELLS[1]]
    ref_y, ref_p = (4 * y2 - y1) / 3, (4 * p2 - p1) / 3
    rows = ['| solver | steps | time [s] | peak lift [mm] | lift error / peak |'
            ' pump-pressure error / peak |', '|---|---|---|---|---|---|']
    prev = None
    orders = []
    for reaches, (sec, steps, y, p) in moc.items():
        rows.append(_row(f'MOC, {reaches} reaches', str(steps), sec, y, p, ref_y, ref_p))
        err = np.abs(y - ref_y).max()
        if prev is not None:
            orders.append(f'{prev / err:.2f}')
        prev = err
    (s_a, _, y_a, p_a), (s_b, _, y_b, p_b) = moc[REACHES[-2]], moc[REACHES[-1]]
    rows.append(_row(f'MOC {REACHES[-2]}+{REACHES[-1]} Richardson', '-', s_a + s_b,
                     (4 * y_b - y_a) / 3, (4 * p_b - p_a) / 3, ref_y, ref_p))
    for cells, (sec, y, p) in mol.items():
        rows.append(_row(f'method of lines, {cells} volumes, Radau rtol {RTOL:g}', 'adaptive',
                         sec, y, p, ref_y, ref_p))
    rows.append(f'| reference: method of lines {CELLS[0]}+{CELLS[1]} extrapolated | - | '
                f'{t1 + t2:.1f} | {ref_y.max() * 1e3:.7f} | 0 | 0 |')
    rows += ['', 'Error ratio per halving of the MOC step (lift): ' + ', '.join(orders)
             + ' (second order: 4).']
    return rows


def main() -> None:
    """Run and write the results table."""
    lines = ['# Hydraulic valve gear benchmark', '', describe(), '',
             __doc__.split('\n\n')[1], ''] + run()
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
