"""Overlay and residual plots of rig runs (one figure per speed), the HTML report and the
human summary lines of a rig result."""
from __future__ import annotations

import base64
import html
import io
import json
from typing import Any, Mapping, Sequence

import numpy as np


def run_figure(curve: Mapping[str, Any]) -> Any:
    """Figure of one run: measured cycle average with its cycle-to-cycle scatter, the
    nominal (and calibrated) prediction over the lobe; the residual below."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (ax, rx) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True,
                                 gridspec_kw={'height_ratios': [2, 1]})
    nom = curve['nominal']
    a, m = nom['alpha_deg'], nom['measured_m'] * 1e3
    sc = np.nan_to_num(nom['scatter_m']) * 1e3
    on = np.nonzero(m > 0.01 * np.nanmax(m))[0]
    lo, hi = (a[on[0]] - 20, a[on[-1]] + 40) if on.size else (-180, 180)
    ax.fill_between(a, m - 2 * sc, m + 2 * sc, color='0.8', label='measured ±2 scatter')
    ax.plot(a, m, 'k-', lw=1.2, label='measured (cycle average)')
    ax.plot(a, nom['predicted_m'] * 1e3, 'C0--', lw=1, label='predicted, nominal train')
    rx.plot(a, (nom['measured_m'] - nom['predicted_m']) * 1e6, 'C0-', lw=1, label='nominal')
    cal = curve.get('calibrated')
    if cal is not None:
        ax.plot(cal['alpha_deg'], cal['predicted_m'] * 1e3, 'C3:', lw=1.2,
                label='predicted, calibrated train')
        rx.plot(cal['alpha_deg'], (cal['measured_m'] - cal['predicted_m']) * 1e6, 'C3-',
                lw=1, label='calibrated')
    ax.set_xlim(lo, hi)
    ax.set_ylabel('valve lift [mm]')
    ax.set_title(f"{curve['name']}: {curve['rpm']:.0f} rpm camshaft")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    rx.set_xlabel('cam angle from the nose [deg]')
    rx.set_ylabel('measured - predicted [um]')
    rx.legend(fontsize=8)
    rx.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def write_plots(curves: Sequence[Mapping[str, Any]], folder: Any) -> list[Any]:
    """One PNG per run in ``folder`` (``<run>.png``); the paths."""
    import matplotlib.pyplot as plt

    from cam_metrology.inputs.files import output_dir, safe_name, save_figure

    out = output_dir(folder, '--plot')
    paths = []
    for c in curves:
        fig = run_figure(c)
        paths.append(save_figure(fig, out / f"{safe_name(c['name'])}.png", '--plot', dpi=100))
        plt.close(fig)
    return paths


def html_report(result: Mapping[str, Any], curves: Sequence[Mapping[str, Any]],
                title: str) -> str:
    """A self-contained HTML page: the runs' table, the parameters, the plots."""
    import matplotlib.pyplot as plt

    rows = []
    for r in result['runs']:
        res = r['residual_rms_m']
        rows.append('<tr>' + ''.join(f'<td>{html.escape(str(v))}</td>' for v in (
            r['name'], f"{r['rpm']:.1f}", f"{r['speed_variation'] * 100:.2f} %",
            f"{r['revolutions']:.2f}", r['separated'],
            '' if r['separation_angle_deg'] is None else f"{r['separation_angle_deg']:.1f}",
            r['bounce_count'],
            '' if r['seating_velocity_m_s'] is None else f"{r['seating_velocity_m_s']:.3f}",
            f"{res['nominal'] * 1e6:.2f}",
            '' if 'calibrated' not in res else f"{res['calibrated'] * 1e6:.2f}")) + '</tr>')
    head = ('run', 'rpm', 'speed variation', 'revolutions', 'separated', 'separation [deg]',
            'bounces', 'seating velocity [m/s]', 'residual rms nominal [um]',
            'residual rms calibrated [um]')
    parts = [f'<h1>{html.escape(title)}</h1>',
             f"<p>lobe {html.escape(str(result['lobe']))}, nose angle "
             f"{result['nose_angle_deg']:.4f} deg ({result['nose_angle_source']}); jump "
             f"speed {html.escape(json.dumps(result['jump_speed_rpm']))} rpm</p>",
             '<table border=1 cellspacing=0 cellpadding=3><tr>'
             + ''.join(f'<th>{h}</th>' for h in head) + '</tr>' + ''.join(rows) + '</table>']
    if 'parameters' in result:
        prow = ''.join(f"<tr><td>{n}</td><td>{p['nominal']:.6g}</td><td>{p['value']:.6g}"
                       f"</td><td>{p['std']:.3g}</td><td>{p['unit']}</td></tr>"
                       for n, p in result['parameters'].items())
        parts.append('<h2>Calibrated parameters</h2><table border=1 cellspacing=0 '
                     'cellpadding=3><tr><th>name</th><th>nominal</th><th>value</th>'
                     f'<th>std</th><th>unit</th></tr>{prow}</table>')
        for w in result.get('warnings', []):
            parts.append(f'<p><b>warning:</b> {html.escape(w)}</p>')
    for c in curves:
        fig = run_figure(c)
        buf = io.BytesIO()
        fig.savefig(buf, format='png', dpi=90)
        plt.close(fig)
        data = base64.b64encode(buf.getvalue()).decode()
        parts.append(f'<h3>{html.escape(c["name"])}</h3><img src="data:image/png;base64,'
                     f'{data}">')
    return ('<!DOCTYPE html><html><head><meta charset="utf-8"><title>'
            f'{html.escape(title)}</title></head><body>' + '\n'.join(parts)
            + '</body></html>\n')


def summary_lines(result: dict[str, Any]) -> list[str]:
    """Human summary of a rig result."""
    std = result.get('nose_angle_std_deg')
    lines = [f"lobe {result['lobe']}: nose angle {result['nose_angle_deg']:.4f} deg"
             + (f' +- {std:.4f}' if std is not None else '')
             + f" ({result['nose_angle_source']})"]
    for r in result['runs']:
        res = r['residual_rms_m']
        cal = f", calibrated {res['calibrated'] * 1e6:.2f}" if 'calibrated' in res else ''
        sep = (f"separated at {r['separation_angle_deg']:.1f} deg" if r['separated']
               else 'no separation')
        vs = r['seating_velocity_m_s']
        lines.append(f"{r['name']}: {r['rpm']:.1f} rpm (+-{100 * r['speed_variation'] / 2:.2f}"
                     f" %), {r['revolutions']:.1f} rev; {sep}; {r['bounce_count']} bounce(s); "
                     f"seating {'-' if vs is None else f'{vs:.3f} m/s'}; residual rms nominal "
                     f"{res['nominal'] * 1e6:.2f} um{cal}")
    for n, p in result.get('parameters', {}).items():
        lines.append(f"{n}: {p['value']:.6g} +- {p['std']:.3g} {p['unit']} (nominal "
                     f"{p['nominal']:.6g})")
    j = result['jump_speed_rpm']
    if j.get('skipped'):
        return lines + ['jump speed: skipped (--no-jump)']
    fmt = (lambda v: 'above 3x the fastest run' if v is None else f'{v:.0f} rpm')
    lines.append('jump speed: nominal ' + fmt(j.get('nominal'))
                 + (f", calibrated {fmt(j.get('calibrated'))}" if 'calibrated' in j else ''))
    return lines
