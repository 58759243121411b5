"""Benchmark of the valve trains with the coupled hydraulic lash adjuster
(``cam_design.hydraulic.hla_coupled``): wall time per revolution of the SDOF and the
default MDOF (4 + 8 + 8 DOF) train with the HLA, and the accuracy of the LSODA path
(rtol 1e-9, the product's setting) against the same equations at rtol 1e-12 (largest
valve-lift difference over the last revolution / peak lift, and the difference of the
HLA's leak-down over it).

Case: the preset flat_tappet_intake lobe, the default scene's train (0.12 kg, 1.2e7 N/m,
3e4 N/m, 250 N, rocker 1.5, lash 0.25 mm), the default HLA; 3 revolutions from the
base-circle equilibrium at 1500 rpm (no pump-up) and 4000 rpm (pump-up).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_hla`` (a few minutes;
writes benchmarks/results/hla.md).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import cam_design.hydraulic.hla_coupled as hc
from benchmarks.machine import report
from cam_design.hydraulic.lash_adjuster import LashAdjuster
from cam_design.lift_laws.registry import from_spec
from cam_design.valve_train.mdof import mdof_from_mapping
from cam_design.valve_train.params import SdofParams

RESULT = Path(__file__).resolve().parent / 'results' / 'hla.md'
LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lift_law')
BASE = SdofParams(mass=0.12, stiffness=1.2e7, damping=60.0, spring_rate=3.0e4,
                  spring_preload=250.0, rocker_ratio=1.5, lash=0.25e-3)
REVS = 3


def _run(mdof, rpm: float, rtol: float):
    t0 = time.perf_counter()
    res = hc.simulate_hla(LAW, BASE, LashAdjuster(), rpm, mdof=mdof, revolutions=REVS,
                          rtol=rtol)
    return time.perf_counter() - t0, res


def run() -> list[str]:
    rows = ['| train | rpm | time per revolution [s] | pump-up | leak-down last rev [um] |'
            ' lift error / peak (vs rtol 1e-12) | leak-down error [um] |',
            '|---|---|---|---|---|---|---|']
    for name, mdof in (('SDOF + HLA', None), ('MDOF 4+8+8 + HLA', mdof_from_mapping(None, BASE))):
        for rpm in (1500.0, 4000.0):
            sec, res = _run(mdof, rpm, 1e-9)
            _, ref = _run(mdof, rpm, 1e-12)
            err = float(np.max(np.abs(res.y - ref.y)) / np.max(np.abs(ref.y)))
            rows.append(f'| {name} | {rpm:g} | {sec / REVS:.2f} | '
                        f"{'yes' if res.pumped_up else 'no'} | {res.leak_down * 1e6:.3f} | "
                        f'{err:.1e} | {abs(res.leak_down - ref.leak_down) * 1e6:.1e} |')
            print(rows[-1], flush=True)
    return rows


def main() -> None:
    """Run and write the results table."""
    report('Valve trains with the coupled HLA', __doc__, run(), RESULT)


if __name__ == '__main__':
    main()
