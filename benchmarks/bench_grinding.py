"""Benchmark of cam_design.grinding: wheel-centre table and the fit of machining errors.

Run: ``.venv/bin/python -m benchmarks.bench_grinding`` (writes
benchmarks/results/grinding.md). Times are the best of several repeats (perf_counter).
Wheel table: eccentric disc R_c = 20 mm, e = 5 mm, wheel 200 mm; error against the
closed form D = e cos a + sqrt((R_c + R_w)^2 - e^2 sin^2 a). Fit: the preset
flat_tappet_intake lobe (base circle 16.5 mm, flat tappet) ground with known errors,
measured with Gaussian noise, fitted; the systematic error before and after one
correction (exact regrind simulation).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from benchmarks.machine import best_time, describe, save_results
from cam_design.follower import EccentricDiscLift, Follower
from cam_design.grinding.correction import corrected_curve, fit_errors
from cam_design.grinding.machining_error import GroundCam, MachineErrors
from cam_design.grinding.wheel_path import Design, WheelPath

RC, E, RW = 0.020, 0.005, 0.2
RESULT = Path(__file__).resolve().parent / 'results' / 'grinding.md'


def table_rows() -> list[str]:
    rows = []
    for kind, r in (('flat', 0.0), ('roller', 0.008)):
        law = EccentricDiscLift(RC, E, Follower(kind, r))
        for n in (3600, 36000):
            a = np.linspace(-math.pi, math.pi, n, endpoint=False)

            def build_and_table() -> dict:
                return WheelPath(law, RC - E, Design(kind, r), RW).table(a)
            t, tab = best_time(build_and_table, 5)
            exact = E * np.cos(a) + np.sqrt((RC + RW) ** 2 - E ** 2 * np.sin(a) ** 2)
            err = np.max(np.abs(tab['wheel_centre_distance_m'] - exact))
            rows.append(f'| wheel table, disc, {kind} design | {n} | {t * 1e3:.1f} | '
                        f'max abs D error {err:.1e} m |')
    return rows


def fit_rows() -> list[str]:
    from cam_design.lift_laws import from_spec

    law = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'bench')
    path = WheelPath(law, 0.0165, Design('flat'), RW)
    truth = MachineErrors(wheel_radius=-5e-3, index=math.radians(0.05), run_out_x=2e-6,
                          run_out_y=-1e-6)
    a = np.linspace(-math.pi, math.pi, 1440, endpoint=False)
    t_sim, got = best_time(lambda: GroundCam(path, truth).lift(a), 3)
    before = got[0] - law(a)
    rows = []
    for noise, iters in ((0.0, 0), (0.0, 2), (2e-7, 0), (2e-7, 2), (1e-6, 2)):
        meas = before + np.random.default_rng(11).normal(0.0, noise, a.size)
        t_fit, fit = best_time(
            lambda: fit_errors(path, a, meas, exact_iterations=iters), 3)
        curve, radius = corrected_curve(path, fit)
        after = GroundCam(path, truth, curve=curve, table_radius=radius).lift(a)[0] - law(a)
        est = ', '.join(f'{k} {fit.values[k]:.4g} ± {fit.std[k]:.2g} (true '
                        f'{getattr(truth, k):.4g})' for k in fit.values)
        rows.append(f'| fit, noise {noise * 1e6:.1f} um, {iters} exact iterations, 1440 '
                    f'points | {t_fit * 1e3:.1f} | {est}; systematic rms '
                    f'{np.std(before) * 1e6:.3f} -> {np.std(after) * 1e6:.4f} um |')
    rows.append(f'| exact grinding simulation, 1440 points | {t_sim * 1e3:.1f} | - |')
    return rows


def main() -> None:
    """Run, print and write benchmarks/results/grinding.md."""
    text = '\n'.join(['# grinding benchmark', '', __doc__.split('\n\n', 1)[1].strip(), '',
                      f'Machine: {describe()}', '',
                      '| case | points | time [ms] | result |', '|---|---|---|---|']
                     + table_rows()) + '\n\n' + '\n'.join(
        ['| case | time [ms] | estimates [m, rad] and effect |', '|---|---|---|']
        + fit_rows()) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
