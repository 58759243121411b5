"""`cam-bench golden BAG OUT.json`: freeze a bag's report as the golden reference.

The golden file is the JSON report of ``cam-bench analyze BAG`` without the run's
provenance; tests compare later runs with it within stated tolerances
(``cam_metrology.golden.assert_report_matches``, or the pytest plugin's
``cam_bench_analysis`` fixture: see the README, "pytest over your own bags").
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
from pathlib import Path
from typing import Any


def register(subparsers: Any) -> None:
    """Add the ``golden`` subcommand."""
    p = subparsers.add_parser(
        'golden', help="write a bag's report as a golden file for regression tests",
        description="Analyse BAG exactly as `cam-bench analyze` does and write its JSON "
                    "report, without the run's provenance, to OUT. Later runs are compared "
                    "with it within tolerances by the pytest plugin (assert_report_matches).")
    p.add_argument('bag', help='rosbag2 directory (metadata.yaml + MCAP)')
    p.add_argument('out', help='golden JSON file to write (refused if it exists, unless '
                   '--force)')
    p.add_argument('--params', metavar='FILE', help='ROS parameter YAML for the cores, as '
                   'for analyze')
    p.add_argument('--force', action='store_true', help='overwrite an existing OUT')
    p.set_defaults(func=run)


def analyze_report(bag: str | Path, params: str | Path | None = None, *,
                   only_metrology: bool = False) -> dict[str, Any]:
    """The JSON report of ``cam-bench analyze BAG`` as a dict (the same code path).

    Raises ``CliError`` with analyze's one-line message when the bag cannot be
    analysed (not a bag, no samples, bad scene ...)."""
    from cam_metrology.cli import CliError, main

    with tempfile.TemporaryDirectory(prefix='cam_bench_golden_') as tmp:
        out = Path(tmp) / 'report.json'
        argv = ['analyze', str(bag), '--json', str(out)]
        if params is not None:
            argv += ['--params', str(params)]
        if only_metrology:
            argv.append('--only-metrology')
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        if not out.is_file():
            lines = err.getvalue().strip().splitlines()
            message = lines[-1].split(': error: ', 1)[-1] if lines else f'exit code {code}'
            raise CliError(message)
        return json.loads(out.read_text(encoding='utf-8'))


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench golden``: 0 when written, 2 for bad input."""
    from cam_design.errors import InputError
    from cam_metrology.golden import golden_of

    out = Path(args.out)
    if out.exists() and not args.force:
        raise InputError('OUT', args.out, 'a file that does not exist yet (or --force)')
    if out.is_dir():
        raise InputError('OUT', args.out, 'a file name, not a directory')
    if not out.parent.is_dir():
        raise InputError('OUT', args.out, f'a file in an existing directory ({out.parent} '
                         'does not exist)')
    report = golden_of(analyze_report(args.bag, args.params))
    tmp = out.with_name(f'.{out.name}.partial')
    try:
        tmp.write_text(json.dumps(report, indent=1, sort_keys=True) + '\n', encoding='utf-8')
        tmp.replace(out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError('OUT', args.out, f'a writable path ({exc.strerror})') from None
    n = len(report.get('features', {}))
    print(f'cam-bench golden: wrote {out} ({n} features of {args.bag})')
    return 0
