"""Benchmark of the hydraulic sweep (``cam_design.hydraulic.speed_limit``): CPU time of a
``--sweep`` with the hydraulic gear and how the no-open speed depends on the pipe's
characteristic grid (the sweep runs every speed on the scene's grid, not a coarser one).

Case: the preset flat_tappet_intake lobe (8.5 mm), plunger and actuator 20 mm, a 1.5 m
pipe of 6 mm bore (friction 0.02), relief at 40 bar, valve 0.1 kg on 2e4 N/m with 300 N
preload, a blow-down of 3 bar at the lobe start falling to 0 at 150 deg crank on a 30 mm
head; speeds 200:1000:100 rpm, the no-open speed bisected to 0.5 rpm; 4 to 64 reaches.
Second table: the same gear with the relief at 120 bar over 500:3000:250 rpm, where the
valve is thrown past the rigid-oil lift on its inertia (a soft spring, no lift stop):
the peak lift there depends strongly on the grid.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_hydraulic_sweep``
(about 10 s; writes benchmarks/results/hydraulic_sweep.md).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks.machine import report
from cam_design.hydraulic.gas import gas_force, on_cam_angle
from cam_design.hydraulic.run import hydraulic_params, run_hydraulic
from cam_design.hydraulic.speed_limit import hydraulic_sweep
from cam_design.lift_laws.registry import from_spec

RESULT = Path(__file__).resolve().parent / 'results' / 'hydraulic_sweep.md'
LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lift_law')
GAS = on_cam_angle(gas_force([0.0, 150.0, 700.0], [3e5, 0.0, 0.0], 0.03), 0.0,
                   LAW.support[0])
SPEEDS = np.arange(200.0, 1001.0, 100.0)


def _params(reaches: int, relief: float = 4e6):
    return hydraulic_params({'plunger_diameter': 0.02, 'actuator_diameter': 0.02,
                             'pipe_length': 1.5, 'pipe_diameter': 0.006,
                             'relief_pressure': relief, 'reaches': reaches},
                            mass=0.1, spring_rate=2e4, spring_preload=300.0)


def run() -> list[str]:
    rows = ['| reaches | pipe step [us] | no-open bracket [rpm] | passes | CPU [s] |'
            ' spill before the peak at 431 rpm |',
            '|---|---|---|---|---|---|']
    for reaches in (4, 8, 16, 32, 64):
        prm = _params(reaches)
        t0 = time.process_time()
        res = hydraulic_sweep(LAW, prm, SPEEDS.tolist(), gas=GAS)
        cpu = time.process_time() - t0
        spill = run_hydraulic(LAW, prm, 431.0, gas=GAS).events['relief_spill_before_peak']
        lo, hi = res.no_open.bracket
        rows.append(f'| {reaches} | {res.pipe_time_step * 1e6:.1f} | [{lo:.2f}, {hi:.2f}] | '
                    f'{res.runs} | {cpu:.2f} | {spill:.3e} |')
        print(rows[-1], flush=True)
    rows += ['', '| reaches (relief 120 bar) | no-open bracket [rpm] | CPU [s] | peak lift / rigid'
             ' at 1000, 2000, 3000 rpm | spill before the peak at 3000 rpm |',
             '|---|---|---|---|---|']
    fast = np.arange(500.0, 3001.0, 250.0)
    for reaches in (4, 16, 64):
        t0 = time.process_time()
        res = hydraulic_sweep(LAW, _params(reaches, 1.2e7), fast.tolist(), gas=GAS)
        cpu = time.process_time() - t0
        ratio = [res.lift_ratio[int(np.argmin(abs(fast - r)))] for r in (1000, 2000, 3000)]
        rows.append(f'| {reaches} | {res.no_open.bracket} | {cpu:.2f} | '
                    + ', '.join(f'{x:.3f}' for x in ratio)
                    + f' | {res.spill_before_peak[-1]:.3f} |')
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    """Run and write the results table."""
    report('Hydraulic sweep: no-open speed and cost', __doc__, run(), RESULT)


if __name__ == '__main__':
    main()
