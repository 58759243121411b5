"""Peak memory of ``cam-bench analyze`` against the size of one feature, at a fixed
bag size.

    .venv/bin/python -m benchmarks.bench_memory_features [--samples 10000000]
        [--features 1,3,100] [--single 2e6,5e6]

For each count F of features, a bag of about ``--samples`` samples (default scene's
lobes, 1 um probe noise) in which every feature holds samples / F samples:
F = 1: lobe_1 alone; F = 3: lobes 1-3; F = 100: the five features of the default scene
measured 20 times over (``write_sim_bag(rounds=20)``); ``--single``: bags of one
feature of those sample counts besides (the curve against feature size). Each bag is analysed by
``cam-bench analyze BAG --only-metrology --json F`` in a child process
(``bench_memory.measure``: peak RSS, CPU time user + system, wall time) and deleted.
The 300 MB goal is drawn on the plot. Measuring 10 M samples takes minutes of CPU for
each bag (simulating it and analysing it): run it on a quiet machine.
Writes ``benchmarks/results/memory_features.md`` and ``memory_features.png``.
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

from benchmarks.bench_memory import finish_plot, measure
from benchmarks.machine import describe, save_results

RESULTS = Path(__file__).resolve().parent / 'results' / 'memory_features.md'
PLOT = RESULTS.with_suffix('.png')
SAMPLES_PER_REV = 3600


def write_bag(path: Path, samples: int, features: int) -> tuple[int, int]:
    """A bag of about ``samples`` samples in ``features`` features of equal size;
    returns (samples, samples of the largest feature)."""
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.scene.parse import parse_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    doc = yaml.safe_load(Path(default_scene_path()).read_text(encoding='utf-8'))
    rounds = 1
    if features <= len(doc['lobes']):
        doc['lobes'] = doc['lobes'][:features]
        doc.pop('dowel_pin', None)
        per_round = features
    else:   # the default scene's features measured again and again
        per_round = len(doc['lobes']) + (1 if doc.get('dowel_pin') else 0)
        rounds = max(1, round(features / per_round))
    scene = parse_scene(yaml.safe_dump(doc, sort_keys=False), 'bench_memory_features')
    revs = samples / (per_round * rounds * SAMPLES_PER_REV)
    run = write_sim_bag(path, scene, SimParams(probe_noise=1e-6, revolutions=revs,
                                               samples_per_rev=SAMPLES_PER_REV),
                        rounds=rounds)
    return run.sample_count * rounds, max(f.theta.size for f in run.features)


def plot(rows: list[dict[str, Any]], path: Path) -> None:
    """Peak RSS against the samples of the largest feature."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    rows = sorted(rows, key=lambda r: r['largest'])
    x = [r['largest'] for r in rows]
    ax.plot(x, [r['rss'] for r in rows], '-o', color='C3', label='peak RSS of analyze')
    for r in rows:
        ax.annotate(f"{r['features']} x {r['largest'] / 1e6:.2g} M", (r['largest'], r['rss']),
                    textcoords='offset points', xytext=(4, 6), fontsize=8)
    ax.axhline(300, color='grey', lw=0.8, ls=':')
    ax.text(max(x), 290, '300 MB goal', color='grey', ha='right', va='top')
    ax.set_ylim(0, 1.15 * max(300.0, max(r['rss'] for r in rows)))   # room for the labels
    bags = sorted({round(r['samples'] / 1e6, 2) for r in rows})
    finish_plot(fig, ax, path, 'samples of the largest feature (bags of %s samples)'
                % ', '.join(f'{b:g} M' for b in bags), 'peak RSS [MB]',
                'cam-bench analyze --only-metrology: memory against feature size')


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and write the table and plot."""
    p = argparse.ArgumentParser(prog='python -m benchmarks.bench_memory_features')
    p.add_argument('--samples', type=float, default=1e7)
    p.add_argument('--features', default='1,3,100')
    p.add_argument('--single', default='',
                   help='sample counts of extra one-feature bags, e.g. 2e6,5e6')
    p.add_argument('--tmp', default=tempfile.gettempdir())
    args = p.parse_args(argv)
    machine = describe()
    rows: list[dict[str, Any]] = []
    runs = [(int(args.samples), int(c)) for c in args.features.split(',') if c]
    runs += [(int(float(n)), 1) for n in args.single.split(',') if n]
    for samples, count in runs:
        work = Path(tempfile.mkdtemp(prefix='cam_bench_memfeat_', dir=args.tmp))
        try:
            t0 = time.perf_counter()
            n, largest = write_bag(work / 'bag', samples, count)
            write_s = time.perf_counter() - t0
            rss, wall, code, cpu = measure(work / 'bag', work / 'r.json', None, False)
            rows.append({'features': count, 'samples': n, 'largest': largest, 'rss': rss,
                         'cpu': cpu, 'wall': wall, 'code': code, 'write_s': write_s,
                         'load': os.getloadavg()[0]})
            print(rows[-1], flush=True)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    lines = ['# Memory of `analyze` against feature size (`python -m '
             'benchmarks.bench_memory_features`)', '', f'Machine: {machine}.', '',
             '`cam-bench analyze BAG --only-metrology --json F` in a child process, one run '
             'each; peak RSS and CPU time (user + system) of the child; load = 1-min load '
             'average after the run (other jobs share the machine).', '',
             '| features | samples | samples of the largest feature | peak RSS [MB] | '
             'CPU [s] | wall [s] | exit | load |', '|---:|---:|---:|---:|---:|---:|---:|---:|']
    rows.sort(key=lambda r: (-r['samples'], r['features']))
    lines += [f"| {r['features']} | {r['samples']:,} | {r['largest']:,} | {r['rss']:.0f} | "
              f"{r['cpu']:.1f} | {r['wall']:.1f} | {r['code']} | {r['load']:.1f} |"
              for r in rows]
    lines += ['', f'Load average at the end: {os.getloadavg()[0]:.2f}.']
    text = '\n'.join(lines) + '\n'
    save_results(RESULTS, text)
    if rows:
        plot(rows, PLOT)
    print(text)


if __name__ == '__main__':
    main()
