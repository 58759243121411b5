"""Benchmark of the form analysis (harmonics, Gaussian filter, roundness, waviness): CPU
time per feature and the recovered chatter amplitude against noise and UPR.

Run: ``.venv/bin/python -m benchmarks form`` (writes results/form.md). Time is CPU time
(user + sys of this process, best of 5), so other jobs on the machine do not inflate it;
the machine line gives the load average at the start. Errors: a chatter of 0.8 um at k UPR
(phase random) on one revolution with Gaussian probe noise sigma, over 20 seeds: RMS of
(recovered - 0.8 um), against the standard error sigma sqrt(2/N) of a least-squares
harmonic; a third of the samples removed at random for the gappy rows; harmonics fitted
up to max(k, 150) UPR as the report's analysis does with its default 50 UPR cut-off.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.machine import report

RESULT = Path(__file__).resolve().parent / 'results' / 'form.md'


def _cpu() -> float:
    """CPU time [s] of this process (user + sys, the clock's full resolution)."""
    return time.process_time()


def timing_rows() -> list[str]:
    """CPU time of ``analyze_form`` per feature, uniform and gappy, 3600 and 36 000."""
    from cam_metrology.metrology.form import FILTER_SPAN, analyze_form

    rows = ['| samples | sampling | cut-off [UPR] | harmonics fitted | CPU per feature [ms] '
            '(best of 5) |', '|---|---|---|---|---|']
    rng = np.random.default_rng(0)
    for n in (3600, 36_000):
        theta = np.arange(n) * (2 * math.pi / n)
        dev = 0.8e-6 * np.cos(37 * theta) + rng.normal(0, 0.2e-6, n)
        keep = rng.random(n) > 1 / 3
        for label, th, y in (('uniform (DFT)', theta, dev),
                             ('1/3 missing (least squares; bin means above 2400)',
                              theta[keep], dev[keep])):
            best = math.inf
            for _ in range(5):
                t0 = _cpu()
                res = analyze_form(th, y)
                best = min(best, _cpu() - t0)
            fitted = min(FILTER_SPAN * res.cutoff_upr, res.nyquist_upr)
            rows.append(f'| {n} | {label} | {res.cutoff_upr} | {fitted} | '
                        f'{best * 1e3:.1f} |')
    return rows


def error_rows() -> list[str]:
    """RMS amplitude error of a 0.8 um chatter against noise and UPR."""
    from cam_design.errors import InputError
    from cam_metrology.metrology.form import harmonics, nyquist_upr

    n = 3600
    theta = np.arange(n) * (2 * math.pi / n)
    rows = ['| noise sigma [um] | UPR | sampling | RMS amplitude error [nm] | '
            'sigma sqrt(2/N) [nm] | ratio |', '|---|---|---|---|---|---|']
    for sigma in (0.05e-6, 0.2e-6, 1.0e-6):
        for k in (5, 37, 150, 600):
            for gappy in (False, True):
                errs, refused = [], []
                for seed in range(20):
                    rng = np.random.default_rng(seed)
                    y = 0.8e-6 * np.cos(k * theta - rng.uniform(0, 2 * math.pi)) + \
                        rng.normal(0, sigma, n)
                    keep = rng.random(n) > 1 / 3 if gappy else np.ones(n, bool)
                    try:
                        # fitted to 150 UPR at least, as analyze_form does (3 cut-offs)
                        spec = harmonics(theta[keep], y[keep], max(k, 150))
                    except InputError:   # above this sampling's Nyquist UPR: refused
                        refused.append(nyquist_upr(np.asarray(theta[keep], dtype=float)))
                        continue
                    errs.append(spec.amplitude[k - 1] - 0.8e-6)
                if not errs:
                    where = '1/3 missing' if gappy else 'uniform'
                    rows.append(f'| {sigma * 1e6:g} | {k} | {where} | refused in '
                                f'{len(refused)} of 20 draws (Nyquist UPR {min(refused)}-'
                                f'{max(refused)}) | | |')
                    continue
                rms = math.sqrt(float(np.mean(np.square(errs))))
                se = sigma * math.sqrt(2.0 / (n * (2 / 3 if gappy else 1)))
                note = f' ({len(refused)} of 20 refused)' if refused else ''
                rows.append(f"| {sigma * 1e6:g} | {k} | {'1/3 missing' if gappy else 'uniform'}"
                            f'{note} | {rms * 1e9:.2f} | {se * 1e9:.2f} | {rms / se:.2f} |')
    return rows


def main() -> None:
    """Run both tables and save results/form.md."""
    report('Form analysis: harmonics, filter, roundness, waviness', __doc__,
           ['## CPU time per feature', ''] + timing_rows() +
           ['', '## Recovered chatter amplitude (0.8 um) against noise and UPR', ''] +
           error_rows(), RESULT)


if __name__ == '__main__':
    main()
