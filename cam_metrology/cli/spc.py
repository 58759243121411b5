"""`cam-bench spc RESULTS.parquet`: control charts, capability and gauge R&R of a batch.

Reads the table of ``cam-bench batch`` (Parquet or CSV). For every feature and every
quantity asked for (default: angle_deg, phase_error_deg), in the order the parts were
measured (bag start time, then bag name): the individuals and moving-range chart, the
run rules that fire, and with ``--tolerance QUANTITY=LSL:USL`` Cp, Cpk, Pp and Ppk.
``--grr`` runs a gauge R&R study (ANOVA method) instead; the table then needs the
columns ``part_id``, ``operator`` and ``trial`` (one row per measurement); with a
``--tolerance`` (or the scene's limits) it is also reported against the tolerance (%Tol)
with the acceptance bands. ``--type1 QUANTITY=REFERENCE`` runs a type-1 gauge study (Cg,
Cgk, bias and its t-test) of every feature's repeated measurements of one reference part
against its ``--tolerance``.
``--report FILE.html`` writes one self-contained page with the charts inline.
"""
from __future__ import annotations

import argparse
import base64
import html
import io
import json
import math
from pathlib import Path
from typing import Any


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``spc`` subcommand."""
    p = subparsers.add_parser(
        'spc', help='control charts, capability (Cpk) and gauge R&R of a batch table',
        description='SPC over the results table of `cam-bench batch`: individuals / '
                    'moving-range charts per feature and quantity in measurement order, '
                    'Western Electric run rules, Cp/Cpk/Pp/Ppk against --tolerance, or a '
                    'gauge R&R study (--grr, ANOVA method).')
    p.add_argument('table', metavar='TABLE',
                   help='results table (.parquet or .csv) of cam-bench batch')
    p.add_argument('--json', metavar='FILE|-',
                   help='write the results as JSON (- for standard output)')
    p.add_argument('--report', metavar='FILE.html', help='self-contained HTML report')
    p.add_argument('--quantity', action='append', metavar='NAME', help='column to chart '
                   '(repeatable; default angle_deg and phase_error_deg)')
    p.add_argument('--feature', action='append', metavar='ID', help='only these features')
    p.add_argument('--tolerance', action='append', default=[], metavar='NAME=LSL:USL',
                   help='specification limits of a quantity (either side may be empty); '
                        'default: the limits the scene tolerances gave the verdict')
    p.add_argument('--grr', action='store_true', help='gauge R&R study (needs part_id, '
                   'operator, trial columns)')
    p.add_argument('--type1', action='append', default=[], metavar='NAME=REFERENCE',
                   help='type-1 gauge study of QUANTITY against its reference value (the '
                        'rows: repeated measurements of one reference part; needs '
                        '--tolerance or scene limits for the quantity); repeatable')
    return p


def load_rows(path: str) -> list[dict[str, Any]]:
    """Rows of a Parquet or CSV table."""
    from cam_design.errors import InputError

    p = Path(path)
    if not p.is_file():
        raise InputError('table', path, 'an existing .parquet or .csv file')
    try:
        if p.suffix == '.csv':
            import pyarrow.csv as pacsv
            table = pacsv.read_csv(p)
        else:
            import pyarrow.parquet as pq
            table = pq.read_table(p)
    except Exception as exc:  # noqa: BLE001 -- any reader error: one line
        raise InputError('table', path, f'a results table of cam-bench batch ({exc})') \
            from None
    missing = [c for c in ('bag', 'feature', 'status') if c not in table.column_names]
    if missing:
        raise InputError('table', path, 'a results table of cam-bench batch (columns bag, '
                         'feature, status and the report fields); this one has columns '
                         + ', '.join(table.column_names[:6]) + ' and no ' + ', '.join(missing))
    return table.to_pylist()


def _tolerances(items: list[str]) -> dict[str, tuple[float | None, float | None]]:
    from cam_design.errors import InputError

    out = {}
    for item in items:
        name, _, rng = item.partition('=')
        lo, sep, hi = rng.partition(':')
        try:
            lsl = float(lo) if lo.strip() else None
            usl = float(hi) if hi.strip() else None
        except ValueError:
            lsl = usl = math.nan
        if not name or not sep or (lsl is None and usl is None) or (
                lsl is not None and not math.isfinite(lsl)) or (
                usl is not None and not math.isfinite(usl)):
            raise InputError('--tolerance', item, 'NAME=LSL:USL with numbers (one side may '
                             'be empty), e.g. phase_error_deg=-0.05:0.05')
        out[name] = (lsl, usl)
    return out


def scene_limits(rows: list[dict[str, Any]], quantity: str
                 ) -> tuple[float | None, float | None] | None:
    """The specification limits of ``quantity`` that the scene's tolerances gave the
    verdict (``verdict.checks`` of the latest row that checked it), or None."""
    for r in reversed(_ordered(rows)):
        raw = r.get('verdict.checks')
        try:
            checks = json.loads(raw) if isinstance(raw, str) else (raw or [])
        except ValueError:
            continue
        for c in checks:
            if isinstance(c, dict) and c.get('quantity') == quantity and (
                    c.get('lower') is not None or c.get('upper') is not None):
                return c.get('lower'), c.get('upper')
    return None


def _ordered(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(rows, key=lambda r: (r.get('bag_start_utc_ns') or 0, str(r.get('bag'))))


def spc_results(rows: list[dict[str, Any]], quantities: list[str], features: list[str] | None,
                tolerances: dict[str, tuple[float | None, float | None]]) -> list[dict[str, Any]]:
    """One entry per feature x quantity: chart, rule violations, capability."""
    from cam_design.errors import InputError
    from cam_metrology.quality.spc import capability, individuals

    ok = [r for r in rows if r.get('status') == 'ok']
    if not ok:
        raise InputError('table', len(rows), 'rows with status ok')
    for q in quantities:
        if not any(q in r for r in ok):
            raise InputError('--quantity', q, 'a column of the table, e.g. angle_deg')
    out = []
    for fid in sorted({r['feature'] for r in ok}):
        if features and fid not in features:
            continue
        frs = _ordered([r for r in ok if r['feature'] == fid])
        for q in quantities:
            vals = [(r['bag'], v) for r in frs if (v := r.get(q)) is not None]
            entry: dict[str, Any] = {'feature': fid, 'quantity': q, 'n': len(vals),
                                     'bags': [b for b, _ in vals],
                                     'values': [float(v) for _, v in vals]}
            if len(vals) >= 3:
                chart = individuals(entry['values'], key=f'{fid}.{q}')
                entry['chart'] = chart.as_dict()
                limits = tolerances.get(q)
                entry['tolerance_source'] = '--tolerance'
                if limits is None:
                    limits = scene_limits(frs, q)
                    entry['tolerance_source'] = 'scene (the verdict\'s limits)'
                if limits is not None:
                    lsl, usl = limits
                    entry['capability'] = capability(entry['values'], lsl, usl,
                                                     sigma_within=chart.sigma_within).as_dict()
                    entry['tolerance'] = [lsl, usl]
                else:
                    del entry['tolerance_source']
            else:
                entry['note'] = 'fewer than 3 parts: no chart'
            out.append(entry)
    return out


def _tolerance_width(rows: list[dict[str, Any]], quantity: str,
                     tolerances: dict[str, tuple[float | None, float | None]]
                     ) -> float | None:
    """USL - LSL of ``quantity`` (``--tolerance`` first, else the scene's limits); None
    when either side is missing."""
    lsl, usl = tolerances.get(quantity) or scene_limits(rows, quantity) or (None, None)
    return None if lsl is None or usl is None else float(usl) - float(lsl)


def type1_results(rows: list[dict[str, Any]], items: list[str], features: list[str] | None,
                  tolerances: dict[str, tuple[float | None, float | None]]
                  ) -> list[dict[str, Any]]:
    """Type-1 gauge study per feature for each ``QUANTITY=REFERENCE`` of ``items``."""
    from cam_design.errors import InputError
    from cam_metrology.quality.gauge_type1 import type1_study

    out = []
    ok = [r for r in rows if r.get('status') == 'ok']
    for item in items:
        name, _, ref = item.partition('=')
        try:
            reference = float(ref)
        except ValueError:
            raise InputError('--type1', item, 'QUANTITY=REFERENCE with a number, e.g. '
                             'angle_deg=36.7756') from None
        width = _tolerance_width(rows, name, tolerances)
        if width is None:
            raise InputError('--type1', item, f'a tolerance of {name}: --tolerance '
                             f'{name}=LSL:USL (or a scene tolerance in the table)')
        for fid in sorted({r['feature'] for r in ok}):
            if features and fid not in features:
                continue
            values = [float(r[name]) for r in _ordered(ok)
                      if r['feature'] == fid and r.get(name) is not None]
            study = type1_study(values, reference, width, key=f'--type1 {fid}.{name}')
            out.append({'feature': fid, 'quantity': name, **study.as_dict()})
    return out


def grr_results(rows: list[dict[str, Any]], quantities: list[str],
                features: list[str] | None,
                tolerances: dict[str, tuple[float | None, float | None]] | None = None,
                ) -> list[dict[str, Any]]:
    """Gauge R&R per feature x quantity from part_id / operator / trial columns (and
    against the quantity's tolerance when one is known)."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_metrology.quality.gauge_rr import gauge_rr

    ok = [r for r in rows if r.get('status') == 'ok']
    missing = [c for c in ('part_id', 'operator', 'trial')
               if not ok or any(r.get(c) in (None, '') for r in ok)]
    if missing:
        raise InputError('--grr', ', '.join(missing), 'columns part_id, operator and trial '
                         'filled in every row (scene keys of the same names, or added to '
                         'the table; one row per measurement)')
    out = []
    for fid in sorted({r['feature'] for r in ok}):
        if features and fid not in features:
            continue
        frs = [r for r in ok if r['feature'] == fid]
        parts = sorted({str(r['part_id']) for r in frs})
        ops = sorted({str(r['operator']) for r in frs})
        trials = sorted({str(r['trial']) for r in frs})
        for q in quantities:
            y = np.full((len(parts), len(ops), len(trials)), np.nan)
            for r in frs:
                y[parts.index(str(r['part_id'])), ops.index(str(r['operator'])),
                  trials.index(str(r['trial']))] = float(r[q])
            if np.isnan(y).any():
                raise InputError('--grr', f'{fid}.{q}', 'a complete study: every part '
                                 'measured by every operator in every trial')
            width = _tolerance_width(rows, q, tolerances or {})
            out.append({'feature': fid, 'quantity': q, 'parts': len(parts),
                        'operators': len(ops), 'trials': len(trials),
                        **gauge_rr(y).as_dict(width)})
    return out


def _chart_png(entry: dict[str, Any]) -> str:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    c = entry['chart']
    x = list(range(1, entry['n'] + 1))
    fig, ax = plt.subplots(figsize=(9, 3.2))
    ax.plot(x, entry['values'], 'o-', ms=3, label='part')
    ax.axhline(c['centre'], color='k', lw=0.8, label='centre')
    ax.axhline(c['ucl'], color='k', ls='--', lw=0.8, label='control limits (3 sigma)')
    ax.axhline(c['lcl'], color='k', ls='--', lw=0.8)
    for i, lim in enumerate(entry.get('tolerance', [])):
        if lim is not None:
            ax.axhline(lim, color='r', lw=1.0, label='tolerance' if i == 0 or
                       entry['tolerance'][0] is None else None)
    bad = sorted({v['index'] for v in c['violations']})
    ax.plot([x[i] for i in bad], [entry['values'][i] for i in bad], 'rs', ms=6, mfc='none')
    ax.set_xlabel('part (measurement order)')
    ax.set_ylabel(entry['quantity'])
    ax.set_title(f"{entry['feature']}: {entry['quantity']}")
    ax.legend(loc='center left', bbox_to_anchor=(1.0, 0.5), fontsize=8, frameon=False)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=90)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def write_report(path: Path, table: str, spc: list[dict[str, Any]],
                 grr: list[dict[str, Any]]) -> None:
    """One self-contained HTML page (charts as inline PNG)."""
    parts = [f'<!doctype html><html><head><meta charset="utf-8"><title>SPC {html.escape(table)}'
             '</title><style>body{font-family:sans-serif;margin:2em}td,th{padding:2px 8px;'
             'text-align:right}table{border-collapse:collapse}tr:nth-child(even){background:'
             '#f3f3f3}</style></head><body>', f'<h1>SPC of {html.escape(table)}</h1>']
    if spc:
        parts.append('<table><tr><th>feature</th><th>quantity</th><th>n</th><th>centre</th>'
                     '<th>LCL</th><th>UCL</th><th>rules fired</th><th>Cpk</th><th>Ppk</th></tr>')
        for e in spc:
            c, cap = e.get('chart', {}), e.get('capability', {})

            def f(v: Any) -> str:
                return '' if v is None else f'{v:.6g}'
            parts.append(f"<tr><td>{html.escape(e['feature'])}</td><td>{e['quantity']}</td>"
                         f"<td>{e['n']}</td><td>{f(c.get('centre'))}</td><td>{f(c.get('lcl'))}"
                         f"</td><td>{f(c.get('ucl'))}</td><td>{len(c.get('violations', []))}"
                         f"</td><td>{f(cap.get('cpk'))}</td><td>{f(cap.get('ppk'))}</td></tr>")
        parts.append('</table>')
        for e in spc:
            if 'chart' in e:
                parts.append(f'<p><img alt="{html.escape(e["feature"])} {e["quantity"]}" '
                             f'src="data:image/png;base64,{_chart_png(e)}"></p>')
    for g in grr:
        parts.append(f"<h2>Gauge R&amp;R: {html.escape(g['feature'])} {g['quantity']}</h2>"
                     f"<p>%GRR {g['percent_grr']:.2f} %, ndc {g['ndc']}, {g['parts']} parts x "
                     f"{g['operators']} operators x {g['trials']} trials</p>")
    parts.append('</body></html>')
    from cam_metrology.inputs.files import write_output
    write_output(path, '\n'.join(parts), '--report')


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench spc``."""
    rows = load_rows(args.table)
    quantities = args.quantity or ['angle_deg', 'phase_error_deg']
    if not args.quantity:
        quantities = [q for q in quantities if any(q in r and r[q] is not None for r in rows)]
    tol = _tolerances(args.tolerance)
    spc = [] if args.grr else spc_results(rows, quantities, args.feature, tol)
    grr = grr_results(rows, quantities, args.feature, tol) if args.grr else []
    type1 = type1_results(rows, args.type1, args.feature, tol)
    if type1:
        spc = []
    doc = {'table': args.table, 'spc': spc, 'gauge_rr': grr, 'type1': type1}
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, doc, '--json')
    else:
        for e in spc:
            c = e.get('chart')
            line = f"{e['feature']:<12}{e['quantity']:<18} n={e['n']:<4}"
            if c:
                line += (f" centre {c['centre']:.6g}  limits [{c['lcl']:.6g}, {c['ucl']:.6g}]"
                         f"  rules fired {len(c['violations'])}")
            if 'capability' in e:
                line += f"  Cpk {e['capability']['cpk']:.3f}  Ppk {e['capability']['ppk']:.3f}"
            if e.get('note'):
                line += f"  ({e['note']})"
            print(line)
        for g in grr:
            line = (f"{g['feature']:<12}{g['quantity']:<18} %GRR {g['percent_grr']:.2f} % "
                    f"({g['acceptance']['percent_grr']})  ndc {g['ndc']}")
            if 'percent_tolerance' in g:
                line += (f"  %Tol {g['percent_tolerance']['grr']:.2f} % "
                         f"({g['acceptance']['percent_tolerance']})")
            print(line)
        for t in type1:
            print(f"{t['feature']:<12}{t['quantity']:<18} type 1: Cg {t['cg']:.2f}  Cgk "
                  f"{t['cgk']:.2f}  bias {t['bias']:.6g} (p {t['bias_p_value']:.3f}"
                  f"{', significant' if t['bias_significant'] else ''})  "
                  f"{'capable' if t['capable'] else 'NOT capable'}")
    if args.report:
        write_report(Path(args.report), args.table, spc, grr)
        print(f'cam-bench spc: wrote {args.report}')
    return 0
