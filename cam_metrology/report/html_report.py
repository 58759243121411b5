"""A self-contained HTML report of an analysed camshaft, and the per-feature CSV.

``html_report(report, tables, scene)`` returns one HTML document: the verdict first,
the cam card (measured beside nominal), the per-feature results with uncertainties in
arc-seconds, one figure per feature (measured vs design lift; lift error with its
tolerance band) embedded as base64 PNG, what was skipped, and the provenance block.
No script, no style sheet or image from the network: the file opens offline.
``csv_rows(report)`` gives the per-feature table of ``analyze --csv``.
"""
from __future__ import annotations

import base64
import io
from typing import Any, Mapping

from cam_metrology.report.form_html import form_html
from cam_metrology.report.html_cells import esc as _e
from cam_metrology.report.html_cells import number as _n
from cam_metrology.report.html_cells import result_class as _cls

__all__ = ['html_report', 'csv_text', 'card_lines', 'CSV_COLUMNS']

CSV_COLUMNS = ('feature', 'kind', 'status', 'verdict', 'angle_deg', 'angle_std_arcsec',
               'phase_deg', 'phase_error_deg', 'lift_error_max_plus_um',
               'lift_error_max_minus_um', 'lift_error_rms_um', 'base_circle_runout_um',
               'max_lift_mm', 'nominal_max_lift_mm', 'duration_cam_deg',
               'nominal_duration_cam_deg', 'checking_height_mm', 'failed_checks')

_STYLE = """
body{font-family:sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1.2em}
td,th{border:1px solid #bbb;padding:2px 8px;text-align:right;white-space:nowrap}
th{background:#eee} td.l,th.l{text-align:left}
.pass{background:#c8f0c8}.fail{background:#f6b8b8}.nc{background:#f3e6a8}
.verdict{font-size:1.6em;font-weight:bold;padding:0.4em 0.8em;display:inline-block}
img{max-width:100%;border:1px solid #ddd}
"""


def _unit(unit: str) -> str:
    return 'µm' if unit == 'um' else unit


def _png(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=90, bbox_inches='tight')
    return 'data:image/png;base64,' + base64.b64encode(buf.getvalue()).decode('ascii')


def feature_figure(fid: str, table: Any, feature: Mapping[str, Any]) -> Any:
    """The lift figure of ``analyze --plot`` (``plots.lift_figure``: tolerance band and
    zones on the lift-error axis). For a lobe, ``table`` is the base-referenced table
    the verdict uses."""
    from cam_metrology.report.plots import lift_figure

    return lift_figure(fid, table, dict(feature))


def _verdict_html(report: Mapping[str, Any]) -> str:
    v = report.get('verdict') or {'result': 'not checked', 'failed': [], 'not_checked': []}
    word = {'pass': 'PASS: part accepted', 'fail': 'FAIL: part rejected'}.get(
        v.get('result'), 'NOT CHECKED')
    out = [f'<div class="verdict {_cls(v.get("result"))}" id="verdict">{_e(word)}</div>',
           f'<p>{_e(v.get("checks", 0))} checks against the scene tolerances.</p>']
    rows = []
    for fid, f in (report.get('features') or {}).items():
        for c in (f.get('verdict') or {}).get('checks', []):
            lo = '-' if c['lower'] is None else f"{c['lower']:g}"
            rows.append(f'<tr class="{_cls(c["result"])}"><td class="l">{_e(fid)}</td>'
                        f'<td class="l">{_e(c["quantity"])}</td><td>{c["value"]:.4g}</td>'
                        f'<td>{lo}</td><td>{c["upper"]:g}</td><td class="l">{_e(_unit(c["unit"]))}'
                        f'</td><td class="l">{_e(c["result"])}'
                        f'{" (within 2 std of a limit)" if c.get("uncertain") else ""}'
                        '</td></tr>')
    if rows:
        out.append('<table><tr><th class="l">feature</th><th class="l">quantity</th>'
                   '<th>value</th><th>lower</th><th>upper</th><th class="l">unit</th>'
                   '<th class="l">result</th></tr>' + ''.join(rows) + '</table>')
    gaps = [m for m in v.get('not_checked') or []]
    if gaps:
        out.append('<ul>' + ''.join(
            f'<li>not checked: {_e(m.get("why"))}</li>' if m.get('feature') == '*' else
            f'<li>not checked: {_e(m.get("feature"))} {_e(m.get("quantity"))}: '
            f'{_e(m.get("why"))}</li>' for m in gaps) + '</ul>')
    return '\n'.join(out)


def _card_html(report: Mapping[str, Any]) -> str:
    rows = []
    for fid, f in (report.get('features') or {}).items():
        card = f.get('cam_card')
        if not card:
            continue
        if 'error' in card:
            rows.append(f'<tr><td class="l">{_e(fid)}</td><td class="l" colspan="8">'
                        f'{_e(card["error"])}</td></tr>')
            continue
        m, n = card['measured'], card['nominal']
        for em, en in zip(m['heights'], n['heights']):
            rows.append(
                f'<tr><td class="l">{_e(fid)}</td><td>{em["height_mm"]:.3f}</td>'
                f'<td>{em["opening_deg"]:.3f} / {en["opening_deg"]:.3f}</td>'
                f'<td>{em["closing_deg"]:.3f} / {en["closing_deg"]:.3f}</td>'
                f'<td>{em["duration_cam_deg"]:.3f} / {en["duration_cam_deg"]:.3f}</td>'
                f'<td>{em["duration_crank_deg"]:.2f} / {en["duration_crank_deg"]:.2f}</td>'
                f'<td>{em["centreline_deg"]:.4f}</td>'
                f'<td>{m["max_lift_mm"]:.4f} / {n["max_lift_mm"]:.4f}</td>'
                f'<td>{_n(m.get("area_mm_deg"), ".2f")} / {_n(n.get("area_mm_deg"), ".2f")}'
                '</td></tr>')
    if not rows:
        return '<p>No cam card (no measured lobe).</p>'
    return ('<p>measured / nominal, both as seen by the probe; cam degrees from the '
            'fitted nose (rise negative), crank = 2 x cam.</p><table><tr>'
            '<th class="l">lobe</th><th>height mm</th><th>opens deg</th><th>closes deg</th>'
            '<th>duration cam deg</th><th>duration crank deg</th><th>centreline deg</th>'
            '<th>max lift mm</th><th>area mm deg</th></tr>' + ''.join(rows) + '</table>')


def _crank_html(report: Mapping[str, Any]) -> str:
    """Valve events in crank degrees and the lobe separations (scene crank datum)."""
    crank = report.get('crank') or {}
    if not crank:
        return ''
    rows = []
    for fid, f in (report.get('features') or {}).items():
        card = f.get('cam_card') or {}
        cm = (card.get('measured') or {}).get('crank')
        cn = (card.get('nominal') or {}).get('crank')
        if not cm or not cn:
            continue
        side = 'ATDC' if cm['role'] == 'intake' else 'BTDC'
        for em, en in zip(cm['events'], cn['events']):
            ev = ', '.join(f'{k.split("_")[0]} {em[k]:.2f} / {en[k]:.2f} '
                           f'{k.split("_")[1].upper()}' for k in em if k != 'height_m')
            rows.append(f'<tr><td class="l">{_e(fid)}</td><td class="l">{_e(cm["role"])} '
                        f'(cyl {_e(cm.get("cylinder"))})</td>'
                        f'<td>{cm["centreline_crank_deg"]:.2f} / '
                        f'{cn["centreline_crank_deg"]:.2f} {side}</td>'
                        f'<td>{em["height_m"] * 1e3:.3f}</td><td class="l">{_e(ev)}</td></tr>')
    pairs = ''.join(
        f'<li>cylinder {_e(p["cylinder"])} {_e(p["intake"])}/{_e(p["exhaust"])}: lobe '
        f'separation {p["lobe_separation_deg"]:.3f} cam deg measured'
        + ''.join(f' / {q["lobe_separation_deg"]:.3f} nominal'
                  for q in (crank.get('nominal') or {}).get('pairs', [])
                  if q['intake'] == p['intake'] and q['exhaust'] == p['exhaust'])
        + '</li>' for p in (crank.get('measured') or {}).get('pairs', []))
    return (f'<h3>Crank timing</h3><p>Cylinder 1 TDC {crank.get("tdc_deg"):g} cam deg from '
            'the datum; measured / nominal, crank degrees (four-stroke: crank = 2 x cam).</p>'
            '<table><tr><th class="l">lobe</th><th class="l">role</th><th>centreline</th>'
            '<th>height mm</th><th class="l">events</th></tr>' + ''.join(rows) + '</table>'
            + (f'<ul>{pairs}</ul>' if pairs else ''))


def _results_html(report: Mapping[str, Any]) -> str:
    rows = []
    for fid, f in (report.get('features') or {}).items():
        std = f.get('angle_std_deg')
        err = f.get('lift_error_um') or {}
        status = f.get('status', '')
        if f.get('reason'):
            status += ': ' + f['reason']
        rows.append(f'<tr><td class="l">{_e(fid)}</td><td>{_n(f.get("angle_deg"), ".5f")}</td>'
                    f'<td>{_n(None if std is None else std * 3600, ".3f")}</td>'
                    f'<td>{_n(f.get("phase_deg"), ".4f")}</td>'
                    f'<td>{_n(f.get("phase_error_deg"), ".4f")}</td>'
                    f'<td>{_n(err.get("max_plus"), ".2f")}</td>'
                    f'<td>{_n(err.get("max_minus"), ".2f")}</td>'
                    f'<td>{_n(err.get("rms"), ".2f")}</td>'
                    f'<td>{_n(f.get("base_circle_runout_um"), ".2f")}</td>'
                    f'<td class="l">{_e(status)}</td></tr>')
    return ('<p>Lift errors are measured minus design with the lift offset taken from '
            'the base circle alone, as the verdict and the plots use them.</p>'
            '<table><tr><th class="l">feature</th><th>angle deg</th><th>std arcsec</th>'
            '<th>phase deg</th><th>phase error deg</th><th>lift error + µm</th>'
            '<th>lift error − µm</th><th>lift error rms µm</th><th>run-out TIR µm</th>'
            '<th class="l">status</th></tr>' + ''.join(rows) + '</table>')


def html_report(report: Mapping[str, Any], tables: Mapping[str, Any],
                profiles: Mapping[str, Any] | None = None,
                designs: Mapping[str, Any] | None = None) -> str:
    """The HTML document (module doc). ``tables``: feature id -> /metrology/lift table;
    ``profiles``: feature id -> (columns, data) of a /reconstruction/profile table (its
    velocity and acceleration are plotted, beside ``designs[id]``'s when given)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    title = f'cam-bench report: {report.get("camshaft_id", "")}'
    parts = ['<!DOCTYPE html>', '<html lang="en"><head><meta charset="utf-8">',
             f'<title>{_e(title)}</title><style>{_STYLE}</style></head><body>',
             f'<h1>{_e(title)}</h1>', '<h2>Verdict</h2>', _verdict_html(report),
             '<h2>Cam card</h2>', _card_html(report), _crank_html(report),
             '<h2>Results</h2>', _results_html(report), form_html(report),
             '<h2>Plots</h2>']
    features = report.get('features') or {}
    for fid, table in tables.items():
        fig = feature_figure(fid, table, features.get(fid) or {})
        try:
            parts.append(f'<h3>{_e(fid)}</h3><img class="plot" alt="{_e(fid)} lift and '
                         f'lift error" src="{_png(fig)}">')
        finally:
            plt.close(fig)
        if profiles and fid in profiles:
            from cam_metrology.report.plots import derivative_figure
            fig = derivative_figure(fid, *profiles[fid], (designs or {}).get(fid))
            try:
                parts.append(f'<img class="plot" alt="{_e(fid)} velocity and acceleration" '
                             f'src="{_png(fig)}">')
            finally:
                plt.close(fig)
    skipped = report.get('skipped') or []
    if skipped:
        parts.append('<h2>Skipped</h2><ul>' + ''.join(
            f'<li>{_e(s.get("what"))}: {_e(s.get("why"))}</li>' for s in skipped) + '</ul>')
    prov = report.get('provenance') or {}
    parts.append('<h2>Provenance</h2><table id="provenance">' + ''.join(
        f'<tr><th class="l">{_e(k)}</th><td class="l">{_e(v)}</td></tr>'
        for k, v in prov.items()) + '</table>')
    parts.append('</body></html>')
    return '\n'.join(parts) + '\n'


def csv_text(report: Mapping[str, Any]) -> str:
    """The per-feature CSV (``CSV_COLUMNS``; empty cells for values not available)."""
    import csv

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator='\n')
    w.writerow(CSV_COLUMNS)
    for fid, f in (report.get('features') or {}).items():
        err = f.get('lift_error_um') or {}
        card = f.get('cam_card') or {}
        m, n = card.get('measured') or {}, card.get('nominal') or {}
        h0m = (m.get('heights') or [{}])[0]
        h0n = (n.get('heights') or [{}])[0]
        std = f.get('angle_std_deg')
        v = f.get('verdict') or {}
        row = [fid, f.get('kind'), f.get('status'), v.get('result'), f.get('angle_deg'),
               None if std is None else std * 3600, f.get('phase_deg'),
               f.get('phase_error_deg'), err.get('max_plus'), err.get('max_minus'),
               err.get('rms'), f.get('base_circle_runout_um'), m.get('max_lift_mm'),
               n.get('max_lift_mm'), h0m.get('duration_cam_deg'), h0n.get('duration_cam_deg'),
               h0m.get('height_mm'), ';'.join(x['quantity'] for x in v.get('failed') or [])]
        w.writerow(['' if x is None else (f'{x:.10g}' if isinstance(x, float) else x)
                    for x in row])
    return buf.getvalue()


def card_lines(report: Mapping[str, Any]) -> list[str]:
    """One line per measured lobe: the cam card at the first checking height, measured /
    nominal (for the human report of ``analyze``)."""
    lines = []
    for fid, f in (report.get('features') or {}).items():
        card = f.get('cam_card')
        if not card:
            continue
        if 'error' in card:
            lines.append(f'card {fid}: not computed: {card["error"]}')
            continue
        m, n = card['measured'], card['nominal']
        em, en = m['heights'][0], n['heights'][0]
        lines.append(f'card {fid:<10} measured/nominal: max lift {m["max_lift_mm"]:.4f}/'
                     f'{n["max_lift_mm"]:.4f} mm; @{em["height_mm"]:g} mm '
                     f'{em["opening_deg"]:.2f}/{en["opening_deg"]:.2f} .. '
                     f'{em["closing_deg"]:.2f}/{en["closing_deg"]:.2f} deg, duration '
                     f'{em["duration_cam_deg"]:.3f}/{en["duration_cam_deg"]:.3f}')
        if m.get('crank') and n.get('crank'):
            cm, cn = m['crank'], n['crank']
            words = [k.split('_')[:2] for k in cm['events'][0] if k != 'height_m']
            ev = ', '.join(f'{w[0]} {cm["events"][0]["_".join(w) + "_deg"]:.2f}/'
                           f'{cn["events"][0]["_".join(w) + "_deg"]:.2f} {w[1].upper()}'
                           for w in words)
            side = 'ATDC' if cm['role'] == 'intake' else 'BTDC'
            lines.append(f'crank {fid:<9} measured/nominal: {cm["role"]} centreline '
                         f'{cm["centreline_crank_deg"]:.2f}/{cn["centreline_crank_deg"]:.2f} '
                         f'{side}; @{em["height_mm"]:g} mm {ev}')
    crank = report.get('crank') or {}
    for pm in (crank.get('measured') or {}).get('pairs', []):
        pn = next((p for p in (crank.get('nominal') or {}).get('pairs', [])
                   if p['intake'] == pm['intake'] and p['exhaust'] == pm['exhaust']), None)
        nominal = '-' if pn is None else f"{pn['lobe_separation_deg']:.3f}"
        lines.append(f"lobe separation {pm['intake']}/{pm['exhaust']} (cylinder "
                     f"{pm['cylinder']}) measured/nominal: {pm['lobe_separation_deg']:.3f}/"
                     f'{nominal} cam deg')
    return lines
