"""analyze in one pass: CPU time of the offline analysis of a bag, and its scene parses.

``analyze_bag`` of ``bags/default_clean`` with the HTML report's tables
(``plot_tables=True``, what ``analyze --report`` runs), after one warm-up call: the CPU
time (user + sys of this process) of each of five calls, and how many times the scene
text was validated per call (one since the parse is shared by the bag check and the
three cores). Run: ``python -m benchmarks analyze_pass``.
"""
from __future__ import annotations

import resource
from pathlib import Path

from benchmarks.machine import report

ROOT = Path(__file__).resolve().parent.parent
BAG = ROOT / 'bags' / 'default_clean'
RESULT = ROOT / 'benchmarks' / 'results' / 'analyze_pass.md'
REPEATS = 5


def _cpu_s() -> float:
    """user + sys CPU time [s] of this process."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def run() -> list[str]:
    """The results rows."""
    from cam_metrology.offline.analyze import analyze_bag
    from cam_metrology.scene import parse

    real = parse._parse_document
    parses: list[int] = []

    def counting(*args: object) -> object:
        parses[-1] += 1
        return real(*args)   # type: ignore[arg-type]

    analyze_bag(str(BAG), plot_tables=True)   # warm-up: imports, caches
    parse._parse_document = counting   # type: ignore[assignment]
    cpu = []
    try:
        for _ in range(REPEATS):
            parses.append(0)
            c0 = _cpu_s()
            analyze_bag(str(BAG), plot_tables=True)
            cpu.append(_cpu_s() - c0)
    finally:
        parse._parse_document = real   # type: ignore[assignment]
    cpu.sort()
    return ['| bag | calls | CPU s per call (min / median / max) | scene parses per call |',
            '|---|---|---|---|',
            f'| default_clean | {REPEATS} | {cpu[0]:.2f} / {cpu[REPEATS // 2]:.2f} / '
            f'{cpu[-1]:.2f} | {max(parses)} |']


def main() -> None:
    """Run and write the results table."""
    report('analyze in one pass', __doc__, run(), RESULT)


if __name__ == '__main__':
    main()
