"""Coarse (5 deg, 72-row) lift tables: CPU time of one automatic reconstruction on a
fresh table, and what it decided, for each accuracy family (the sixth, 'narrow peak',
is the flat-tappet preset), by default (no junction search on such tables) and with the
opt-in junction search (junctions fitted as short ramps of h'').

Run: ``.venv/bin/python -m benchmarks coarse_tables`` (writes
benchmarks/results/coarse_tables.md; about 10 s). Each family of
``cam_design.lift_table.truth_lobes`` tabulated at 5 deg over a full turn with 0.1 um
of Gaussian noise, seeds
101-108 (a new table every call, so that no cached level or hinge system is reused), with
``SplineOptions()`` and ``SplineOptions(coarse_junctions=True)``; CPU time (user + sys
of this process) of ``reconstruct_spline`` per table, median and worst; the junctions
kept and refused, the level rule, and the h'' RMS error against the closed form
[mm/rad^2] beside scipy's GCV spline's (median ratio over the seeds).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import make_smoothing_spline

from benchmarks.machine import report
from cam_design.lift_table.spline import SplineOptions, reconstruct_spline
from cam_design.lift_table.truth_lobes import DEG, families, measured_table

RESULT = Path(__file__).resolve().parent / 'results' / 'coarse_tables.md'
SEEDS = range(101, 109)


def main() -> None:
    rows = ['| family | junction search | CPU median [ms] | CPU worst [ms] | '
            'junctions kept (median) | '
            'tables with refused junctions | tables with the Cp level | '
            "h'' error ours / scipy [mm/rad^2] (median) | ratio median / worst |",
            '|---|---|---|---|---|---|---|---|---|']
    cases = [(fam, opt) for fam in families()
             for opt in (SplineOptions(), SplineOptions(coarse_junctions=True))]
    for fam, opt in cases:
        times, kept, refused, cp, ours, theirs, ratios = [], [], 0, 0, [], [], []
        for seed in SEEDS:
            a, h = measured_table(fam.law, 5 * DEG, sigma=0.1e-6, seed=seed)
            t0 = time.process_time()
            rec = reconstruct_spline(a, h, opt)
            times.append(time.process_time() - t0)
            kept.append(len(rec.parameter.get('junctions_deg', [])))
            refused += any('coarse table: no step' in n for n in rec.notes)
            cp += "Mallows' Cp" in rec.why
            grid = np.arange(a[0], a[-1], 0.05 * DEG)
            truth = fam.law(grid, 2)
            e = math.sqrt(float(np.mean((rec.evaluate(grid, 2) - truth) ** 2)))
            r = math.sqrt(float(np.mean((make_smoothing_spline(a, h)(grid, 2) - truth) ** 2)))
            ours.append(e)
            theirs.append(r)
            ratios.append(e / r)
        mode = 'opt-in (ramps)' if opt.coarse_junctions else 'default (off)'
        rows.append(f'| {fam.name} | {mode} | {np.median(times) * 1e3:.1f} | '
                    f'{max(times) * 1e3:.1f} | '
                    f'{np.median(kept):g} | {refused} of {len(times)} | {cp} of {len(times)} | '
                    f'{np.median(ours) * 1e3:.3f} / {np.median(theirs) * 1e3:.3f} | '
                    f'{np.median(ratios):.2f} / {max(ratios):.2f} |')
    report('Coarse lift tables (5 deg): time and decisions', __doc__, rows, RESULT)


if __name__ == '__main__':
    main()
