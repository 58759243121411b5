"""Run every benchmark module in turn and write benchmarks/results/<area>.md."""
from __future__ import annotations

import os

os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')   # as the CLI does; before numpy loads

import importlib  # noqa: E402
import pkgutil  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402


def main() -> int:
    """Import and run ``main()`` of every ``benchmarks.bench_*`` module."""
    here = Path(__file__).resolve().parent
    names = sorted(m.name for m in pkgutil.iter_modules([str(here)])
                   if m.name.startswith('bench_'))
    only = set(sys.argv[1:])
    failed = []
    for name in names:
        if only and name not in only and name.removeprefix('bench_') not in only:
            continue
        print(f'== benchmarks.{name}', flush=True)
        t0 = time.perf_counter()
        try:
            importlib.import_module(f'benchmarks.{name}').main()
        except Exception as exc:  # noqa: BLE001 (report and go on with the others)
            print(f'!! {name} failed: {exc!r}', flush=True)
            failed.append(name)
        print(f'== {name}: {time.perf_counter() - t0:.1f} s', flush=True)
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
