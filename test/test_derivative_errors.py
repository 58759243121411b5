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
