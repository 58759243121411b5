"""The form section of the HTML report: per feature the form, journal and derivative-error
numbers (``wire.form_values``, the list /metrology/values publishes) coloured by their
verdict, the largest harmonics in UPR, the shaft's straightness and each tracked lobe's
taper and twist. Empty when the report has none of them."""
from __future__ import annotations

from typing import Any, Mapping

from cam_metrology.report.html_cells import esc, number, result_class
from cam_metrology.wire.form_values import (FORM_VALUES, FormValue, feature_form_values,
                                            quantity_checks, quantity_verdict)

__all__ = ['form_html', 'HARMONICS_SHOWN']

#: harmonics listed per feature (the largest first)
HARMONICS_SHOWN = 6
#: fields whose entry also says where on the cam the largest value is (``at_deg``)
_AT = {'velocity_error_max_mm_per_rad': 'velocity_error_mm_per_rad',
       'acceleration_error_max_mm_per_rad2': 'acceleration_error_mm_per_rad2'}


def _cell(field: FormValue, value: Any, verdict: str | None, entry: Mapping[str, Any]) -> str:
    """One number, with its verdict as the cell's colour and in words; the checks
    behind it (zones included) in its title."""
    if value is None:
        return '<td>-</td>'
    text = f'{value:d}' if isinstance(value, int) else f'{value:.3f}'
    at = (entry.get(_AT[field.name]) or {}).get('at_deg') if field.name in _AT else None
    if at is not None:
        text += f' at {at:.1f}°'
    if verdict is None or field.quantity is None:
        return f'<td>{esc(text)}</td>'
    title = '; '.join(f"{c['quantity']} {c['value']:.4g} {c['result']}"
                      for c in quantity_checks(entry.get('verdict'), field.quantity))
    return (f'<td class="{result_class(verdict)}" title="{esc(title)}">{esc(text)} '
            f'({esc(verdict)})</td>')


#: the per-feature tables: (heading, FormValue names), each showing the features and
#: columns that have a value
_TABLES = (('Form', ('harmonic_max_upr', 'harmonic_max_amplitude_um', 'roundness_um',
                     'waviness_max_amplitude_um', 'waviness_upr_at_max')),
           ('Size and run-out', ('base_circle_runout_um', 'runout_um', 'runout_direction_deg',
                                 'diameter_deviation_um', 'nose_lift_error_um')),
           ('Velocity and acceleration error', ('velocity_error_max_mm_per_rad',
                                                'acceleration_error_max_mm_per_rad2')))


def _waviness_where(f: Mapping[str, Any]) -> str:
    """The waviness band and where on the cam its envelope peaks."""
    wav = f.get('waviness') or {}
    band = wav.get('band_upr')
    if not band:
        return '-'
    return f'{band[0]}–{band[1]} UPR' + ('' if wav.get('at_deg') is None else
                                         f', near {wav["at_deg"]:.1f}° over '
                                         f'{wav.get("extent_deg", 0.0):.0f}°')


def _features_table(features: Mapping[str, Any], heading: str, names: tuple[str, ...]) -> str:
    """One table of ``names`` (FormValue names): a row per feature with any of them, a
    column per name any feature has; the form table adds the waviness band."""
    entries = {fid: f for fid, f in features.items() if isinstance(f, Mapping)}
    shown = [v for v in FORM_VALUES if v.name in names and any(
        v.get(f) is not None for f in entries.values())]
    rows = []
    for fid, f in entries.items():
        values = {v.name: (value, verdict) for v, value, verdict in feature_form_values(f, None)}
        if all(values[v.name][0] is None for v in shown):
            continue
        where = (f'<td class="l">{esc(_waviness_where(f))}</td>'
                 if 'waviness_upr_at_max' in names else '')
        rows.append(f'<tr><td class="l">{esc(fid)}</td><td class="l">{esc(f.get("kind", ""))}'
                    '</td>' + ''.join(_cell(v, *values[v.name], f) for v in shown) +
                    where + '</tr>')
    if not rows:
        return ''
    head = ''.join(f'<th>{esc(v.label)}</th>' for v in shown)
    if 'waviness_upr_at_max' in names:
        head += '<th class="l">waviness band</th>'
    anchor = heading.lower().split()[0]
    return (f'<h3>{esc(heading)}</h3><table id="{anchor}"><tr><th class="l">feature</th>'
            f'<th class="l">kind</th>{head}</tr>' + ''.join(rows) + '</table>')


def _harmonics_table(features: Mapping[str, Any]) -> str:
    """The largest ``HARMONICS_SHOWN`` harmonics of each feature's deviation, a row per
    feature."""
    rows = []
    for fid, f in features.items():
        harmonics = (f.get('harmonics') or [])[:HARMONICS_SHOWN] \
            if isinstance(f, Mapping) else []
        if harmonics:
            rows.append(f'<tr><td class="l">{esc(fid)}</td>' + ''.join(
                f'<td>{h["upr"]} UPR: {h["amplitude_um"]:.4f} µm, {h["phase_deg"]:.1f}°</td>'
                for h in harmonics) + '</tr>')
    if not rows:
        return ''
    return (f'<h3>Harmonics</h3><p>The {HARMONICS_SHOWN} largest harmonics of each '
            'feature\'s deviation over the revolution, largest first: undulations per '
            'revolution (UPR), amplitude, phase φ (the first crest at encoder angle '
            'φ/UPR).</p><table id="harmonics"><tr><th class="l">feature</th>' +
            ''.join(f'<th>{k + 1}</th>' for k in range(HARMONICS_SHOWN)) + '</tr>' +
            ''.join(rows) + '</table>')


def _shaft_html(shaft: Mapping[str, Any]) -> str:
    """Straightness and bow of the shaft, the features used and those left out."""
    if not shaft:
        return ''
    if shaft.get('straightness_um') is None:
        text = f'Straightness not computed: {esc(shaft.get("why", ""))}.'
    else:
        text = (f'Straightness {shaft["straightness_um"]:.3f} µm: bow {shaft["bow_um"]:.3f} µm '
                f'at {shaft["bow_at_mm"]:g} mm towards {shaft["bow_direction_deg"]:.1f}° '
                f'(centres of {esc(", ".join(shaft.get("from") or []))}).')
    left = ''.join(f'<li>left out: {esc(n.get("feature"))}: {esc(n.get("why"))}</li>'
                   for n in shaft.get('left_out') or [])
    return (f'<h3>Shaft</h3><p id="shaft">{text}</p>' +
            (f'<ul>{left}</ul>' if left else ''))


def _tracks_html(tracks: Mapping[str, Any]) -> str:
    """Taper and twist of each lobe measured on tracks, with their verdicts."""
    rows = []
    for lobe, tr in tracks.items():
        if 'tracks' not in tr:
            rows.append(f'<tr><td class="l">{esc(lobe)}</td><td class="l" colspan="4">'
                        f'{esc(tr.get("why", ""))}</td></tr>')
            continue
        cells = []
        for field, quantity, spec in (('taper_um_per_mm', 'taper_um_per_mm', '.3f'),
                                      ('nose_angle_difference_deg',
                                       'nose_angle_difference_deg', '.4f')):
            verdict = quantity_verdict(tr.get('verdict'), quantity)
            text = number(tr.get(field), spec)
            cells.append(f'<td>{esc(text)}</td>' if verdict is None else
                         f'<td class="{result_class(verdict)}">{esc(text)} ({esc(verdict)})</td>')
        rows.append(f'<tr><td class="l">{esc(lobe)}</td>'
                    f'<td class="l">{esc(", ".join(tr["tracks"]))}</td>' + ''.join(cells) +
                    f'<td>{tr["twist_deg_per_mm"] * 3600:.2f}</td></tr>')
    if not rows:
        return ''
    return ('<h3>Tracks across the lobe width</h3><table id="tracks"><tr><th class="l">lobe'
            '</th><th class="l">tracks</th><th>taper µm/mm</th><th>nose-angle difference deg'
            '</th><th>twist arcsec/mm</th></tr>' + ''.join(rows) + '</table>')


def form_html(report: Mapping[str, Any]) -> str:
    """The form section (module doc), or '' when the report has no form results."""
    features = report.get('features') or {}
    body = (''.join(_features_table(features, h, n) for h, n in _TABLES) +
            _harmonics_table(features) +
            _shaft_html(report.get('shaft') or {}) +
            _tracks_html(report.get('lobe_tracks') or {}))
    if not body:
        return ''
    return ('<h2>Form, journals and tracks</h2><p>Each number coloured by its check when the '
            'scene tolerances it (the checks are listed under the verdict); velocity and '
            'acceleration errors with the cam angle of their largest value.</p>' + body)
