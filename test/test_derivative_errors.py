"""Velocity and acceleration error of a measured lobe (reconstruction's h', h'' minus the
design's), in the report and judged in the verdict: a lobe ground 0.4 % too high has the
errors 0.004 h' and 0.004 h'' exactly (closed form, the lift scaled)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from cam_metrology.scene.parse import parse_scene
from scene_docs import default_doc

SCALE = 1.004


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.offline.replay import run_offline
    from cam_metrology.simulation.bench import SimParams, probe_lift, write_sim_bag

    doc = default_doc(lobes=1)
    doc['tolerances'] = {'velocity_error_max_mm_per_rad': 0.05,
                         'acceleration_error_max_mm_per_rad2': 1.0}
    scene = parse_scene(yaml.safe_dump(doc))
    bag = tmp_path_factory.mktemp('deriv') / 'high'
    write_sim_bag(bag, scene, SimParams(samples_per_rev=3600, lift_scale=SCALE))
    core = MetrologyCore()
    run_offline(bag, [core])
    return core.report(), probe_lift(scene, 'lobe_1')


def test_scaled_lobe_gives_the_scaled_derivatives(run) -> None:
    """max |h'_measured - h'| = 0.004 max |h'| within 2 %, at its angle within 1 deg;
    the acceleration error 0.004 max |h''| within 5 % (noise-free: the spline's own bias
    only)."""
    report, law = run
    f = report['features']['lobe_1']
    lo, hi = law.support
    grid = np.linspace(lo, hi, 20001)
    vel = (SCALE - 1) * law(grid, 1)
    acc = (SCALE - 1) * law(grid, 2)
    v, a = f['velocity_error_mm_per_rad'], f['acceleration_error_mm_per_rad2']
    assert v['max_abs'] == pytest.approx(np.max(np.abs(vel)) * 1e3, rel=0.02)
    assert abs(v['at_deg']) == pytest.approx(abs(np.degrees(grid[np.argmax(np.abs(vel))])),
                                             abs=1.0)
    assert a['max_abs'] == pytest.approx(np.max(np.abs(acc)) * 1e3, rel=0.05)


def test_judged_in_the_verdict(run) -> None:
    report, law = run
    checks = {c['quantity']: c for c in report['features']['lobe_1']['verdict']['checks']}
    assert checks['velocity_error_mm_per_rad']['result'] == 'fail'   # about 0.057 > 0.05
    assert checks['velocity_error_mm_per_rad']['unit'] == 'mm/rad'
    assert 'acceleration_error_mm_per_rad2' in checks


def test_noise_alone_is_no_derivative_error(tmp_path) -> None:
    """The design ground exactly, 0.2 um probe noise, errors asked by the scene's
    form.derivative_errors: the smoothed error is flat, so both errors are far below what
    the 0.4 % lobe gives (0.055 mm/rad, 0.18 mm/rad^2)."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.offline.replay import run_offline
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    doc = default_doc(lobes=1)
    doc['form'] = {'derivative_errors': True}
    write_sim_bag(tmp_path / 'b', parse_scene(yaml.safe_dump(doc)),
                  SimParams(samples_per_rev=3600, probe_noise=0.2e-6, seed=8))
    core = MetrologyCore()
    run_offline(tmp_path / 'b', [core])
    f = core.report()['features']['lobe_1']
    assert f['velocity_error_mm_per_rad']['max_abs'] < 0.005
    assert f['acceleration_error_mm_per_rad2']['max_abs'] < 0.05


# ------------------------------------------------------- angle zones (tolerances)
BUMP_UM, BUMP_CENTRE_DEG, BUMP_WIDTH_DEG = 5.0, -30.0, 20.0


def _bumped(noise_um: float = 0.1, seed: int = 5):
    """A lobe table (alpha, measured, design) at 0.05 deg steps whose measured lift has
    the bump E sin^4(pi u), u = (alpha - alpha_0) / W in [0, 1], on the rise flank only:
    C3 (its derivatives vanish at both ends), max |e'| = (3 sqrt3 / 4) E pi / W (where
    tan^2(pi u) = 3), max |e''| = 4 E (pi / W)^2 at its middle."""
    from cam_metrology.metrology.synthetic import PolynomialRampCam, bumped_lobe_table

    law = PolynomialRampCam()
    return bumped_lobe_table(law, BUMP_UM * 1e-6, np.radians(BUMP_CENTRE_DEG),
                             np.radians(BUMP_WIDTH_DEG), noise=noise_um * 1e-6,
                             seed=seed), law


def _zones_tolerances():
    from cam_metrology.scene.model import DerivativeZone, Tolerances

    zones = tuple(DerivativeZone(lo, hi, 0.03, 0.5) for lo, hi in
                  ((-80, -50), (-50, -10), (50, 80)))   # -10..50: the lobe's own maxima
    return Tolerances(velocity_error_max_mm_per_rad=0.03,
                      acceleration_error_max_mm_per_rad2=0.5, derivative_error_zones=zones)


def test_error_injected_in_one_zone_is_judged_there_only() -> None:
    """The bump (5 um over 20 deg at -30 deg, 0.1 um noise) gives in the zone -50..-10 deg
    the closed-form maxima (3 sqrt3 / 4) E pi / W = 0.0585 mm/rad within 3 % and
    4 E (pi / W)^2 = 1.62 mm/rad^2 within 6 % (the smoothing spline's bias) at -30 deg
    within 0.5 deg; the other zones and the lobe outside the zones see noise only: < 10 %
    of the bump's velocity error, < 20 % of its acceleration error (one GCV smoothing
    level for the lobe: following the bump lets 0.16-0.25 mm/rad^2 of the 0.1 um noise
    through everywhere); the verdict fails exactly that zone's two checks."""
    from cam_metrology.metrology.derivative_error import derivative_errors
    from cam_metrology.metrology.tolerances import judge_lobe

    table, law = _bumped()
    tol = _zones_tolerances()
    feature = {'status': 'ok', 'runout_fitted': False}
    feature.update(derivative_errors(table, feature, law, tol.derivative_error_zones))
    w = np.radians(BUMP_WIDTH_DEG)
    vel_max = 3 * np.sqrt(3) / 4 * BUMP_UM * 1e-3 * np.pi / w     # mm/rad
    acc_max = 4 * BUMP_UM * 1e-3 * (np.pi / w) ** 2                 # mm/rad^2
    zones = {(z['from_deg'], z['to_deg']): z for z in feature['derivative_error_zones']}
    flank = zones[(-50, -10)]
    assert flank['velocity_error_mm_per_rad']['max_abs'] == pytest.approx(vel_max, rel=0.03)
    assert flank['acceleration_error_mm_per_rad2']['max_abs'] == pytest.approx(acc_max,
                                                                               rel=0.06)
    assert flank['acceleration_error_mm_per_rad2']['at_deg'] == pytest.approx(
        BUMP_CENTRE_DEG, abs=0.5)
    for span, z in zones.items():
        if span != (-50, -10):
            assert z['velocity_error_mm_per_rad']['max_abs'] < 0.1 * vel_max, span
            assert z['acceleration_error_mm_per_rad2']['max_abs'] < 0.2 * acc_max, span
    outside = feature['derivative_error_outside_zones']
    assert outside['velocity_error_mm_per_rad']['max_abs'] < 0.1 * vel_max
    assert outside['acceleration_error_mm_per_rad2']['max_abs'] < 0.2 * acc_max
    # the whole lobe's maximum is the bump's
    assert feature['velocity_error_mm_per_rad']['max_abs'] == pytest.approx(vel_max, rel=0.03)
    verdict = judge_lobe(tol, feature)
    assert verdict['result'] == 'fail'
    assert sorted(f['quantity'] for f in verdict['failed']) == [
        'acceleration_error_mm_per_rad2[-50..-10 deg]', 'velocity_error_mm_per_rad[-50..-10 deg]']
    assert len(verdict['checks']) == 8 and not verdict['not_checked']


def test_zone_limits_override_the_lobe_maximum() -> None:
    """The same bump with a loose flank zone (0.1 mm/rad, 2 mm/rad^2) and the lobe's own
    tight maxima: the part passes (the bump is judged by its zone only); a zone limiting
    only the velocity leaves the acceleration there to the lobe's maximum, which fails."""
    from cam_metrology.metrology.derivative_error import derivative_errors
    from cam_metrology.metrology.tolerances import judge_lobe
    from cam_metrology.scene.model import DerivativeZone, Tolerances

    table, law = _bumped()
    for zone, failed in ((DerivativeZone(-50, -10, 0.1, 2.0), []),
                         (DerivativeZone(-50, -10, 0.1, None),
                          ['acceleration_error_mm_per_rad2'])):
        tol = Tolerances(velocity_error_max_mm_per_rad=0.03,
                         acceleration_error_max_mm_per_rad2=0.5,
                         derivative_error_zones=(zone,))
        feature = {'status': 'ok', 'runout_fitted': False}
        feature.update(derivative_errors(table, feature, law, tol.derivative_error_zones))
        verdict = judge_lobe(tol, feature)
        assert [f['quantity'] for f in verdict['failed']] == failed
        assert verdict['result'] == ('fail' if failed else 'pass')


def test_derivative_zones_in_the_scene() -> None:
    """Scene ``tolerances.derivative_error_zones`` parsed into the lobe's tolerances;
    overlapping zones, a zone with no limit or a zone beyond 180 deg: one line naming the
    key."""
    from cam_design.errors import InputError

    doc = default_doc(lobes=1)
    doc['tolerances'] = {'derivative_error_zones': [
        {'from_deg': -10, 'to_deg': 10, 'acceleration_max_mm_per_rad2': 2},
        {'from_deg': -60, 'to_deg': -30, 'velocity_max_mm_per_rad': 0.02,
         'acceleration_max_mm_per_rad2': 0.5}]}
    tol = parse_scene(yaml.safe_dump(doc)).lobes[0].tolerances
    assert [(z.from_deg, z.to_deg, z.velocity_max_mm_per_rad, z.acceleration_max_mm_per_rad2)
            for z in tol.derivative_error_zones] == [(-60, -30, 0.02, 0.5), (-10, 10, None, 2)]
    assert tol.wants_derivatives()
    from cam_metrology.cli.scene.check import tolerance_text
    assert tolerance_text(tol) == ('velocity error <= 0.02 mm/rad and acceleration error <= '
                                   '0.5 mm/rad² over -60..-30 deg; acceleration error <= '
                                   '2 mm/rad² over -10..10 deg')
    for zones, key in (([{'from_deg': -60, 'to_deg': -20, 'velocity_max_mm_per_rad': 1},
                         {'from_deg': -30, 'to_deg': 0, 'velocity_max_mm_per_rad': 1}],
                        "tolerances.derivative_error_zones: got 'zones -60..-20 and -30..0"),
                       ([{'from_deg': -60, 'to_deg': -20}],
                        'tolerances.derivative_error_zones[0].velocity_max_mm_per_rad'),
                       ([{'from_deg': -60, 'to_deg': 200, 'velocity_max_mm_per_rad': 1}],
                        'tolerances.derivative_error_zones[0].to_deg')):
        doc['tolerances'] = {'derivative_error_zones': zones}
        with pytest.raises(InputError) as err:
            parse_scene(yaml.safe_dump(doc))
        assert str(err.value).startswith(key) and '\n' not in str(err.value)


def test_zones_covering_the_lobe_leave_nothing_to_its_maximum() -> None:
    """Zones over the whole lobe (-80..80 deg): every angle is judged by a zone, the lobe's
    own maximum has no sample left and adds no check (as the lift-error band outside its
    zones); a lobe whose derivative errors could not be computed is not checked, with
    the reason, in every zone."""
    from cam_metrology.metrology.derivative_error import derivative_errors
    from cam_metrology.metrology.tolerances import judge_lobe
    from cam_metrology.scene.model import DerivativeZone, Tolerances

    table, law = _bumped()
    tol = Tolerances(velocity_error_max_mm_per_rad=0.03, derivative_error_zones=(
        DerivativeZone(-80, 0, 0.1), DerivativeZone(0, 80, 0.1)))
    feature = {'status': 'ok', 'runout_fitted': False}
    feature.update(derivative_errors(table, feature, law, tol.derivative_error_zones))
    verdict = judge_lobe(tol, feature)
    assert [c['quantity'] for c in verdict['checks']] == [
        'velocity_error_mm_per_rad[-80..0 deg]', 'velocity_error_mm_per_rad[0..80 deg]']
    assert verdict['result'] == 'pass'
    failed = judge_lobe(tol, {'status': 'ok', 'derivative_error': 'smoothing failed'})
    assert failed['result'] == 'not checked'
    assert [(m['quantity'], m['why']) for m in failed['not_checked']] == [
        ('velocity_error_mm_per_rad[-80..0 deg]', 'smoothing failed'),
        ('velocity_error_mm_per_rad[0..80 deg]', 'smoothing failed'),
        ('velocity_error_mm_per_rad', 'smoothing failed')]


def test_zones_through_a_simulated_bag(tmp_path) -> None:
    """Scene zones end to end (bag -> metrology core -> report, verdict and
    /metrology/values): the lobe ground 0.4 % high has the acceleration error
    0.004 h'' (closed form); over the nose zone -10..10 deg its largest value is
    0.004 max |h''| there, within 5 %, and fails the zone's 0.1 mm/rad^2; the flanks'
    zone -60..-10 deg with 10 mm/rad^2 passes."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.offline.replay import run_offline
    from cam_metrology.simulation.bench import SimParams, probe_lift, write_sim_bag
    from cam_metrology.wire.plots import VALUE_NAMES, report_values

    doc = default_doc(lobes=1)
    doc['tolerances'] = {'derivative_error_zones': [
        {'from_deg': -10, 'to_deg': 10, 'acceleration_max_mm_per_rad2': 0.1},
        {'from_deg': -60, 'to_deg': -10, 'acceleration_max_mm_per_rad2': 10}]}
    scene = parse_scene(yaml.safe_dump(doc))
    write_sim_bag(tmp_path / 'b', scene, SimParams(samples_per_rev=3600, lift_scale=SCALE))
    core = MetrologyCore()
    run_offline(tmp_path / 'b', [core])
    report = core.report()
    f = report['features']['lobe_1']
    grid = np.radians(np.linspace(-10, 10, 2001))
    truth = (SCALE - 1) * np.max(np.abs(probe_lift(scene, 'lobe_1')(grid, 2))) * 1e3
    nose = next(z for z in f['derivative_error_zones'] if z['from_deg'] == -10)
    assert nose['acceleration_error_mm_per_rad2']['max_abs'] == pytest.approx(truth, rel=0.05)
    results = {c['quantity']: c['result'] for c in f['verdict']['checks']}
    assert results == {'acceleration_error_mm_per_rad2[-60..-10 deg]': 'pass',
                       'acceleration_error_mm_per_rad2[-10..10 deg]': 'fail'}
    values = dict(report_values(report))['lobe_1']
    assert values[VALUE_NAMES.index('acceleration_error_max_mm_per_rad2_verdict')] == 0.0


def test_failed_lobe_names_its_derivative_limits_not_checked() -> None:
    """A lobe that failed to measure: every derivative limit it has (a maximum of 0
    included) is listed as not checked with the failure's reason."""
    from cam_metrology.metrology.tolerances import judge_lobe

    tol = _zones_tolerances()
    v = judge_lobe(tol, {'status': 'failed', 'reason': 'too few samples'})
    assert v['result'] == 'not checked'
    assert [(m['quantity'], m['why']) for m in v['not_checked']] == [
        (q, 'feature failed: too few samples') for q in (
            'velocity_error_max_mm_per_rad', 'acceleration_error_max_mm_per_rad2',
            'derivative_error_zones')]
    from cam_metrology.scene.model import Tolerances
    zero = judge_lobe(Tolerances(roundness_max_um=0.0), {'status': 'failed', 'reason': 'x'})
    assert [m['quantity'] for m in zero['not_checked']] == ['roundness_max_um']
