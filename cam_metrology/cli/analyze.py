"""`cam-bench analyze BAG`: replay a bag through the node cores, no ROS graph needed.

The bag goes through the same cores as the live nodes (metrology, plus the
reconstruction and dynamics cores when they exist in this tree), so live and
offline results come from one code path. Prints a human report, or writes the JSON
report of docs/contract.md (``--json FILE`` or ``-`` for stdout); ``--plot DIR`` writes
PNGs of measured vs design lift and the lift error per feature; ``--out-bag DIR``
writes a copy of the bag plus every output the cores produced.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from cam_metrology.offline.analyze import (add_cards_and_provenance, analyze_bag,  # noqa: F401
                                           bag_warnings, load_params)
from cam_metrology.report.plots import lift_figure
from cam_metrology.wire.topics import JOINT_STATES as JOINT_TOPIC
from cam_metrology.wire.topics import METROLOGY_LIFT as LIFT_TOPIC


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``analyze`` subcommand."""
    p = subparsers.add_parser(
        'analyze', help='replay a bag through the node cores and print the report',
        description='Replay a rosbag2 (MCAP) bag in-process through the same node cores as '
                    'the live nodes and print (or write) the metrology report.')
    p.add_argument('bag', metavar='BAG', help='rosbag2 directory (metadata.yaml + MCAP)')
    p.add_argument('--params', metavar='FILE', help='ROS parameter YAML for the cores '
                   '(node_name: ros__parameters: ...)')
    p.add_argument('--json', metavar='FILE|-',
                   help='write the JSON report instead of the human report '
                   '(- for standard output)')
    p.add_argument('--plot', metavar='DIR', help='write lift and lift-error PNGs per feature')
    p.add_argument('--out-bag', metavar='DIR', help='write the bag plus all outputs to DIR')
    p.add_argument('--report', metavar='FILE.html', help='write a self-contained HTML report '
                   '(verdict, cam card, results, plots, provenance)')
    p.add_argument('--csv', metavar='FILE|-', help='write the per-feature results as CSV (- for '
                   'standard output)')
    p.add_argument('--dfq', metavar='FILE.dfq', help='write the results as a Q-DAS AQDEF '
                   'transfer file (one characteristic per reported quantity, with the '
                   "scene tolerances' limits) for SPC packages")
    p.add_argument('--only-metrology', action='store_true',
                   help='run only the metrology core')
    p.add_argument('--heights-mm', metavar='LIST', default=None,
                   help='cam-card checking heights [mm], comma-separated (default 1,1.27,0.1)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench analyze``: 0 when features were measured, 2 for bad input
    (checked before the replay), 1 when the bag gave nothing to measure."""
    from cam_design.errors import InputError

    if not Path(args.bag).exists():
        raise InputError('bag', args.bag, 'an existing rosbag2 directory')
    if args.out_bag and Path(args.out_bag).exists():
        raise InputError('--out-bag', args.out_bag, 'a path that does not exist yet')
    from cam_metrology.cli.card import heights_from

    if args.out_bag:   # written during the replay: complete or not there at all
        from cam_metrology.inputs.files import atomic_dir
        with atomic_dir(args.out_bag, '--out-bag') as tmp:
            run_ = analyze_bag(args.bag, args.params, only_metrology=args.only_metrology,
                               heights=heights_from(args), out_bag=str(tmp),
                               plot_tables=bool(args.report or args.plot))
    else:
        run_ = analyze_bag(args.bag, args.params, only_metrology=args.only_metrology,
                           heights=heights_from(args),
                           plot_tables=bool(args.report or args.plot))
    report, outputs, metrology, tables = (run_.report, run_.outputs, run_.metrology,
                                          run_.tables)
    for line in run_.warnings:
        print(f'cam-bench analyze: warning: {line}', file=sys.stderr)
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, report, '--json')
    else:
        print(human_report(report))
        for line in core_summaries(outputs):
            print(line)
    if args.plot:
        write_plots(outputs, Path(args.plot), report, tables)
    if args.report:
        from cam_metrology.inputs.files import write_output
        from cam_metrology.report.html_report import html_report
        write_output(args.report, html_report(report, tables, profiles(outputs),
                                              getattr(metrology, '_design', {})), '--report')
    if args.csv:
        from cam_metrology.inputs.files import write_output
        from cam_metrology.report.html_report import csv_text
        write_output(args.csv, csv_text(report), '--csv')
    if args.dfq:
        write_report_dfq(args.dfq, args.bag, report)
    if not any(f.get('status') == 'ok' for f in report.get('features', {}).values()):
        print(f'cam-bench analyze: error: nothing was measured in {args.bag}: no feature '
              f'of the scene was measured from its {JOINT_TOPIC} samples (see the '
              'report)', file=sys.stderr)
        return 1
    return verdict_exit_code(report)


def write_report_dfq(path: str, bag: str, report: dict[str, Any]) -> None:
    """``--dfq``: the report as a Q-DAS DFQ file (the rows ``batch`` tabulates)."""
    from cam_metrology.offline.batch import bag_start_ns, rows_of_report
    from cam_metrology.quality.qdas import write_dfq

    sha = str((report.get('provenance') or {}).get('bag_sha256') or '')
    write_dfq(path, rows_of_report(bag, sha, report, bag_start_ns(Path(bag))))


def profiles(outputs: list[tuple[int, Any]]) -> dict[str, tuple[Any, Any]]:
    """feature id -> (columns, data) of its first /reconstruction/profile table as seen
    by the probe (label ``<id>/<method>/probe`` when the design follower differs from
    the probe, else ``<id>/<method>``): the velocity and acceleration of the HTML
    report, drawn beside the design as seen by the probe."""
    from cam_metrology.cores.outputs import TableOutput

    probe: dict[str, tuple[Any, Any]] = {}
    plain: dict[str, tuple[Any, Any]] = {}
    for _, o in outputs:
        if isinstance(o, TableOutput) and o.topic == '/reconstruction/profile':
            parts = o.label.split('/')
            target = probe if parts[-1] == 'probe' and len(parts) == 3 else plain
            target.setdefault(parts[0], (o.columns, o.data))
    return {**plain, **probe}


def core_summaries(outputs: list[tuple[int, Any]]) -> list[str]:
    """One line per other core (reconstruction, dynamics): each result's name and level
    (with its message when not OK), so what ``analyze`` computed is shown, not hidden."""
    from cam_metrology.cores.outputs import StatusOutput

    levels = {0: 'OK', 1: 'WARN', 2: 'ERROR'}
    found: dict[str, list[str]] = {}
    for _, o in outputs:
        if not isinstance(o, StatusOutput) or not o.topic.endswith('/result') \
                or o.topic.startswith('/metrology/'):
            continue
        core = o.topic.split('/')[1]
        for st in o.statuses:
            if st.name.startswith('skipped/'):
                continue
            level = levels.get(int(st.level), str(st.level))
            why = st.message if len(st.message) <= 60 else st.message[:57] + '...'
            found.setdefault(core, []).append(
                f'{st.name} {level}' + ('' if level == 'OK' else f' ({why})'))
    return [f'{core}: ' + ', '.join(items) + ' (all of it: --json)'
            for core, items in found.items()]


#: exit status of analyze for a part rejected against its tolerances (docs/contract.md)
EXIT_REJECTED = 3


def verdict_exit_code(report: dict[str, Any]) -> int:
    """3 for a rejected part, 1 when the scene has tolerances that could not all be
    checked (never a silent 0), else 0; the reason goes to stderr."""
    verdict = report.get('verdict') or {}
    if verdict.get('result') == 'fail':
        failed = verdict.get('failed') or []
        first = failed[0] if failed else {}
        print(f"cam-bench analyze: part rejected: {len(failed)} check(s) out of tolerance"
              + (f" (first: {first.get('feature')} {first.get('quantity')} = "
                 f"{first.get('value'):.4g} {first.get('unit')}, limit {first.get('limit'):g})"
                 if first else ''), file=sys.stderr)
        return EXIT_REJECTED
    if verdict.get('result') == 'not checked' and verdict.get('checks', 0) + len(
            [m for m in verdict.get('not_checked') or [] if m.get('feature') != '*']) > 0:
        print('cam-bench analyze: verdict not checked: some toleranced quantities could not '
              'be evaluated (see the report)', file=sys.stderr)
        return 1
    return 0


def _fmt(value: Any, spec: str) -> str:
    """``value`` formatted with ``spec``; a right-aligned '-' of the same width if None."""
    width = int(spec.split('.')[0] or 0)
    return '-'.rjust(width) if value is None else format(value, spec)


def human_report(report: dict[str, Any]) -> str:
    """A fixed-width text report of the JSON report."""
    lines = [f"camshaft {report.get('camshaft_id', '')}  direction "
             f"{report.get('direction', '')}"]
    head = (f"{'feature':<12}{'angle deg':>13}{'std arcsec':>11}{'SP - LSQ as':>12}"
            f"{'phase deg':>11}{'phase err':>11}{'asym deg':>10}{'lift rms µm':>12}  status")
    lines += [head, '-' * len(head)]
    for fid, f in report.get('features', {}).items():
        std = None if f.get('angle_std_deg') is None else f['angle_std_deg'] * 3600
        dsp = f.get('sensitive_point_minus_lsq_deg')
        dsp = None if dsp is None else dsp * 3600
        rms = (f.get('lift_error_um') or {}).get('rms')
        status = f.get('status', '')
        if status == 'failed':
            status += ': ' + f.get('reason', '')
        elif not (f.get('validity') or {}).get('valid', True):
            status += ' (sensitive-point validity check failed)'
        lines.append(f"{fid:<12}{_fmt(f.get('angle_deg'), '13.5f')}{_fmt(std, '11.3f')}"
                     f"{_fmt(dsp, '12.3f')}{_fmt(f.get('phase_deg'), '11.4f')}"
                     f"{_fmt(f.get('phase_error_deg'), '11.4f')}"
                     f"{_fmt(f.get('asymmetry_deg'), '10.5f')}{_fmt(rms, '12.3f')}  {status}")
    lines += form_lines(report)
    for item in report.get('skipped', []):
        lines.append(f"skipped {item['what']}: {item['why']}")
    from cam_metrology.report.html_report import card_lines
    from cam_metrology.metrology.tolerances import verdict_lines
    return '\n'.join(verdict_lines(report) + lines + card_lines(report))


def form_lines(report: dict[str, Any]) -> list[str]:
    """One line per feature with form results (roundness, waviness, journal diameter and
    run-out), then the shaft's straightness and each tracked lobe's taper and twist."""
    lines = []
    for fid, f in report.get('features', {}).items():
        wav = f.get('waviness') or {}
        parts = []
        if f.get('kind') == 'journal':
            d = f.get('diameter_deviation_um')
            parts.append('diameter ' + ('-' if d is None else f'{d:+.2f} µm') +
                         f", run-out {f['runout_um']:.2f} µm")
        if f.get('roundness_um') is not None:
            parts.append(f"roundness {f['roundness_um']:.3f} µm")
        if wav.get('upr_at_max') is not None:
            parts.append(f"waviness {wav['max_amplitude_um']:.3f} µm at {wav['upr_at_max']} "
                         f"UPR ({wav['band_upr'][0]}-{wav['band_upr'][1]}), near "
                         f"{wav['at_deg']:.1f} deg")
        if parts:
            lines.append(f'form {fid}: ' + ', '.join(parts))
    shaft = report.get('shaft') or {}
    if shaft.get('straightness_um') is not None:
        lines.append(f"shaft straightness {shaft['straightness_um']:.2f} µm (bow "
                     f"{shaft['bow_um']:.2f} µm at {shaft['bow_at_mm']:g} mm towards "
                     f"{shaft['bow_direction_deg']:.1f} deg, from "
                     f"{len(shaft.get('from') or [])} centres)")
    elif shaft:
        lines.append(f"shaft straightness not computed: {shaft.get('why', '')}")
    for note in shaft.get('left_out') or []:
        lines.append(f"shaft straightness leaves out {note['feature']}: {note['why']}")
    for lobe, tr in (report.get('lobe_tracks') or {}).items():
        if 'twist_deg_per_mm' in tr:
            taper = tr.get('taper_um_per_mm')
            lines.append(f"tracks {lobe}: taper " + ('-' if taper is None else
                                                     f'{taper:.3f} µm/mm') +
                         f", twist {tr['twist_deg_per_mm'] * 3600:.2f} arcsec/mm over "
                         f"{len(tr['tracks'])} tracks")
    return lines


def write_plots(outputs: list[tuple[int, Any]], folder: Path, report: dict[str, Any],
                tables: dict[str, Any]) -> None:
    """One PNG per lift table: measured and design lift, and the lift error [um]. A lobe's
    table is the one the analysis referenced to the base circle for its verdict, cards and
    HTML report (``tables``, feature id -> table), not referenced again here."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from cam_metrology.cores.outputs import TableOutput
    from cam_metrology.inputs.files import output_dir, safe_name, save_figure

    folder = output_dir(folder, '--plot')
    for _, o in outputs:
        if not (isinstance(o, TableOutput) and o.topic == LIFT_TOPIC):
            continue
        feature = report.get('features', {}).get(o.label) or {}
        fig = lift_figure(o.label, tables.get(o.label, o.data), feature)
        try:
            save_figure(fig, folder / f'{safe_name(o.label)}.png', '--plot', dpi=110,
                        bbox_inches='tight')
        finally:
            plt.close(fig)


if __name__ == '__main__':   # pragma: no cover
    from cam_metrology.cli import main
    sys.exit(main(['analyze'] + sys.argv[1:]))
