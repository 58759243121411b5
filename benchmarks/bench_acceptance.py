"""Benchmark of the acceptance layer: how well a form error is seen by the verdict
quantities, how accurate the measured cam-card events are under noise, and what the
verdict and the cards cost.

Run: ``.venv/bin/python -m benchmarks.bench_acceptance`` (writes results/acceptance.md).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.machine import describe, save_results

RESULT = Path(__file__).resolve().parent / 'results' / 'acceptance.md'
DEG = math.pi / 180.0


def form_error_rows() -> list[str]:
    """A lobe ground lift_scale x the design: true max-lift error vs what is reported."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.offline.replay import run_offline
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag
    import tempfile

    scene = load_scene('config/default_scene.yaml')
    rows = ['| lift_scale | true max-lift error [µm] | fit_runout | reported lift_error max_plus '
            '[µm] | max lift error, fit offset [µm] | max_lift_error (base-referenced) [µm] | '
            'duration error @1 mm [deg] (true) | verdict+cards [ms] |',
            '|---|---|---|---|---|---|---|---|']
    with tempfile.TemporaryDirectory() as tmp:
        for scale in (1.001, 1.002, 1.005):
            bag = Path(tmp) / f's{scale}'
            write_sim_bag(bag, scene, SimParams(samples_per_rev=3600, lift_scale=scale))
            for runout in (True, False):
                core = MetrologyCore({'fit_runout': runout})
                run_offline(bag, [core])
                design = core._design['lobe_1']
                table = core.results['lobe_1'].table
                assert table is not None     # the lobe of the fixture bag is measured
                from cam_design.cam_card import law_events, law_peak, table_events, table_peak
                from cam_metrology.metrology.lift_error import base_referenced
                t0 = time.perf_counter()
                report = core.report()
                raw = table_peak(table[:, 0], table[:, 1], design)[1]
                table = base_referenced(table, runout)[0]
                _, mp = table_peak(table[:, 0], table[:, 1], design)
                _, npk = law_peak(design)
                o, c = table_events(table[:, 0], table[:, 1], 1e-3, design)
                o0, c0 = law_events(design, 1e-3)
                ms = (time.perf_counter() - t0) * 1e3
                true = (scale - 1) * npk * 1e6
                o1, c1 = law_events(design, 1e-3 / scale)
                f = report['features']['lobe_1']
                rows.append(f'| {scale} | {true:.2f} | {runout} | '
                            f'{f["lift_error_um"]["max_plus"]:.2f} | {(raw - npk) * 1e6:.2f} | '
                            f'{(mp - npk) * 1e6:.2f} | '
                            f'{math.degrees((c - o) - (c0 - o0)):.4f} '
                            f'({math.degrees((c1 - o1) - (c0 - o0)):.4f}) | {ms:.0f} |')
    return rows


def event_rows() -> list[str]:
    """Events of a noisy measured table vs the closed-form constant-acceleration lobe."""
    from cam_design.cam_card import card_from_table
    from cam_design.lift_laws.registry import from_spec

    H, A0, P1 = 8e-3, 60 * DEG, 20 * DEG
    law = from_spec({'family': 'constant_acceleration', 'ramp': 'none', 'rise': H,
                     'half_angle': A0, 'positive_width': P1})
    a1 = 2 * H / (P1 * A0)
    t = math.sqrt(2 * 1e-3 / a1)
    truth = math.degrees(-A0 + t)
    rows = ['| noise [µm] | samples/rev | reference | RMS opening error @1 mm [deg] | '
            'card time [ms] |', '|---|---|---|---|---|']
    rng = np.random.default_rng(1)
    for noise in (0.5, 2.0):
        for n in (720, 3600):
            for ref in (law, None):
                errs, times = [], []
                for _ in range(20):
                    a = np.linspace(-math.pi, math.pi, n, endpoint=False)
                    h = law(a) + rng.normal(0, noise * 1e-6, n)
                    t0 = time.perf_counter()
                    card = card_from_table(a, h, (1e-3,), ref)
                    times.append(time.perf_counter() - t0)
                    errs.append(card['heights'][0]['opening_deg'] - truth)
                rms = float(np.sqrt(np.mean(np.square(errs))))
                rows.append(f'| {noise} | {n} | {"design" if ref else "none"} | {rms:.5f} | '
                            f'{np.median(times) * 1e3:.1f} |')
    return rows


def main() -> None:
    text = '\n'.join(['# Acceptance benchmark', '', describe(), '',
                      '## A form error (lift scaled) as the verdict sees it (lobe_1, '
                      'default scene, no noise)', ''] + form_error_rows() +
                     ['', '## Measured cam-card events under noise (20 runs each)', '']
                     + event_rows()) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
