"""Benchmark of ``cam-bench batch``: throughput on 1 and 2 local Dask workers over
simulated bags (bags/s, samples/s, scaling factor) and the peak memory of a worker.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_batch [N_BAGS]``
(default 200 bags of 4 lobes + pin at 720 samples/rev; writes results/batch.md).
"""
from __future__ import annotations

import resource
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.machine import describe, save_results

RESULT = Path(__file__).resolve().parent / 'results' / 'batch.md'


def _samples(bags: list[Path]) -> int:
    import yaml
    total = 0
    for b in bags:
        info = yaml.safe_load((b / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
        for t in info.get('topics_with_message_count', []):
            if t['topic_metadata']['name'] == '/bench/joint_states':
                total += int(t['message_count'])
    return total


def run(n: int) -> list[str]:
    from cam_metrology.offline.batch import run_batch

    rows = ['| workers | bags | wall [s] | bags/s | samples/s | scaling | failed |',
            '|---|---|---|---|---|---|---|']
    with tempfile.TemporaryDirectory(prefix='cam_bench_batch_') as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        bags = []
        import contextlib
        import io

        from cam_metrology.cli import main
        for i in range(1, n + 1):
            bag = root / f'part_{i:04d}'
            with contextlib.redirect_stdout(io.StringIO()):
                code = main(['simulate', str(bag), '--seed', str(i), '--noise-um', '0.5',
                             '--samples-per-rev', '720'])
            if code != 0:
                raise RuntimeError(f'simulate failed for seed {i}')
            bags.append(bag)
        made = time.perf_counter() - t0
        samples = _samples(bags)
        base = None
        for workers in (1, 2):
            out = root / f'r{workers}.parquet'
            t1 = time.perf_counter()
            s = run_batch(bags, out, workers=workers)
            wall = time.perf_counter() - t1
            rate = len(bags) / wall
            base = base or rate
            rows.append(f'| {workers} | {len(bags)} | {wall:.1f} | {rate:.2f} | '
                        f'{samples / wall:,.0f} | {rate / base:.2f} | {s.failed} |')
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return [f'{n} bags simulated in {made:.1f} s ({samples:,} JointState samples in all).',
            f'Peak RSS of the largest worker process: {peak:.0f} MB.', ''] + rows


def main() -> None:
    """Run and write the results table."""
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    lines = ['# Batch analysis benchmark (Dask LocalCluster)', '', describe(), ''] + run(n)
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
