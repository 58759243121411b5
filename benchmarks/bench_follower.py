"""Benchmark of convert_lift: time against max error vs the exact eccentric disc.

Run: ``.venv/bin/python -m benchmarks.bench_follower`` (writes
benchmarks/results/follower.md). Disc of methods §7 #13: R_c = 20 mm, e = 5 mm, roller
8 mm. Times are the best of several repeats (perf_counter); errors are the max over the
evaluated points of |h - h_exact| and of |h^(k) - h^(k)_exact| for k = 1..3.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from benchmarks.machine import best_time, describe, save_results
from cam_design.follower import EccentricDiscLift, Follower, convert_lift

RC, E, R = 0.020, 0.005, 0.008
SIZES = (360, 3600, 36000)
PAIRS = ((Follower('flat'), Follower('roller', R)), (Follower('flat'), Follower('knife')),
         (Follower('roller', R), Follower('flat')))
RESULT = Path(__file__).resolve().parent / 'results' / 'follower.md'


def run() -> list[str]:
    """The Markdown table rows (one per conversion and size)."""
    rows = []
    for source, target in PAIRS:
        law = EccentricDiscLift(RC, E, source)
        exact = EccentricDiscLift(RC, E, target)
        build, conv = best_time(lambda: convert_lift(law, RC - E, source, target), 15)
        for n in SIZES:
            alpha = np.linspace(-math.pi, math.pi, n, endpoint=False)
            t_eval, got = best_time(lambda: conv.derivatives(alpha), 15 if n < 36000 else 5)
            err = np.max(np.abs(got - exact.derivatives(alpha)), axis=1)
            rows.append(f'| {source.kind} -> {target.kind} | {n} | {build * 1e3:.2f} | '
                        f'{t_eval * 1e3:.2f} | {err[0]:.1e} | {err[1]:.1e} | {err[2]:.1e} | '
                        f'{err[3]:.1e} |')
    return rows


def realistic() -> list[str]:
    """Preset flat-tappet lobe -> 2 mm ball probe and back: round-trip error and time."""
    from cam_design.lift_laws import from_spec

    law = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'bench')
    flat, ball = Follower('flat'), Follower('roller', 0.002)
    alpha = np.linspace(-math.pi, math.pi, 3600, endpoint=False)
    build, conv = best_time(lambda: convert_lift(law, 0.0165, flat, ball), 5)
    t_eval, _ = best_time(lambda: conv.derivatives(alpha), 5)
    back = convert_lift(conv, 0.0165, ball, flat)
    t_back, got = best_time(lambda: back.derivatives(alpha), 3)
    err = np.max(np.abs(got - law.derivatives(alpha)), axis=1)
    return [f'| preset flat_tappet_intake: flat -> ball 2 mm | 3600 | {build * 1e3:.2f} | '
            f'{t_eval * 1e3:.2f} | round trip (ball -> flat, {t_back * 1e3:.1f} ms): '
            f'{err[0]:.1e} | {err[1]:.1e} | {err[2]:.1e} | {err[3]:.1e} |']


def brute_force() -> list[str]:
    """Baseline of methods §2.6: max over sampled profile points (lift_from_profile)."""
    from cam_design.cam_profile import flat_profile, lift_from_profile

    law = EccentricDiscLift(RC, E, Follower('flat'))
    alpha = np.linspace(-math.pi, math.pi, 3600, endpoint=False)
    rows = []
    for target in (Follower('roller', R), Follower('knife')):
        exact = EccentricDiscLift(RC, E, target)(alpha)
        for points in (2000, 20000):
            s = np.linspace(-math.pi, math.pi, points, endpoint=False)
            prof = flat_profile(law, RC - E, s)
            t, got = best_time(lambda: lift_from_profile(prof.x, prof.y, alpha, target, RC - E), 2)
            err = np.max(np.abs(got - exact))
            rows.append(f'| baseline lift_from_profile ({points} profile points): flat -> '
                        f'{target.kind} | 3600 | - | {t * 1e3:.1f} | {err:.1e} | - | - | - |')
    return rows


def main() -> None:
    """Run, print and write benchmarks/results/follower.md."""
    machine = describe()
    head = ['| conversion | points | build [ms] | evaluate h..h\'\'\' [ms] | max err h [m] | '
            'h\' [m/rad] | h\'\' [m/rad²] | h\'\'\' [m/rad³] |',
            '|---|---|---|---|---|---|---|---|']
    rows = run() + realistic() + brute_force()
    text = '\n'.join(['# convert_lift benchmark', '',
                      'Eccentric disc R_c = 20 mm, e = 5 mm, roller 8 mm (methods §7 #13); '
                      'errors against the closed forms of methods §2.1/§2.2. Build = '
                      'construction (contact-angle table and undercut checks, once per '
                      'law); evaluate = `derivatives(alpha)` (all four orders, one solve).',
                      '', f'Machine: {machine}', ''] + head + rows) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
