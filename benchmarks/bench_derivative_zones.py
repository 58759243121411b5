"""Benchmark of the velocity and acceleration errors judged by angle zone: CPU time per
lobe, and the zone maxima recovered against the closed form of an injected bump.

Run: ``.venv/bin/python -m benchmarks derivative_zones`` (writes
results/derivative_zones.md). Time is CPU time (user + sys of this process, best of 3), so
other jobs on the machine do not inflate it; the machine line gives the load average at
the start. Lobe: the test cam (synthetic.PolynomialRampCam, support +-80 deg) with a C3
bump E sin^4 of E = 5 um over W = 20 deg centred at -30 deg (closed forms: largest
|e'| = (3 sqrt3 / 4) E pi / W = 0.0585 mm/rad, largest |e''| = 4 E (pi / W)^2 =
1.620 mm/rad^2), Gaussian noise sigma, 10 seeds; zones -80..-50, -50..-10 (the bump),
50..80 deg. Error: the bump zone's maxima relative to the closed forms (median and
worst over the seeds), and the largest value any other zone shows (noise only).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.machine import report

RESULT = Path(__file__).resolve().parent / 'results' / 'derivative_zones.md'
BUMP, CENTRE_DEG, WIDTH_DEG = 5e-6, -30.0, 20.0
SPANS = ((-80.0, -50.0), (-50.0, -10.0), (50.0, 80.0))


def _zones() -> tuple:
    from cam_metrology.scene.model import DerivativeZone

    return tuple(DerivativeZone(lo, hi, 0.03, 0.5) for lo, hi in SPANS)


def _table(n: int, sigma: float, seed: int):
    from cam_metrology.metrology.synthetic import PolynomialRampCam, bumped_lobe_table

    law = PolynomialRampCam()
    return bumped_lobe_table(law, BUMP, math.radians(CENTRE_DEG), math.radians(WIDTH_DEG),
                             n_per_rev=n, noise=sigma, seed=seed), law


def timing_rows() -> list[str]:
    """CPU time of ``derivative_errors`` per lobe, without and with zones."""
    from cam_metrology.metrology.derivative_error import derivative_errors

    rows = ['| samples per revolution | zones | CPU per lobe [ms] (best of 3) |',
            '|---|---|---|']
    for n in (3600, 36_000):
        table, law = _table(n, 0.1e-6, 0)
        for zones in ((), _zones()):
            best = math.inf
            for _ in range(3):
                t0 = time.process_time()
                derivative_errors(table, {'runout_fitted': False}, law, zones)
                best = min(best, time.process_time() - t0)
            rows.append(f'| {n} | {len(zones)} | {best * 1e3:.0f} |')
    return rows


def error_rows() -> list[str]:
    """The bump zone's maxima against the closed forms, and the other zones' noise."""
    from cam_metrology.metrology.derivative_error import (ACCELERATION, VELOCITY,
                                                          derivative_errors)

    w = math.radians(WIDTH_DEG)
    truth = {VELOCITY: 3 * math.sqrt(3) / 4 * BUMP * 1e3 * math.pi / w,
             ACCELERATION: 4 * BUMP * 1e3 * (math.pi / w) ** 2}
    rows = ['| noise sigma [um] | quantity | bump zone: relative error median / worst | '
            'other zones: largest value (noise) | closed form |', '|---|---|---|---|---|']
    for sigma in (0.0, 0.1e-6, 0.5e-6):
        errs: dict[str, list[float]] = {VELOCITY: [], ACCELERATION: []}
        floor = {VELOCITY: 0.0, ACCELERATION: 0.0}
        for seed in range(10 if sigma else 1):
            table, law = _table(7200, sigma, seed)
            out = derivative_errors(table, {'runout_fitted': False}, law, _zones())
            for z in out['derivative_error_zones']:
                for q in errs:
                    value = z[q]['max_abs']
                    if (z['from_deg'], z['to_deg']) == SPANS[1]:
                        errs[q].append(value / truth[q] - 1.0)
                    else:
                        floor[q] = max(floor[q], value)
        for q, unit in ((VELOCITY, 'mm/rad'), (ACCELERATION, 'mm/rad^2')):
            e = np.abs(errs[q])
            rows.append(f'| {sigma * 1e6:g} | {q} | {np.median(e) * 100:.1f} % / '
                        f'{np.max(e) * 100:.1f} % | {floor[q]:.4f} {unit} | '
                        f'{truth[q]:.4f} {unit} |')
    return rows


def main() -> None:
    """Run both tables and save results/derivative_zones.md."""
    report('Velocity and acceleration errors by angle zone', __doc__,
           ['## CPU time per lobe', ''] + timing_rows() +
           ['', '## Zone maxima against the closed form of a 5 um bump', ''] + error_rows(),
           RESULT)


if __name__ == '__main__':
    main()
