"""`analyze --report/--csv`, the provenance block and `cam-bench --version`; the HTML
report rendered by a real headless browser (Debian's chromium) when it is installed."""
from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from cam_metrology import __version__
from cam_metrology.cli import main


@pytest.fixture(scope='module')
def analysed(tmp_path_factory):
    """A bag of a part with a 0.3 % form error against tolerances, analysed once."""
    from cam_metrology.scene.parse import parse_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    with open('config/default_scene.yaml', encoding='utf-8') as f:
        doc = yaml.safe_load(f)
    doc.pop('valve_train')
    doc['lobes'] = doc['lobes'][:2]
    doc['tolerances'] = {'lift_error_um': 10, 'lift_error_zones': [
        {'from_deg': -20, 'to_deg': 20, 'band_um': 12}], 'phase_deg': 0.6}
    root = tmp_path_factory.mktemp('report')
    bag = root / 'bag'
    write_sim_bag(bag, parse_scene(yaml.safe_dump(doc)),
                  SimParams(samples_per_rev=1440, lift_scale=1.003, seed=2))
    out = {'bag': bag, 'html': root / 'r.html', 'csv': root / 'r.csv', 'json': root / 'r.json'}
    code = main(['analyze', str(bag), '--only-metrology', '--report', str(out['html']),
                 '--csv', str(out['csv']), '--json', str(out['json'])])
    out['code'] = code
    return out


def test_report_files(analysed) -> None:
    assert analysed['code'] == 3
    report = json.loads(analysed['json'].read_text())
    assert report['verdict']['result'] == 'fail'
    text = analysed['html'].read_text()
    assert text.index('id="verdict"') < text.index('<h2>Cam card')
    assert 'FAIL: part rejected' in text
    assert len(re.findall(r'<img class="plot"[^>]+src="data:image/png;base64,', text)) == 3
    assert not re.search(r'(src|href)="(https?:)?//', text)    # nothing from the network
    prov = report['provenance']
    assert prov['cam_bench_version'] == __version__
    files = sorted(p for p in Path(analysed['bag']).rglob('*') if p.is_file())
    h = hashlib.sha256()
    for p in files:
        h.update(str(p.relative_to(analysed['bag'])).encode() + b'\0' + p.read_bytes())
    assert prov['bag_sha256'] == h.hexdigest()
    assert prov['bag_sha256'] in text
    rows = list(csv.DictReader(io.StringIO(analysed['csv'].read_text())))
    assert [r['feature'] for r in rows] == ['lobe_1', 'lobe_2', 'dowel_pin']
    lobe = report['features']['lobe_1']
    assert float(rows[0]['angle_std_arcsec']) == pytest.approx(lobe['angle_std_deg'] * 3600,
                                                               rel=1e-9)
    assert rows[0]['verdict'] == lobe['verdict']['result']
    card = lobe['cam_card']
    assert float(rows[0]['max_lift_mm']) == pytest.approx(card['measured']['max_lift_mm'])
    assert card['nominal']['max_lift_mm'] == pytest.approx(8.5, abs=1e-6)


def test_version_everywhere(capsys) -> None:
    setup = Path('setup.py').read_text()
    assert f"version='{__version__}'" in setup
    assert f'<version>{__version__}</version>' in Path('package.xml').read_text()
    with pytest.raises(SystemExit) as exc:
        main(['--version'])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith(f'cam-bench {__version__}')


def _chromium() -> str | None:
    return shutil.which('chromium') or shutil.which('chromium-browser')


#: headless, and nothing that would reach outside (the CI network refuses connections)
CHROMIUM_FLAGS = ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic',
                  '--no-first-run', '--disable-background-networking',
                  '--disable-component-update', '--disable-sync')


@pytest.mark.skipif(_chromium() is None, reason='chromium not installed: ./run-tests installs '
                    'it as root (tools/bootstrap.sh said why it could not)')
def test_report_renders_in_a_headless_browser(analysed, tmp_path) -> None:
    """The browser's DOM after layout: the verdict is there and every image decoded
    (naturalWidth > 0 is written into the title by a one-line script in a copy)."""
    page = tmp_path / 'page.html'
    probe = ('<script>window.onload=function(){var i=document.images,n=0;for(var k=0;'
             'k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0)n++;}'
             'document.title="loaded "+n+" of "+i.length;};</script>')
    page.write_text(analysed['html'].read_text().replace('</body>', probe + '</body>'))
    profile = tmp_path / 'chromium-profile'   # a fresh profile every run
    run = subprocess.run([_chromium(), *CHROMIUM_FLAGS, f'--user-data-dir={profile}',
                          '--virtual-time-budget=5000', '--dump-dom', page.as_uri()],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert '<title>loaded 3 of 3</title>' in run.stdout
    assert 'FAIL: part rejected' in run.stdout


def test_human_report_has_verdict_and_card(analysed, capsys) -> None:
    assert main(['analyze', str(analysed['bag']), '--only-metrology',
                 '--heights-mm', '0.5']) == 3
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith('verdict: FAIL')
    card = next(line for line in out if line.startswith('card lobe_1'))
    assert '@0.5 mm' in card


def test_card_of_a_bag_and_its_measured_profile_file(analysed, tmp_path, capsys) -> None:
    from cam_metrology.inputs.lift_tables import read_gauge_file

    out = tmp_path / 'lobe_1.txt'
    assert main(['card', str(analysed['bag']), '--lobe', 'lobe_1', '--nominal', str(out),
                 '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    measured = doc['cards']['lobe_1']['measured']
    assert measured['max_lift_mm'] == pytest.approx(8.5 * 1.003, abs=2e-4)   # the truth
    table = read_gauge_file(out)
    assert table.follower == ('roller', pytest.approx(0.0125))
    assert main(['card', str(out), '--json', '-']) == 0
    again = json.loads(capsys.readouterr().out)['cards']['lobe_1']
    assert again['max_lift_mm'] == pytest.approx(measured['max_lift_mm'], abs=1e-4)
    assert again['heights'][0]['duration_cam_deg'] == pytest.approx(
        measured['heights'][0]['duration_cam_deg'], abs=0.01)


def test_velocity_acceleration_plot_scaled_to_the_measured_curve() -> None:
    """The HTML report's derivative figure: both curves drawn, the axes scaled to the
    reconstructed (measured) curve even when the design has a spike 1000x larger."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    from cam_design.lift_laws.registry import from_spec
    from cam_metrology.report.html_report import html_report
    from cam_metrology.report.plots import derivative_figure

    law = from_spec({'family': 'constant_acceleration', 'ramp': 'none', 'rise': 8e-3,
                     'half_angle': math.radians(60), 'positive_width': math.radians(20)})
    a = np.radians(np.arange(-180, 180, 0.5))
    data = np.column_stack([a] + [law(a, nu) for nu in range(4)])
    cols = ('alpha_rad', 'lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
            'jerk_m_per_rad3')

    def spiky(x, nu=0):
        return law(x, nu) + (1000 * np.max(np.abs(law(a, 2))) * (np.abs(x) < 0.01)
                             if nu == 2 else 0.0)

    fig = derivative_figure('lobe', cols, data, spiky)
    try:
        acc = data[:, 3] * 1e3 * (math.pi / 180) ** 2
        lo, hi = fig.axes[1].get_ylim()
        span = acc.max() - acc.min()
        assert lo == pytest.approx(acc.min() - 0.1 * span) and \
            hi == pytest.approx(acc.max() + 0.1 * span)
        assert len(fig.axes[1].lines) == 2
    finally:
        plt.close(fig)
    report = {'camshaft_id': 'x', 'features': {'lobe': {'kind': 'lobe', 'status': 'ok'}}}
    table = np.column_stack([a, law(a), law(a)])
    page = html_report(report, {'lobe': table}, {'lobe': (cols, data)}, {'lobe': law})
    assert page.count('<img class="plot"') == 2 and 'lobe velocity and acceleration' in page


def test_seating_window_finds_the_bounces() -> None:
    """A lobe closing at 60 deg, then two bounces of 5 and 2 um ending at 75 deg: the
    inset window of the dynamics plot spans first seating to the last bounce."""
    import numpy as np

    from cam_design.valve_train.sweep import seating_window

    a = np.radians(np.arange(-90.0, 270.0, 0.1))
    lift = np.where(np.abs(a) < np.radians(60), 8e-3 * np.cos(1.5 * a) ** 2, 0.0)
    bounce = (a > np.radians(62)) & (a < np.radians(68))
    lift = lift + np.where(bounce, 5e-6 * np.sin((a - np.radians(62)) * 30) ** 2, 0.0)
    second = (a > np.radians(70)) & (a < np.radians(75))
    lift = lift + np.where(second, 2e-6 * np.sin((a - np.radians(70)) * 36) ** 2, 0.0)
    seat, end = np.degrees(seating_window(a, lift))
    assert 55.0 < seat < 60.0 and 74.0 < end < 75.0
    assert seating_window(a, 8e-3 + 0 * a) is None


class _Tables(__import__('html.parser').parser.HTMLParser):
    """The text of every cell of every table with an id: {id: [[cell, ...], ...]}."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, list[list[str]]] = {}
        self._id: str | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs) -> None:
        if tag == 'table':
            self._id = dict(attrs).get('id')
            if self._id:
                self.tables[self._id] = []
        elif tag == 'tr' and self._id:
            self.tables[self._id].append([])
        elif tag in ('td', 'th') and self._id:
            self._cell = []

    def handle_endtag(self, tag) -> None:
        if tag in ('td', 'th') and self._cell is not None:
            self.tables[self._id][-1].append(''.join(self._cell).strip())
            self._cell = None
        elif tag == 'table':
            self._id = None

    def handle_data(self, data) -> None:
        if self._cell is not None:
            self._cell.append(data)


CHATTER_UM, BEND_UM = 0.8, 10.0


@pytest.fixture(scope='module')
def form_analysed(tmp_path_factory):
    """Two lobes at z = 0.1 and 0.3 m with a 37-UPR chatter of 0.8 um, three 3-lobed
    journals at 0, 0.2, 0.4 m on a shaft bent 10 um towards 30 deg, tolerances on every
    form, journal and derivative quantity (the waviness and the mid journal's run-out
    fail)."""
    from cam_metrology.scene.parse import parse_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    with open('config/default_scene.yaml', encoding='utf-8') as f:
        doc = yaml.safe_load(f)
    doc.pop('valve_train')
    doc['lobes'] = doc['lobes'][:2]
    for lobe, z in zip(doc['lobes'], (0.1, 0.3)):
        lobe['axial_position'] = z
    doc['journals'] = [{'id': f'journal_{i + 1}', 'radius': 0.0125, 'axial_position': z,
                        'tolerances': {'runout_max_um': 15, 'roundness_max_um': 3,
                                       'diameter_um': 2}}
                       for i, z in enumerate((0.0, 0.2, 0.4))]
    doc['probe']['zero_radius'] = doc['base_circle_radius'] - 0.5e-3
    doc['tolerances'] = {'roundness_max_um': 2, 'waviness_max_um': 0.5,
                         'velocity_error_max_mm_per_rad': 0.05,
                         'acceleration_error_max_mm_per_rad2': 0.5}
    root = tmp_path_factory.mktemp('form_report')
    write_sim_bag(root / 'bag', parse_scene(yaml.safe_dump(doc)),
                  SimParams(bend=BEND_UM * 1e-6, bend_direction_deg=30.0, probe_noise=0.1e-6,
                            chatter_upr=37, chatter_amplitude=CHATTER_UM * 1e-6,
                            journal_lobes=3, journal_lobing=1e-6, seed=3))
    code = main(['analyze', str(root / 'bag'), '--only-metrology', '--report',
                 str(root / 'r.html'), '--json', str(root / 'r.json')])
    return {'code': code, 'html': root / 'r.html',
            'report': json.loads((root / 'r.json').read_text())}


def _check(feature: dict, quantity: str) -> str | None:
    return next((c['result'] for c in feature['verdict']['checks']
                 if c['quantity'] == quantity), None)


def test_report_shows_form_journals_and_shaft(form_analysed) -> None:
    """Every number of the form tables is the report's (to its 3 printed decimals) with the
    verdict of its check; against the truth: the lobes' waviness is the 0.8 um chatter at
    37 UPR (fails 0.5 um), the mid journal's run-out 2 x 10 um (fails 15 um), the journals'
    largest harmonic the 1 um lobing at 3 UPR, the straightness 2 B (4 - sqrt2) / 5 =
    10.343 um (test_journals), all within 0.05 um."""
    report = form_analysed['report']
    assert form_analysed['code'] == 3
    parser = _Tables()
    parser.feed(form_analysed['html'].read_text())
    tables = parser.tables
    columns = {'roundness µm': ('roundness_um', 'roundness_um'),
               'waviness µm': ('waviness', 'waviness_max_amplitude_um'),
               'journal run-out µm': ('runout_um', 'runout_um'),
               'diameter deviation µm': ('diameter_deviation_um', 'diameter_deviation_um'),
               'velocity error mm/rad': ('velocity_error_mm_per_rad',
                                         'velocity_error_mm_per_rad'),
               'acceleration error mm/rad²': ('acceleration_error_mm_per_rad2',
                                              'acceleration_error_mm_per_rad2')}
    seen = set()
    for table in ('form', 'size', 'velocity'):
        head, *rows = tables[table]
        for row in rows:
            feature = report['features'][row[0]]
            for name, cell in zip(head, row):
                if name not in columns or cell == '-':
                    continue
                field, quantity = columns[name]
                value = feature[field]
                value = value.get('max_amplitude_um', value.get('max_abs')) \
                    if isinstance(value, dict) else value
                number, *rest = cell.split()
                assert float(number) == pytest.approx(value, abs=5e-4), (row[0], name)
                result = _check(feature, quantity)
                assert (cell.endswith(f'({result})') if result else ')' not in cell), \
                    (row[0], name, cell)
                seen.add((row[0], name))
    for lobe in ('lobe_1', 'lobe_2'):
        assert {(lobe, 'waviness µm'), (lobe, 'velocity error mm/rad')} <= seen
        row = next(r for r in tables['form'] if r[0] == lobe)
        assert row[tables['form'][0].index('waviness UPR')] == '37'
        assert float(row[tables['form'][0].index('waviness µm')].split()[0]) == \
            pytest.approx(CHATTER_UM, abs=0.05)
        assert row[tables['form'][0].index('waviness µm')].endswith('(fail)')
    mid = next(r for r in tables['size'] if r[0] == 'journal_2')
    runout = mid[tables['size'][0].index('journal run-out µm')]
    assert float(runout.split()[0]) == pytest.approx(2 * BEND_UM, abs=0.05)
    assert runout.endswith('(fail)')
    assert float(mid[tables['size'][0].index('run-out direction deg')]) == \
        pytest.approx(30.0, abs=0.2)
    j1 = next(r for r in tables['harmonics'] if r[0] == 'journal_1')
    assert j1[1].startswith('3 UPR: 1.00')
    text = form_analysed['html'].read_text()
    assert len(re.findall(r'<td class="fail" title="waviness_max_amplitude_um 0\.[0-9]+ fail">',
                          text)) == 2   # the check behind each failed waviness cell
    straightness = float(re.search(r'Straightness ([0-9.]+) µm', text).group(1))
    assert straightness == pytest.approx(2 * BEND_UM * (4 - math.sqrt(2)) / 5, abs=0.05)
    assert text.index('<h2>Form, journals and tracks') < text.index('<h2>Plots')


@pytest.mark.skipif(_chromium() is None, reason='chromium not installed: ./run-tests installs '
                    'it as root (tools/bootstrap.sh said why it could not)')
def test_form_tables_render_in_a_headless_browser(form_analysed, tmp_path) -> None:
    """The browser's DOM after layout holds the form, size, velocity, harmonics tables and
    the shaft paragraph, with the failed waviness marked."""
    run = subprocess.run([_chromium(), *CHROMIUM_FLAGS,
                          f'--user-data-dir={tmp_path / "profile"}',
                          '--virtual-time-budget=5000', '--dump-dom',
                          form_analysed['html'].as_uri()],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    for anchor in ('form', 'size', 'velocity', 'harmonics'):
        assert f'<table id="{anchor}">' in run.stdout
    assert '<p id="shaft">Straightness' in run.stdout
    assert re.search(r'<td class="fail" title="[^"]*">0\.[0-9]{3} \(fail\)</td>', run.stdout)
