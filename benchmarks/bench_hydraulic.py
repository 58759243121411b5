"""Benchmark of the hydraulic valve gear: the product's method of characteristics (MOC,
backward-Euler chambers) at several pipe resolutions against an independent solution of
the same equations (method of lines + scipy Radau with seat events,
``benchmarks/hydraulic_reference.py``): time and valve-lift difference.

Case: the preset flat_tappet_intake lobe driving a 20 mm plunger, a 1 m x 6 mm pipe and
a 20 mm actuator; valve 0.1 kg, 2e4 N/m, 300 N preload; 300 rpm; pure oil.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_hydraulic``
(several minutes: the reference is slow; writes benchmarks/results/hydraulic.md).
"""
from __future__ import annotations

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


def _params(reaches: int):
    return hydraulic_params(dict(BLOCK, reaches=reaches), mass=0.1, spring_rate=2e4,
                            spring_preload=300.0)


def run() -> list[str]:
    moc = {}
    for reaches in (4, 16, 64, 256):
        t0 = time.perf_counter()
        res = simulate_hydraulic(LAW, _params(reaches), RPM)
        moc[reaches] = (time.perf_counter() - t0, res)
    grid = moc[4][1].alpha
    t0 = time.perf_counter()
    ref = solve_mol(LAW, _params(4), RPM, 25, grid)
    t_ref = time.perf_counter() - t0
    top = float(ref.max())
    fine = np.interp(grid, moc[256][1].alpha, moc[256][1].valve_lift)
    rows = ['| solver | steps | time [s] | peak lift [mm] | max diff to reference / peak |'
            ' max diff to MOC 256 / peak |', '|---|---|---|---|---|---|']
    for reaches, (sec, res) in moc.items():
        y = np.interp(grid, res.alpha, res.valve_lift)
        rows.append(f'| MOC, {reaches} reaches | {res.alpha.size - 1} | {sec:.2f} | '
                    f'{res.valve_lift.max() * 1e3:.5f} | {np.abs(y - ref).max() / top:.2e} |'
                    f' {np.abs(y - fine).max() / top:.2e} |')
    rows.append(f'| method of lines, 25 cells, Radau rtol 1e-9 | adaptive | {t_ref:.1f} | '
                f'{top * 1e3:.5f} | 0 | {np.abs(ref - fine).max() / top:.2e} |')
    return rows


def main() -> None:
    """Run and write the results table."""
    lines = ['# Hydraulic valve gear benchmark', '', describe(), '', __doc__.split('\n\n')[1],
             ''] + run()
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
