"""Benchmark of the valve-train rig calibration (``cam_metrology.rig``): CPU time against
runs, revolutions and fitted parameters; parameter error against laser noise; and the
calibration of the reported uncertainty (error / reported std over seeds).

Case: config/rig_scene.yaml (preset flat_tappet_intake lobe, nominal train 1.2e7 N/m,
60 N s/m, 0.12 kg); the rig's true train 1.0e7 N/m, 90 N s/m, 0.125 kg. Runs from the
product's rig simulator (``rig.simulate``: the dynamics' periodic state on a time clock)
at 50 kHz, 3600-count encoder, no speed ripple unless stated (1 %: order 2, the valve's
response to it simulated and predicted through the ripple's equivalent law), speeds
910/1310/1710/2090 rpm, laser noise 1 um unless stated. The fit goes through the
dynamics solver at every evaluation. CPU time is user+sys of this process
(``time.process_time``), reported with wall time and the load average, because other
jobs may share the machine. The independent-solver
check of the recovery is in test/test_rig.py.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks rig`` (a few minutes of
CPU; writes benchmarks/results/rig.md).
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks.machine import report

RESULT = Path(__file__).resolve().parent / 'results' / 'rig.md'
SCENE = Path(__file__).resolve().parents[1] / 'config' / 'rig_scene.yaml'
SPEEDS = (910.0, 1310.0, 1710.0, 2090.0)
TRUE = {'stiffness': 1.0e7, 'damping': 90.0, 'mass': 0.125}


def _setup():
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.rig.session import RigSetup

    scene = load_scene(SCENE)
    setup = RigSetup.of_scene(scene)
    true = replace(scene.valve_train, **TRUE)
    return scene, setup, true


def _runs(setup, true, speeds, revs, noise, seed, ripple=0.0):
    from cam_metrology.rig.simulate import RigNoise, simulate_run

    n = RigNoise(laser_noise=noise, ripple=ripple, encoder_counts=3600, sample_rate=50_000.0)
    return [simulate_run(setup.law, true, rpm, nose=setup.spec.nose_angle, revolutions=revs,
                         noise=n, seed=seed * 100 + i, name=f'r{rpm:g}')
            for i, rpm in enumerate(speeds)]


def _fit(scene, runs, names):
    from cam_metrology.rig.session import calibrate_runs

    load = os.getloadavg()[0]
    c0, w0 = time.process_time(), time.perf_counter()
    out, fit = calibrate_runs(scene, runs, names, jump=False)
    return out.result, fit, time.process_time() - c0, time.perf_counter() - w0, load


def main() -> None:
    """Run the three tables and write benchmarks/results/rig.md."""
    scene, setup, true = _setup()
    rows = ['## Calibration time', '',
            '| runs | revolutions | ripple [%] | samples | fitted | model evaluations | '
            'CPU [s] | wall [s] | load | stiffness error [%] | mass err/std |',
            '|---|---|---|---|---|---|---|---|---|---|---|']
    full = ('stiffness', 'damping', 'mass')
    cases = [(4, 4.0, ('stiffness', 'damping'), 0.0), (4, 4.0, full, 0.0),
             (4, 4.0, full + ('nose_angle',), 0.0),
             (1, 4.0, ('stiffness', 'damping'), 0.0), (2, 4.0, ('stiffness', 'damping'), 0.0),
             (4, 2.0, ('stiffness', 'damping'), 0.0), (4, 8.0, ('stiffness', 'damping'), 0.0),
             (4, 4.0, full, 0.01)]
    for nruns, revs, names, ripple in cases:
        runs = _runs(setup, true, SPEEDS[:nruns], revs, 1e-6, 1, ripple)
        res, fit, cpu, wall, load = _fit(scene, runs, names)
        err = 100 * (fit.value['stiffness'] / TRUE['stiffness'] - 1)
        zm = (f"{(fit.value['mass'] - TRUE['mass']) / fit.std['mass']:+.2f}"
              if 'mass' in names else '')
        rows.append(f"| {nruns} | {revs:g} | {100 * ripple:g} | "
                    f"{sum(r.time.size for r in runs)} | "
                    f"{','.join(names)} | {res['model_evaluations']} | {cpu:.1f} | "
                    f"{wall:.1f} | {load:.1f} | {err:+.3f} | {zm} |")
    rows += ['', '## Parameter error against laser noise (4 runs x 4 revolutions, seed 1)', '',
             '| noise [um] | stiffness err/std | damping err/std | mass err/std | '
             'stiffness std [%] | damping std [%] | mass std [%] |',
             '|---|---|---|---|---|---|---|']
    names = ('stiffness', 'damping', 'mass')
    for noise in (0.1e-6, 0.3e-6, 1e-6, 2e-6, 5e-6):
        runs = _runs(setup, true, SPEEDS, 4.0, noise, 1)
        res, fit, *_ = _fit(scene, runs, names)
        z = [(fit.value[n] - TRUE[n]) / fit.std[n] for n in names]
        rel = [100 * fit.std[n] / TRUE[n] for n in names]
        rows.append(f'| {noise * 1e6:g} | ' + ' | '.join(f'{v:+.2f}' for v in z) + ' | '
                    + ' | '.join(f'{v:.3g}' for v in rel) + ' |')
    seeds = range(2, 14)
    zs: dict[str, list[float]] = {n: [] for n in names}
    chi = []
    for seed in seeds:
        runs = _runs(setup, true, SPEEDS, 4.0, 1e-6, seed)
        res, fit, *_ = _fit(scene, runs, names)
        for n in names:
            zs[n].append((fit.value[n] - TRUE[n]) / fit.std[n])
        chi.append(res['reduced_chi2'])
    rows += ['', f'## Uncertainty calibration: error / reported std over {len(seeds)} seeds '
                 '(1 um)', '', '| parameter | mean z | rms z | max abs z |', '|---|---|---|---|']
    for n in names:
        zn = np.array(zs[n])
        rows.append(f'| {n} | {zn.mean():+.2f} | {math.sqrt(np.mean(zn ** 2)):.2f} | '
                    f'{np.max(np.abs(zn)):.2f} |')
    rows.append(f'\nreduced chi-square over the seeds: {np.mean(chi):.3f} '
                f'(min {np.min(chi):.3f}, max {np.max(chi):.3f})')
    report('Valve-train rig calibration', __doc__, rows, RESULT)


if __name__ == '__main__':
    main()
