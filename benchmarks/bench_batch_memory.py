"""Memory of a `cam-bench batch` worker over a long archive: does it stay flat?

One local Dask worker (one process, one thread) analyses N distinct small bags (default
1000: copies of one simulated two-lobe bag at 360 samples/rev, each made distinct by a
comment in its metadata.yaml, so that none is skipped as a duplicate). The worker's
resident memory (RSS) and its peak (VmHWM, the kernel's high-water mark) are read from
/proc after every bag (the peak over every worker process, recycled ones included)
and reported at checkpoints (10, 100, 300, 1000 bags ...), with the CPU time of the
workers (user + sys) and the load average. Flat means: the peak at 1000 bags is that
at 100 within a few MB. Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m
benchmarks batch_memory`` (or ``-m benchmarks.bench_batch_memory [N]``); writes
results/batch_memory.md. About 0.2-0.4 s of CPU per bag.
"""
from __future__ import annotations

import contextlib
import io
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.machine import describe, save_results

RESULT = Path(__file__).resolve().parent / 'results' / 'batch_memory.md'
SCENE = Path(__file__).resolve().parent.parent / 'bags' / 'scenes' / 'two_lobes_no_pin.yaml'
CHECKPOINTS = (10, 100, 300, 1000, 3000, 10000)


def make_bags(root: Path, n: int) -> list[Path]:
    """``n`` distinct small bags under ``root`` (one simulation, then copies)."""
    from cam_metrology.cli import main

    first = root / 'b00000'
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(['simulate', str(first), '--scene', str(SCENE), '--samples-per-rev',
                     '360', '--noise-um', '0.5', '--seed', '1', '--quiet'])
    if code != 0:
        raise RuntimeError('simulate failed')
    bags = [first]
    for i in range(1, n):
        bag = root / f'b{i:05d}'
        shutil.copytree(first, bag)
        with open(bag / 'metadata.yaml', 'a', encoding='utf-8') as f:
            f.write(f'# copy {i}\n')   # another SHA-256: not a duplicate
        bags.append(bag)
    return bags


def _proc_status(pid: int) -> dict[str, float]:
    """VmRSS and VmHWM [MB] and CPU time (user + sys) [s] of a process."""
    out: dict[str, float] = {}
    with open(f'/proc/{pid}/status', encoding='utf-8') as f:
        for line in f:
            if line.startswith(('VmRSS:', 'VmHWM:')):
                out[line.split(':')[0]] = int(line.split()[1]) / 1024
    with open(f'/proc/{pid}/stat', encoding='utf-8') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    out['cpu_s'] = (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')
    return out


def _worker_pids() -> list[int]:
    """Processes below this one that run a Dask worker (spawned by the nanny)."""
    import psutil

    me = psutil.Process()
    return [p.pid for p in me.children(recursive=True)
            if 'spawn_main' in ' '.join(p.cmdline())]


def run(n: int) -> list[str]:
    from cam_metrology.offline.batch import run_batch

    rows = ['| bags analysed | worker RSS now [MB] | peak of any worker so far (VmHWM) [MB] '
            '| worker processes so far | worker CPU so far [s] | wall [s] | load (1 min) |',
            '|---|---|---|---|---|---|---|']
    marks = [c for c in CHECKPOINTS if c <= n] + ([n] if n not in CHECKPOINTS else [])
    with tempfile.TemporaryDirectory(prefix='cam_bench_batch_mem_') as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        bags = make_bags(root, n)
        made = time.perf_counter() - t0
        t1 = time.perf_counter()
        peak = {'hwm': 0.0}
        cpu: dict[int, float] = {}   # pid -> CPU time last seen (recycled workers too)

        def progress(line: str) -> None:
            if not line.startswith('['):
                return
            done = int(line[1:].split('/', 1)[0])
            stats = {}
            for pid in _worker_pids():
                try:
                    stats[pid] = _proc_status(pid)
                except OSError:   # a worker being replaced
                    continue
            for pid, st in stats.items():
                peak['hwm'] = max(peak['hwm'], st.get('VmHWM', 0.0))
                cpu[pid] = st['cpu_s']
            if done in marks:
                rss = max((st.get('VmRSS', 0.0) for st in stats.values()), default=0.0)
                rows.append(f'| {done} | {rss:.1f} | {peak["hwm"]:.1f} | {len(cpu)} | '
                            f'{sum(cpu.values()):.1f} | {time.perf_counter() - t1:.0f} | '
                            f'{os.getloadavg()[0]:.1f} |')
                print(rows[-1], flush=True)

        summary = run_batch(bags, root / 'out.parquet', workers=1, progress=progress)
    return [f'{n} bags made in {made:.1f} s; analysed by one worker in '
            f'{summary.seconds:.0f} s ({summary.failed} failed).', ''] + rows


def main() -> None:
    """Run and write the results table."""
    n = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1].isdigit() else 1000
    lines = ['# Batch worker memory over a long archive', '', describe(), '',
             __doc__.split('\n\n')[1].replace('\n', ' '), ''] + run(n)
    text = '\n'.join(lines) + '\n'
    print(text)
    save_results(RESULT, text)


if __name__ == '__main__':
    main()
