"""Golden reports and the pytest plugin for users' own bags.

The comparison is checked on hand-made reports (each tolerance rule on both sides of
its limit, angle wrap-around, missing and extra features), the ``golden`` command on a
fixture bag, and the plugin end to end with pytester: a user's ten-line test file run
over a folder of bags, passing, failing with a readable diff, and skipping without
``--cam-bench-bags``.
"""
from __future__ import annotations

import copy
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from cam_metrology.cli import main
from cam_metrology.report.golden import assert_report_matches, compare_reports, golden_of

pytest_plugins = ['pytester']

REPO = Path(__file__).resolve().parent.parent
BAG = REPO / 'bags' / 'default_clean'

GOLD = {
    'camshaft_id': 'X-1', 'complete': True,
    'features': {
        'lobe_1': {'kind': 'lobe', 'status': 'ok', 'angle_deg': 359.9999,
                   'angle_std_deg': 1e-2, 'phase_deg': 10.0, 'samples_used': 3600,
                   'lift_error_um': {'rms': 0.5, 'max_plus': 1.0}, 'lift_offset_mm': 0.5,
                   'iterations': 3, 'sensitive_point_levels_mm': [1.0, 2.0],
                   'area_mm_deg': 448.49, 'verdict': {'checks': [
                       {'quantity': 'lift_error_max_plus_um', 'unit': 'um', 'value': 3e-11,
                        'lower': -25.0, 'upper': 25.0, 'margin': 25.0 - 3e-11},
                       {'quantity': 'phase_error_deg', 'unit': 'deg', 'value': 0.1,
                        'lower': -0.5, 'upper': 0.5, 'margin': 0.4}]}},
        'dowel_pin': {'kind': 'dowel_pin', 'status': 'ok', 'angle_deg': 0.1},
    },
    'skipped': [{'what': 'dynamics', 'why': 'no valve_train'}],
    'provenance': {'host': 'a'},
}


def _with(path: tuple, value: object) -> dict:
    rep = copy.deepcopy(GOLD)
    node = rep
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return rep


def test_identical_reports_agree_and_provenance_is_ignored() -> None:
    rep = _with(('provenance',), {'host': 'another machine'})
    rep['new_key_of_a_later_version'] = 1          # reports may gain keys
    rep['features']['lobe_1']['iterations'] = 4     # the solver's path is not compared
    assert compare_reports(rep, GOLD) == []
    assert 'provenance' not in golden_of(GOLD)


@pytest.mark.parametrize('arcsec, ok', [(0.49, True), (0.51, False), (-0.49, True),
                                        (-0.51, False)])
def test_angle_tolerance_both_sides_and_across_360(arcsec: float, ok: bool) -> None:
    """359.9999 deg + 0.49" wraps past 360: still 0.49" away, not 359.99 deg."""
    new = (GOLD['features']['lobe_1']['angle_deg'] + arcsec / 3600) % 360
    diffs = compare_reports(_with(('features', 'lobe_1', 'angle_deg'), new), GOLD,
                            angle_tol_arcsec=0.5)
    assert (diffs == []) is ok
    if not ok:
        assert 'features.lobe_1.angle_deg' in diffs[0] and 'arcsec' in diffs[0]


@pytest.mark.parametrize('path, value, ok', [
    (('features', 'lobe_1', 'lift_error_um', 'rms'), 0.5 + 0.049, True),   # nested _um
    (('features', 'lobe_1', 'lift_error_um', 'rms'), 0.5 + 0.051, False),
    (('features', 'lobe_1', 'lift_offset_mm'), 0.5 + 0.049e-3, True),      # mm in µm
    (('features', 'lobe_1', 'lift_offset_mm'), 0.5 + 0.051e-3, False),
    (('features', 'lobe_1', 'angle_std_deg'), 1.09e-2, True),              # 10 % rule
    (('features', 'lobe_1', 'angle_std_deg'), 1.2e-2, False),
    (('features', 'lobe_1', 'samples_used'), 3599, False),                 # counts exact
    (('features', 'lobe_1', 'status'), 'failed', False),
    (('features', 'lobe_1', 'sensitive_point_levels_mm'), [1.0, 2.00004], True),
    (('features', 'lobe_1', 'sensitive_point_levels_mm'), [1.0], False),
    (('camshaft_id',), 'X-2', False),
    # a verdict check's numbers are in its own unit: a noise-free lift error of 3e-11 um
    # on one machine and 4e-11 um on another agree (it was compared to 1e-12 relative)
    (('features', 'lobe_1', 'verdict', 'checks', 0, 'value'), 3e-11 + 0.049, True),
    (('features', 'lobe_1', 'verdict', 'checks', 0, 'value'), 3e-11 + 0.051, False),
    (('features', 'lobe_1', 'verdict', 'checks', 1, 'value'), 0.1 + 0.49 / 3600, True),
    (('features', 'lobe_1', 'verdict', 'checks', 1, 'margin'), 0.4 - 0.51 / 3600, False),
    # an area in mm deg is compared relatively (1e-6), not as an angle in arcsec
    (('features', 'lobe_1', 'area_mm_deg'), 448.49 * (1 + 0.9e-6), True),
    (('features', 'lobe_1', 'area_mm_deg'), 448.49 * (1 + 1.1e-6), False),
])
def test_value_rules(path: tuple, value: object, ok: bool) -> None:
    diffs = compare_reports(_with(path, value), GOLD, angle_tol_arcsec=0.5, lift_tol_um=0.05)
    assert (diffs == []) is ok, diffs


def test_missing_and_extra_features_and_keys_are_named() -> None:
    rep = copy.deepcopy(GOLD)
    del rep['features']['dowel_pin']
    del rep['features']['lobe_1']['phase_deg']
    rep['features']['lobe_9'] = {'kind': 'lobe'}
    diffs = compare_reports(rep, GOLD)
    assert 'features.dowel_pin: missing (the golden report has it)' in diffs
    assert 'features.lobe_9: not in the golden report' in diffs
    assert any(d.startswith('features.lobe_1.phase_deg: missing') for d in diffs)


def test_assert_report_matches_lists_every_difference() -> None:
    rep = _with(('features', 'lobe_1', 'angle_deg'), 1.0)
    rep['features']['lobe_1']['status'] = 'failed'
    with pytest.raises(AssertionError) as info:
        assert_report_matches(rep, GOLD, angle_tol_arcsec=2, lift_tol_um=0.1)
    text = str(info.value)
    assert 'in 2 place(s)' in text and 'angles within 2 arcsec' in text
    assert "features.lobe_1.status: got 'failed', golden 'ok'" in text


def test_golden_command_round_trip(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / 'g.json'
    assert main(['golden', str(BAG), str(out)]) == 0
    gold = json.loads(out.read_text())
    assert len(gold['features']) == 5 and 'provenance' not in gold
    assert main(['golden', str(BAG), str(out)]) == 2              # refuses to overwrite
    assert 'or --force' in capsys.readouterr().err
    from cam_metrology.offline.analyze import analyze_report
    assert_report_matches(analyze_report(BAG), gold, angle_tol_arcsec=0.01, lift_tol_um=1e-3)


@pytest.mark.parametrize('out, expected', [('missing_dir/g.json', 'existing directory'),
                                           ('.', 'not a directory')])
def test_golden_command_bad_out(tmp_path: Path, out: str, expected: str,
                                capsys: pytest.CaptureFixture) -> None:
    target = tmp_path / out
    assert main(['golden', str(BAG), str(target), '--force']) == 2
    assert expected in capsys.readouterr().err


USER_TEST = '''
import json
from pathlib import Path
from cam_metrology.golden import assert_report_matches   # the documented path

def test_lobes_ok(cam_bench_report):
    for fid, f in cam_bench_report['features'].items():
        assert f['status'] == 'ok', fid

def test_matches_golden(cam_bench_bag, cam_bench_report):
    golden_file = Path(__file__).parent / 'golden' / f'{cam_bench_bag.name}.json'
    golden = json.loads(golden_file.read_text())
    assert_report_matches(cam_bench_report, golden, angle_tol_arcsec=0.5, lift_tol_um=0.05)
'''


@pytest.fixture
def user_project(pytester: pytest.Pytester) -> Path:
    """A user's folder: one bag, its golden file and the ten-line test above."""
    bags = pytester.path / 'bags'
    shutil.copytree(BAG, bags / 'part_001')
    (pytester.path / 'golden').mkdir()
    # in a process of its own: pytester restores sys.modules after the test, and a C
    # extension first imported here (numpy's) could not be imported again by later tests
    # of the same worker ("cannot load module more than once per process")
    subprocess.run([sys.executable, '-m', 'cam_metrology', 'golden', str(bags / 'part_001'),
                    str(pytester.path / 'golden' / 'part_001.json')], check=True,
                   capture_output=True, timeout=240)
    pytester.makepyfile(test_user=USER_TEST)
    return bags


def test_plugin_runs_user_tests_over_bags(pytester: pytest.Pytester, user_project: Path) -> None:
    result = pytester.runpytest_subprocess('--cam-bench-bags', str(user_project), '-v')
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(['*test_lobes_ok?part_001? PASSED*'])


def test_plugin_by_its_module_path_without_autoload(
        pytester: pytest.Pytester, user_project: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``-p cam_metrology.pytest_plugin`` (the module path users name) still loads it."""
    monkeypatch.setenv('PYTEST_DISABLE_PLUGIN_AUTOLOAD', '1')
    result = pytester.runpytest_subprocess('-p', 'cam_metrology.pytest_plugin',
                                           '--cam-bench-bags', str(user_project))
    result.assert_outcomes(passed=2)


def test_plugin_failure_shows_the_difference(pytester: pytest.Pytester,
                                             user_project: Path) -> None:
    golden = pytester.path / 'golden' / 'part_001.json'
    doc = json.loads(golden.read_text())
    doc['features']['lobe_2']['angle_deg'] += 2.0 / 3600            # 2 arcsec off
    golden.write_text(json.dumps(doc))
    result = pytester.runpytest_subprocess('--cam-bench-bags', str(user_project))
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(['*features.lobe_2.angle_deg: got *off by -2 arcsec*'])


def test_plugin_without_bags_skips_and_says_how(pytester: pytest.Pytester,
                                                user_project: Path) -> None:
    result = pytester.runpytest_subprocess('-rs')
    result.assert_outcomes(skipped=2)
    result.stdout.fnmatch_lines(['*no bags given: run pytest with --cam-bench-bags DIR*'])


def test_plugin_rejects_a_folder_without_bags(pytester: pytest.Pytester,
                                              user_project: Path) -> None:
    empty = pytester.mkdir('empty')
    result = pytester.runpytest_subprocess('--cam-bench-bags', str(empty))
    assert result.ret != 0
    result.stderr.fnmatch_lines(['*--cam-bench-bags*expected at least one bag*'])


@pytest.mark.parametrize('which, shift_deg, ok', [
    (0, 3.0, True),     # 0.8 um wave: 0.05 um / 0.8 um = 0.0625 rad = 3.58 deg tolerated
    (0, 4.0, False),
    (1, 90.0, True),    # a 0.005 um harmonic is noise: its phase is not a result
])
def test_angles_that_place_a_wave_are_tolerated_by_its_amplitude(which: int, shift_deg: float,
                                                                 ok: bool) -> None:
    gold = copy.deepcopy(GOLD)
    gold['features']['lobe_1']['harmonics'] = [
        {'upr': 37, 'amplitude_um': 0.8, 'phase_deg': 10.0},
        {'upr': 12, 'amplitude_um': 0.005, 'phase_deg': 20.0}]
    new = copy.deepcopy(gold)
    new['features']['lobe_1']['harmonics'][which]['phase_deg'] += shift_deg
    diffs = compare_reports(new, gold, angle_tol_arcsec=0.5, lift_tol_um=0.05)
    assert (diffs == []) is ok, diffs
    # the feature's own angles keep the angle tolerance
    new['features']['lobe_1']['angle_deg'] += 1.0 / 3600
    assert any('angle_deg' in d for d in compare_reports(new, gold, angle_tol_arcsec=0.5,
                                                         lift_tol_um=0.05))


def test_harmonics_are_matched_by_their_upr_not_their_rank() -> None:
    gold = copy.deepcopy(GOLD)
    gold['features']['lobe_1']['harmonics'] = [
        {'upr': 37, 'amplitude_um': 0.8, 'phase_deg': 10.0},
        {'upr': 4, 'amplitude_um': 0.0101, 'phase_deg': 20.0},
        {'upr': 35, 'amplitude_um': 0.0100, 'phase_deg': 30.0}]
    new = copy.deepcopy(gold)
    h = new['features']['lobe_1']['harmonics']
    h[1], h[2] = h[2], h[1]                  # two noise harmonics swap places
    assert compare_reports(new, gold, angle_tol_arcsec=0.5, lift_tol_um=0.05) == []
    h[0]['amplitude_um'] += 0.1              # a real change is still found, by its UPR
    assert any('[upr 37].amplitude_um' in d
               for d in compare_reports(new, gold, angle_tol_arcsec=0.5, lift_tol_um=0.05))
    del h[1]                                 # and a lost harmonic is named
    assert any('[upr 35]: missing' in d
               for d in compare_reports(new, gold, angle_tol_arcsec=0.5, lift_tol_um=0.05))
