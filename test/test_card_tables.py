"""`cam-bench card` on gauge-like tables: coarse steps (2 and 5 deg), lifts rounded to
0.01 mm, lobes with ramps and with acceleration jumps. A table coarser than 1 deg is
read through the reconstruction spline (too few points for local fits); its card must
agree with the card of the analytic law the table was made from, within what the
rounding allows (lift noise q/sqrt(12) over the slope at the event)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cam_design import cam_card as cc
from cam_design.lift_laws.registry import from_spec
from cam_metrology.cli import main
from cam_metrology.cli.card import table_card

DEG = math.pi / 180.0
HEIGHTS = (1e-3, 1.27e-3, 1e-4)
Q = 1e-5   # 0.01 mm rounding
LAWS = {
    'flat_tappet_preset': {'family': 'preset', 'name': 'flat_tappet_intake'},
    'polynomial_ramped': {'family': 'preset', 'name': 'methods_example'},
    'constant_acceleration': {'family': 'constant_acceleration', 'ramp': 'none',
                              'rise': 8e-3, 'half_angle': 60 * DEG,
                              'positive_width': 20 * DEG},
}


def _table(law, step_deg: float) -> tuple[np.ndarray, np.ndarray]:
    a = np.arange(-180.0, 180.0, step_deg) * DEG
    return a, np.round(np.asarray(law(a, 0), dtype=float) / Q) * Q


@pytest.mark.parametrize('name', sorted(LAWS))
@pytest.mark.parametrize('step_deg', [1.0, 2.0, 5.0])
def test_coarse_table_card_matches_the_law(name: str, step_deg: float) -> None:
    law = from_spec(LAWS[name])
    truth = cc.card_from_law(law, HEIGHTS)
    card = table_card(*_table(law, step_deg), HEIGHTS, 'table.csv')
    assert card['source'] == 'table (smoothed)'   # 0.01 mm rounding at >= 1 deg
    assert 'every 5 deg' in card['note'] or step_deg != 5.0
    assert card['max_lift_m'] == pytest.approx(truth['max_lift_m'], abs=3e-6)
    assert card['centreline_deg'] == pytest.approx(truth['centreline_deg'], abs=0.01)
    for got, ref in zip(card['heights'], truth['heights']):
        for side in ('opening_deg', 'closing_deg'):
            slope = abs(float(law(np.array([ref[side] * DEG]), 1)[0])) * DEG   # m/deg
            allow = 4.0 * (Q / math.sqrt(12.0)) / slope + 0.02
            assert abs(got[side] - ref[side]) <= allow, (got['height_m'], side, allow)


def test_fine_table_keeps_local_fits() -> None:
    law = from_spec(LAWS['polynomial_ramped'])
    a = np.arange(-180.0, 180.0, 0.5) * DEG
    card = table_card(a, np.asarray(law(a, 0), dtype=float), HEIGHTS, 'fine.csv')
    assert card['source'] == 'table (interpolated)'   # exact rows
    truth = cc.card_from_law(law, HEIGHTS)
    assert card['heights'][0]['opening_deg'] == pytest.approx(
        truth['heights'][0]['opening_deg'], abs=1e-3)


def test_card_cli_on_a_5_deg_gauge_table(tmp_path) -> None:
    law = from_spec(LAWS['flat_tappet_preset'])
    a, h = _table(law, 5.0)
    path = tmp_path / 'gauge.csv'
    path.write_text('angle_deg,lift_mm\n' + ''.join(
        f'{x:.0f},{y * 1e3:.2f}\n' for x, y in zip(np.degrees(a), h)), encoding='utf-8')
    out = tmp_path / 'card.json'
    assert main(['card', str(path), '--json', str(out)]) == 0
    doc = json.loads(out.read_text(encoding='utf-8'))
    (card,) = doc['cards'].values()
    assert card['source'] == 'table (smoothed)'   # 0.01 mm rounding at >= 1 deg
    truth = cc.card_from_law(law, (1e-3,))
    assert card['heights'][0]['duration_cam_deg'] == pytest.approx(
        truth['heights'][0]['duration_cam_deg'], abs=0.2)


@pytest.mark.parametrize('step_deg', [0.5, 2.0])
@pytest.mark.parametrize('peak_deg', [-90.0, 0.0, 100.0, 179.0])
def test_eccentric_and_off_centre_lobes_keep_their_frame(step_deg: float,
                                                         peak_deg: float) -> None:
    """An eccentric (a full-revolution lobe, e (1 + cos(alpha - peak))) wherever its peak
    lies, also across +-180 deg: durations 2 arccos(y/e - 1), centreline at the peak in
    the table's own frame, area 2 pi e (closed forms)."""
    e = 3e-3
    a = np.arange(-180.0, 180.0, step_deg) * DEG
    h = np.round(e * (1.0 + np.cos(a - peak_deg * DEG)) / 1e-6) * 1e-6   # 0.001 mm
    card = table_card(a, h, HEIGHTS, 'eccentric.csv')
    assert card['max_lift_m'] == pytest.approx(2 * e, abs=2e-6)
    assert card['centreline_deg'] == pytest.approx(peak_deg, abs=0.01)
    assert card['area_m_rad'] == pytest.approx(2 * math.pi * e, rel=1e-3)
    for entry in card['heights']:
        half = math.degrees(math.acos(entry['height_m'] / e - 1.0))
        # 0.02 deg, plus what the rows' 1 um rounding moves an event by: q/2 over the
        # slope there (a peak midway between two rows: both round the same way)
        slope = e * math.sin(math.radians(half)) * DEG   # m/deg
        allow = 0.02 + 0.5e-6 / slope
        assert entry['duration_cam_deg'] == pytest.approx(2 * half, abs=allow)
        assert entry['opening_deg'] == pytest.approx(peak_deg - half, abs=allow)
        assert entry['closing_deg'] == pytest.approx(peak_deg + half, abs=allow)


@pytest.mark.parametrize('nose_deg', [180.0, 200.0, 350.0])
def test_card_of_a_0_to_360_table_is_told_in_its_frame(nose_deg: float) -> None:
    """A gauge table written 0..360 deg (rows 0.5 deg apart, 0.01 mm) keeps its frame:
    the centreline at the nose as written (180, 200, 350 deg, not -180, -160, -10) and
    the events on either side of it, at the analytic lobe's half-durations."""
    law = from_spec(LAWS['polynomial_ramped'])
    a = np.arange(0.0, 360.0, 0.5) * DEG
    rel = (a - nose_deg * DEG + math.pi) % (2 * math.pi) - math.pi
    h = np.round(np.asarray(law(rel, 0), dtype=float) / Q) * Q
    card = table_card(a, h, HEIGHTS[:1], 'lobe_0_360.csv')
    truth = cc.card_from_law(law, HEIGHTS[:1])['heights'][0]
    assert card['centreline_deg'] == pytest.approx(nose_deg, abs=0.02)
    entry = card['heights'][0]
    assert entry['opening_deg'] == pytest.approx(nose_deg + truth['opening_deg'], abs=0.05)
    assert entry['closing_deg'] == pytest.approx(nose_deg + truth['closing_deg'], abs=0.05)
