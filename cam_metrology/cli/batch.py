"""`cam-bench batch INPUTS... --out results.parquet`: many bags in parallel on Dask."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``batch`` subcommand."""
    p = subparsers.add_parser(
        'batch', help='analyse many bags in parallel (Dask) into a Parquet/CSV table',
        description='Analyse every bag named by INPUTS (bag folders, folders searched for '
                    'bags, glob patterns, or @LIST files) exactly as `cam-bench analyze` '
                    'does, in parallel on a local Dask cluster or on an existing scheduler. '
                    'One row per bag and feature with every report field, provenance (bag '
                    'SHA-256, camshaft id, cam-bench version) and failures as rows with '
                    'their reason. Bags already in --out (same path and hash) are skipped '
                    'unless --redo.')
    p.add_argument('inputs', nargs='+', metavar='INPUT')
    p.add_argument('--out', required=True, metavar='FILE.parquet', help='results table')
    p.add_argument('--csv', metavar='FILE.csv', help='also write the table as CSV')
    p.add_argument('--dfq', metavar='FILE.dfq', help='also write every part of the table '
                   'as one Q-DAS AQDEF transfer file (values with date/time, operator and '
                   'part id)')
    p.add_argument('--scheduler', metavar='ADDRESS', help='existing Dask scheduler, e.g. '
                   'tcp://10.0.0.5:8786 (default: a local cluster)')
    p.add_argument('--workers', type=int, default=2, help='local worker processes '
                   '(default 2)')
    p.add_argument('--all-cores', action='store_true', help='also run the reconstruction '
                   'and dynamics cores on every bag (slower; the table holds the metrology '
                   'report either way)')
    p.add_argument('--redo', action='store_true', help='analyse bags again even if they '
                   'are in --out')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler: 0 when every bag was analysed, 1 when some failed, 2 for bad input."""
    from cam_design.errors import InputError
    from cam_metrology.offline.batch import find_bags, run_batch

    out = Path(args.out)
    if out.is_dir() or not out.parent.is_dir():
        raise InputError('--out', args.out, 'a file in an existing directory')
    if not 1 <= args.workers <= 64:
        raise InputError('--workers', args.workers, 'an integer in [1, 64]')
    bags = find_bags(args.inputs)
    if not bags:
        raise InputError('INPUTS', ' '.join(args.inputs), 'at least one bag')
    print(f'cam-bench batch: {len(bags)} bags', file=sys.stderr)
    summary = run_batch(bags, out, csv=Path(args.csv) if args.csv else None,
                        scheduler=args.scheduler, workers=args.workers, redo=args.redo,
                        all_cores=args.all_cores,
                        progress=lambda m: print(m, file=sys.stderr, flush=True))
    if args.dfq:
        from cam_metrology.offline.batch import read_table
        from cam_metrology.quality.qdas import write_dfq
        n = write_dfq(args.dfq, read_table(out))
        print(f'cam-bench batch: {n} characteristics in {args.dfq}', file=sys.stderr)
    print(f'cam-bench batch: {summary.analysed} analysed, {summary.skipped} already in '
          f'{out.name}, {summary.duplicates} duplicates, {summary.failed} failed; '
          f'{summary.rows} rows in {out} ({summary.seconds:.1f} s)')
    return 1 if summary.failed else 0
