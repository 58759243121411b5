"""What every benchmark shares: the machine line of its table, the best-of timer, saving
the results."""
from __future__ import annotations

import math
import os
import platform
import time
from pathlib import Path


def describe() -> str:
    """CPU model, core count, Python version and the 1-minute load average."""
    model = platform.processor() or 'unknown CPU'
    try:
        with open('/proc/cpuinfo', encoding='utf-8') as f:
            for line in f:
                if line.startswith('model name'):
                    model = line.split(':', 1)[1].strip()
                    break
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, 'getloadavg') else float('nan')
    return (f'{model}, {os.cpu_count()} cores, Python {platform.python_version()}, '
            f'load average {load:.2f} at start')


def report(title: str, doc: str | None, rows: list[str], path: Path) -> None:
    """Print and save a results table: ``# title``, the machine line, the second
    paragraph of the benchmark's docstring ``doc`` (what was run), then ``rows``."""
    text = '\n'.join([f'# {title}', '', describe(), '', (doc or '').split('\n\n')[1], '']
                     + rows) + '\n'
    print(text)
    save_results(path, text)


def save_results(path: Path, text: str) -> None:
    """Write a benchmark's Markdown results to ``path`` (UTF-8; folders created)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding='utf-8')


def best_time(fn, repeats: int) -> tuple[float, object]:
    """(smallest wall time [s] of ``repeats`` calls of ``fn``, the last result)."""
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out
