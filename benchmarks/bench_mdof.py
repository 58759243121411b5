"""MDOF 4+N1+N2 benchmark: the exact piecewise-linear solver against scipy at equal error.

Default scene train (``bench_dynamics._params``), lobe ``flat_tappet_intake``, the
4+8+8 model with the defaults derived from the SDOF values (40 states), one revolution
from rest at 1500 and 3000 rpm (camshaft). Truth: ``mdof_reference`` (scipy DOP853 rtol
1e-12 with a restart at every switch, on the exact lift law). Rows: the exact solver at
output steps 2..0.1 deg, and the earlier scipy path (switches inside the right-hand
side) with LSODA and Radau at several tolerances. Then the periodic state: Newton
shooting against plain repeated revolutions.

Run: ``.venv/bin/python -m benchmarks.bench_mdof`` -> benchmarks/results/mdof.md
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from benchmarks.bench_dynamics import _law, _params, _timed
from benchmarks.machine import describe, save_results

RESULTS = Path(__file__).resolve().parent / 'results' / 'mdof.md'
GRID_DEG = 0.1


def rows_at(law, mp, rpm: float) -> tuple[list[tuple], float, float]:
    """(rows (solver, setting, s, err m, rel), max lift, reference seconds)."""
    from cam_design.valve_train.mdof import simulate_mdof
    from cam_design.valve_train.mdof_reference import reference_mdof

    grid_run = simulate_mdof(law, mp, rpm, step_deg=GRID_DEG, max_revolutions=1)
    alpha = grid_run.alpha
    t_ref, ref = _timed(lambda: reference_mdof(law, mp, rpm, alpha, method='DOP853',
                                               rtol=1e-12, atol=1e-16))
    ymax = float(np.max(ref.y))
    rows = []
    for step in (2.0, 1.0, 0.5, 0.25, 0.1):
        t, res = _timed(lambda s=step: simulate_mdof(law, mp, rpm, step_deg=s,
                                                     max_revolutions=1), repeat=3)
        idx = np.rint((res.alpha - alpha[0]) / math.radians(GRID_DEG)).astype(int)
        ok = (idx < alpha.size) & (np.abs(res.alpha - alpha[np.minimum(idx, alpha.size - 1)])
                                   < 1e-9)
        err = float(np.max(np.abs(res.y[ok] - ref.y[idx[ok]])))
        rows.append(('exact', f'step {step:g} deg', t, err, err / ymax))
    for method, tols in (('LSODA', (1e-6, 1e-8, 1e-10, 1e-11)), ('Radau', (1e-6, 1e-8))):
        for rtol in tols:
            t, res = _timed(lambda m=method, r=rtol: simulate_mdof(
                law, mp, rpm, step_deg=GRID_DEG, method=m, rtol=r, atol=r * 1e-4))
            err = float(np.max(np.abs(res.y - ref.y)))
            rows.append((f'scipy {method}', f'rtol {rtol:g}', t, err, err / ymax))
    return rows, ymax, t_ref


def speedups(rows: list[tuple]) -> list[str]:
    """For every scipy row: the fastest exact row at an error no larger, and the ratio."""
    ours = [r for r in rows if r[0] == 'exact']
    out = []
    for r in rows:
        if r[0] == 'exact':
            continue
        ok = [o for o in ours if o[3] <= r[3]]
        if not ok:
            out.append(f'- {r[0]} {r[1]} ({r[3]:.1e} m): no exact setting as accurate')
            continue
        best = min(ok, key=lambda o: o[2])
        out.append(f'- {r[0]} {r[1]}: {r[2]:.3f} s at {r[3]:.1e} m; exact {best[1]} '
                   f'{best[2]:.4f} s at {best[3]:.1e} m: **{r[2] / best[2]:.0f}x**')
    return out


def shooting_rows(law, mp, rpm: float) -> list[str]:
    from cam_design.valve_train.mdof import simulate_mdof

    lines = ['| method | revolutions | residual [m] | settled | time [s] |',
             '|---|---:|---:|---|---:|']
    t, res = _timed(lambda: simulate_mdof(law, mp, rpm, step_deg=0.5, max_revolutions=12,
                                          periodic_tol=1e-12))
    lines.append(f'| Newton shooting (default) | {res.revolutions} | '
                 f'{res.periodic_residual:.1e} | {res.settled} | {t:.3f} |')
    from cam_design.valve_train.cam_input import build_cam_input
    from cam_design.valve_train.mdof import MdofAssembly
    from cam_design.valve_train.mdof_exact import run_exact

    asm = MdofAssembly(mp)
    cam = build_cam_input(law, mp.base.rocker_ratio, 0.0, math.radians(0.5),
                          pre=math.radians(1.0))
    for revs in (res.revolutions, 12, 40):
        t, ex = _timed(lambda n=revs: run_exact(asm, cam, rpm * math.pi / 30,
                                                max_revolutions=n, periodic_tol=1e-12,
                                                shooting=False))
        lines.append(f'| repeated revolutions | {ex.revolutions} | '
                     f'{ex.periodic_residual:.1e} | {ex.settled} | {t:.3f} |')
    return lines


def main() -> None:
    from cam_design.valve_train.mdof import mdof_from_mapping

    law, p = _law(), _params()
    mp = mdof_from_mapping(None, p)
    lines = ['# MDOF benchmark (valve_train 4+N1+N2)', '', f'Machine: {describe()}', '',
             'Model: 4+8+8 (40 states), defaults derived from the SDOF scene values, '
             'penalty seat 1e9 N/m; lobe flat_tappet_intake; one revolution from rest. '
             'Errors: max |y - y_ref| of the valve lift on the 0.1 deg grid (exact: its '
             'nodes on that grid) against scipy DOP853 rtol 1e-12 with a restart at every '
             'switch on the exact lift law (`mdof_reference`). Times: best of 3 for the '
             'exact solver, single runs for scipy (wall clock, shared machine).', '']
    for rpm in (1500.0, 3000.0):
        rows, ymax, t_ref = rows_at(law, mp, rpm)
        lines += [f'## {rpm:g} rpm (max lift {ymax * 1e3:.3f} mm, reference {t_ref:.1f} s)',
                  '', '| solver | setting | time [s] | max valve-lift error [m] | '
                  'relative |', '|---|---|---:|---:|---:|']
        for name, setting, t, err, rel in rows:
            lines.append(f'| {name} | {setting} | {t:.4f} | {err:.2e} | {rel:.1e} |')
        lines += ['', 'Speed-up at equal or better error:', ''] + speedups(rows) + ['']
        print('\n'.join(lines[-len(rows) - 12:]), flush=True)
    lines += ['## Periodic state at 1500 rpm (step 0.5 deg, tolerance 1e-12 m)', '']
    lines += shooting_rows(law, mp, 1500.0) + ['']
    text = '\n'.join(lines) + '\n'
    save_results(RESULTS, text)
    print(text)


if __name__ == '__main__':
    main()
