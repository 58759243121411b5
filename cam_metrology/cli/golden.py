"""`cam-bench golden BAG OUT.json`: freeze a bag's report as the golden reference.

The golden file is the JSON report of ``cam-bench analyze BAG`` without the run's
provenance; tests compare later runs with it within stated tolerances
(``cam_metrology.report.golden.assert_report_matches``, or the pytest plugin's
``cam_bench_analysis`` fixture: see docs/cli.md, "pytest over your own bags").
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from cam_metrology.offline.analyze import analyze_report  # noqa: F401 (re-exported)


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``golden`` subcommand."""
    p = subparsers.add_parser(
        'golden', help="write a bag's report as a golden file for regression tests",
        description="Analyse BAG exactly as `cam-bench analyze` does and write its JSON "
                    "report, without the run's provenance, to OUT. Later runs are compared "
                    "with it within tolerances by the pytest plugin (assert_report_matches).")
    p.add_argument('bag', metavar='BAG', help='rosbag2 directory (metadata.yaml + MCAP)')
    p.add_argument('out', metavar='OUT',
                   help='golden JSON file to write (refused if it exists, unless --force)')
    p.add_argument('--params', metavar='FILE', help='ROS parameter YAML for the cores, as '
                   'for analyze')
    p.add_argument('--force', action='store_true', help='overwrite an existing OUT')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench golden``: 0 when written, 2 for bad input."""
    from cam_design.errors import InputError
    from cam_metrology.report.golden import golden_of

    out = Path(args.out)
    if out.exists() and not args.force:
        raise InputError('OUT', out, 'a file that does not exist yet (or --force)')
    if out.is_dir():
        raise InputError('OUT', out, 'a file name, not a directory')
    if not out.parent.is_dir():
        raise InputError('OUT', out, f'a file in an existing directory ({out.parent} '
                         'does not exist)')
    report = golden_of(analyze_report(args.bag, args.params))
    from cam_metrology.report.json_out import write_json
    write_json(out, report, 'OUT', sort_keys=True)
    n = len(report.get('features', {}))
    print(f'cam-bench golden: wrote {out} ({n} features of {args.bag})')
    return 0
