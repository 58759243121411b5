"""Where ``cam-bench analyze`` of one long feature holds its memory: peak RSS per
stage of the analysis.

    .venv/bin/python -m benchmarks.bench_memory_stages [--samples 2000000]

A bag of one lobe of ``--samples`` samples (``bench_memory_features.write_bag``) is
analysed (``analyze BAG --only-metrology --json F``) in a child process in which a
thread reads the resident set (``/proc/self/statm``) every 5 ms and notes, for each
stage (the innermost function of the main thread in ``cam_metrology.metrology``
or ``cam_metrology.offline``), the largest RSS seen while it ran. The shape at 2 M
samples is that of 10 M at a fifth of the cost (``--samples 1e7`` on a quiet
machine: minutes). Sampling misses stages shorter than 5 ms; the per-stage RSS
includes everything still alive from earlier stages.
Writes ``benchmarks/results/memory_stages.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from benchmarks.bench_memory_features import write_bag
from benchmarks.machine import describe, save_results

RESULTS = Path(__file__).resolve().parent / 'results' / 'memory_stages.md'
#: folders whose functions name a stage
STAGE_DIRS = ('cam_metrology/metrology/', 'cam_metrology/offline/')


def _rss_mb() -> float:
    """Resident set size of this process [MB]."""
    with open('/proc/self/statm', encoding='ascii') as f:
        return int(f.read().split()[1]) * os.sysconf('SC_PAGE_SIZE') / 2**20


def _peak_mb() -> float:
    """Peak resident set of this process since its ``exec`` (``VmHWM``) [MB]
    (``ru_maxrss`` would carry the forking parent's peak over)."""
    with open('/proc/self/status', encoding='ascii') as f:
        for line in f:
            if line.startswith('VmHWM:'):
                return int(line.split()[1]) / 1024
    return float('nan')


def _stage(frame: Any) -> str | None:
    """``module.function:line`` of the innermost frame in ``STAGE_DIRS``."""
    while frame is not None:
        name = frame.f_code.co_filename.replace(os.sep, '/')
        for d in STAGE_DIRS:
            if d in name:
                mod = name.split(d, 1)[1].removesuffix('.py')
                return f'{mod}.{frame.f_code.co_name}'
        frame = frame.f_back
    return None


def child(bag: str, report: str) -> None:
    """Analyse ``bag`` here, sampling the RSS per stage; print one JSON line."""
    main_id = threading.get_ident()
    stages: dict[str, list[float]] = {}   # stage -> [first seen s, largest RSS MB]
    t0 = time.perf_counter()
    done = threading.Event()

    def sample() -> None:
        while not done.is_set():
            frame = sys._current_frames().get(main_id)
            key = _stage(frame) if frame is not None else None
            if key is not None:
                row = stages.setdefault(key, [time.perf_counter() - t0, 0.0])
                row[1] = max(row[1], _rss_mb())
            time.sleep(0.005)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    from cam_metrology.cli import main as cli_main
    try:
        cli_main(['analyze', bag, '--only-metrology', '--json', report])
    except SystemExit:
        pass
    done.set()
    thread.join()
    print(json.dumps({'stages': stages, 'peak': _peak_mb()}))


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and write the table."""
    p = argparse.ArgumentParser(prog='python -m benchmarks.bench_memory_stages')
    p.add_argument('--samples', type=float, default=2e6)
    p.add_argument('--tmp', default=tempfile.gettempdir())
    p.add_argument('--child', nargs=2, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        child(*args.child)
        return
    machine = describe()
    work = Path(tempfile.mkdtemp(prefix='cam_bench_memstage_', dir=args.tmp))
    try:
        n, _ = write_bag(work / 'bag', int(args.samples), 1)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        out = subprocess.run([sys.executable, '-m', 'benchmarks.bench_memory_stages',
                              '--child', str(work / 'bag'), str(work / 'r.json')],
                             capture_output=True, text=True, check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    data = json.loads(out.stdout.strip().splitlines()[-1])
    rows = sorted(data['stages'].items(), key=lambda kv: kv[1][0])
    lines = ['# Peak RSS per stage of `analyze`, one feature (`python -m '
             'benchmarks.bench_memory_stages`)', '', f'Machine: {machine}.', '',
             f'One lobe of {n:,} samples; peak RSS of the child {data["peak"]:.0f} MB, '
             f'CPU (user + system) {cpu:.1f} s, load {os.getloadavg()[0]:.2f} after the '
             'run. RSS sampled every 5 ms; a stage is the innermost function in '
             '`cam_metrology/metrology` or `cam_metrology/offline` (first seen [s] '
             'from the start of the child).', '',
             '| first seen [s] | stage | largest RSS while it ran [MB] |', '|---:|---|---:|']
    lines += [f'| {first:.2f} | `{key}` | {rss:.0f} |' for key, (first, rss) in rows]
    text = '\n'.join(lines) + '\n'
    save_results(RESULTS, text)
    print(text)


if __name__ == '__main__':
    main()
