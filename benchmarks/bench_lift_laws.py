"""Lift-law benchmark: evaluation rate and accuracy of every family.

Rate: points/s of ``law.derivatives(alpha)`` (h, h', h'', h''' at once) on 10^5
points over the support, best of 5. Accuracy, per family:
* polynomial: max |h - h_exact| against an exact ``fractions.Fraction`` evaluation
  (exact coefficients from exact inputs) at 200 points, incl. exponents up to 50;
* every family: the largest junction jump in the stated orders, relative to
  max |h^(n)| (the construction check);
* polydyne: max |k h - (x0 + F0/c + (1 + c'/c) y_d + eps y_d'')| [m];
* harmonic: end-condition residual [m]; dual_peak: connection end residuals [m];
* table: TabulatedLift of the preset at 0.5 deg vs the analytic law at midpoints.
Run: ``.venv/bin/python -m benchmarks.bench_lift_laws`` (well under a minute).
"""
from __future__ import annotations

import math
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

from benchmarks.machine import describe, save_results

DEG = math.pi / 180
MM = 1e-3
V = 0.015 * MM / DEG
S2 = {'kind': 'constant_acceleration_velocity', 'height': 0.3 * MM, 'velocity': V,
      'angle': 30 * DEG}
TRAIN = {'rocker_ratio': 1.5, 'lash': 0.25 * MM, 'mass': 0.12, 'stiffness': 1.2e7,
         'spring_rate': 3e4, 'spring_preload': 250.0, 'design_cam_speed_rpm': 1500}
OUT = Path(__file__).resolve().parent / 'results' / 'lift_laws.md'


def rate(law, n: int = 100_000) -> tuple[float, float]:
    """(points/s, build-independent) of derivatives on n points, best of 5."""
    a = np.linspace(*law.support, n)
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        law.derivatives(a)
        best = min(best, time.perf_counter() - t0)
    return n / best, best


def junction_residual(law) -> float:
    """Largest stated-order junction jump relative to max |h^(n)|."""
    lo, hi = law.support
    grid = np.linspace(lo, hi, 4001)
    scale = [max(float(np.max(np.abs(law(grid, nu)))), 1e-300) for nu in range(4)]
    worst = 0.0
    for j in getattr(law, 'junction_report', ()):
        for nu in range(j.required + 1):
            worst = max(worst, j.jumps[nu] / scale[nu])
    return worst


def exact_polynomial_error(exps: list[int]) -> float:
    """max |h - exact| [m] at 200 points of the base section of a polynomial lobe."""
    from cam_design.lift_laws import from_spec

    rise, half = 8 * MM, 50 * DEG
    law = from_spec({'family': 'polynomial', 'ramp': S2, 'rise': rise, 'half_angle': half,
                     'exponents': exps}, 'L')
    fr = [Fraction(rise), Fraction(V) * Fraction(half)]
    n = len(exps)
    a = [[Fraction(math.perm(e, m)) for e in exps] + [(-fr[0], -fr[1], 0, 0)[m]]
         for m in range(n)]
    for col in range(n):
        for r in range(n):
            if r != col:
                f = a[r][col] / a[col][col]
                a[r] = [x - f * y for x, y in zip(a[r], a[col])]
    c = {e: a[i][n] / a[i][i] for i, e in enumerate(exps)}
    xs = np.linspace(0, 1, 200)
    err = 0.0
    for x in xs:
        xf = Fraction(float(x))
        exact = Fraction(0.3 * MM) + fr[0] + sum(ci * xf ** e for e, ci in c.items())
        alpha = -float(xf) * half          # x = -alpha/alpha0 on the rise flank
        err = max(err, abs(float(law(alpha)) - float(exact)))
    return err


def main() -> None:
    """Run and write benchmarks/results/lift_laws.md."""
    from cam_design.lift_laws import PRESETS, TabulatedLift, from_spec

    import scipy.interpolate  # noqa: F401  (import cost out of the build times)
    import scipy.linalg  # noqa: F401
    import scipy.optimize  # noqa: F401

    t_start = time.perf_counter()
    machine = describe()
    rows = []
    specs = {
        'polynomial 2-6-10-14 (methods_example)': PRESETS['methods_example'],
        'polynomial 2-10-18-26 (flat_tappet_intake)': PRESETS['flat_tappet_intake'],
        'polynomial 2-20-35-50': dict(PRESETS['methods_example'], exponents=[2, 20, 35, 50]),
        'polynomial 44-46-48-50': dict(PRESETS['methods_example'],
                                       exponents=[44, 46, 48, 50]),
        'constant_acceleration (3 segments)': {
            'family': 'constant_acceleration', 'ramp': S2, 'rise': 8 * MM,
            'half_angle': 50 * DEG, 'positive_width': 15 * DEG, 'nose_width': 15 * DEG,
            'nose_ratio': 0.5},
        'composite half_sine + quarter_sine': {
            'family': 'composite', 'ramp': S2, 'rise': 8 * MM,
            'segments': [{'shape': 'half_sine', 'width': 15 * DEG},
                         {'shape': 'quarter_sine', 'width': 35 * DEG}]},
        'polydyne 2-6-10-14-18 + CV ramp': dict(TRAIN, family='polydyne', valve_lift=8 * MM,
                                                half_angle=50 * DEG, ramp_velocity=V),
        'harmonic N=15 fit to methods_example': {
            'family': 'harmonic', 'order': 15, 'half_angle': 80 * DEG, 'max_lift': 8.3 * MM,
            'target': PRESETS['methods_example']},
        'harmonic N=15 with S2 ramps, fit to methods_example': {
            'family': 'harmonic', 'order': 15, 'half_angle': 50 * DEG, 'max_lift': 8.3 * MM,
            'ramp': S2, 'target': PRESETS['methods_example']},
        'dual_peak (S2 example)': {
            'family': 'dual_peak', 'ramp': S2, 'rise': 8 * MM, 'half_angle': 50 * DEG,
            'connection': {'start': 5 * DEG, 'angle': 40 * DEG, 'point_angle': 20 * DEG,
                           'point_lift': 0.1 * MM},
            'secondary': {'rise': 1.5 * MM, 'half_angle': 20 * DEG,
                          'ramp': {'height': 0.25 * MM, 'velocity': 0.0125 * MM / DEG,
                                   'angle': 30 * DEG}}},
    }
    for spec in specs.values():      # warm-up: module imports out of the build times
        from_spec(spec, 'warm-up')
    for name, spec in specs.items():
        t0 = time.perf_counter()
        law = from_spec(spec, 'bench')
        build = time.perf_counter() - t0
        pts, _ = rate(law)
        extra = ''
        if name.startswith('polynomial'):
            exps = spec.get('exponents', [2, 6, 10, 14])
            extra = f'max abs(h - Fraction exact) = {exact_polynomial_error(exps):.2e} m'
        elif name.startswith(('constant', 'composite')):
            extra = (f'nose: abs(h - 8.3 mm) = {abs(float(law(0.0)) - 8.3 * MM):.1e} m, '
                     f"abs(h'(0-)) = {abs(float(law(-1e-300, 1))):.1e} m/rad")
        elif name.startswith('polydyne'):
            seg, tr = law.valve_motion[0], law.train
            a = np.linspace(seg.lo, seg.hi, 10001)
            rhs = (tr.lash + tr.spring_preload / tr.stiffness
                   + (1 + tr.spring_rate / tr.stiffness) * seg(a) + tr.eps * seg(a, 2))
            res = np.max(np.abs(tr.rocker_ratio * law(a) - rhs))
            extra = f'inversion identity residual {res:.2e} m'
        elif name.startswith('harmonic'):
            lo, hi = law.support
            tgt = from_spec(spec['target'], 't')
            g = np.linspace(lo, hi, 2001)
            extra = f'fit error to the target {np.max(np.abs(law(g) - tgt(g))):.2e} m'
        elif name.startswith('dual'):
            b = law.connection
            p = np.polynomial.Polynomial(b)
            a4 = 40 * DEG
            extra = (f'connection end residuals: h {abs(p(a4) - 0.25 * MM):.1e} m, '
                     f"h' {abs(p.deriv()(a4) - 0.0125 * MM / DEG):.1e} m/rad")
        rows.append((name, build * 1e3, pts, junction_residual(law),
                     int(law.continuity_order), extra))
    # table interpolation of the preset
    pre = from_spec(PRESETS['flat_tappet_intake'], 'p')
    lo, hi = pre.support
    grid = np.arange(lo, hi + 1e-12, 0.5 * DEG)
    t0 = time.perf_counter()
    tab = TabulatedLift(grid, pre(grid))
    build = time.perf_counter() - t0
    mid = (grid[1:] + grid[:-1]) / 2
    err = [float(np.max(np.abs(tab(mid, nu) - pre(mid, nu)))) for nu in range(3)]
    pts, _ = rate(tab)
    rows.append(('table (TabulatedLift of flat_tappet_intake, 0.5 deg)', build * 1e3, pts,
                 float('nan'), int(tab.continuity_order),
                 f"midpoint error h {err[0]:.1e} m, h' {err[1]:.1e}, h'' {err[2]:.1e}"))
    total = time.perf_counter() - t_start
    lines = ['# Lift-law benchmark', '',
             'Rate: `law.derivatives(alpha)` (h, h\', h\'\', h\'\'\' together) on 10^5 points '
             'over the support, best of 5. Junction jump: the largest jump in the stated '
             'orders at any junction, relative to max |h^(n)|. Accuracy column: see the '
             'module docstring of `benchmarks/bench_lift_laws.py`.', '',
             f'Machine: {machine}', f'Run time: {total:.1f} s. Command: '
             '`.venv/bin/python -m benchmarks.bench_lift_laws`.', '',
             '| law | build [ms] | rate [points/s] | max junction jump (rel.) | C order | '
             'accuracy |', '|---|---|---|---|---|---|']
    for name, b, pts, jr, order, extra in rows:
        jr_s = '-' if math.isnan(jr) else f'{jr:.1e}'
        lines.append(f'| {name} | {b:.2f} | {pts:.3g} | {jr_s} | {order} | {extra} |')
    text = '\n'.join(lines) + '\n'
    save_results(OUT, text)
    print(text)


if __name__ == '__main__':
    main()
