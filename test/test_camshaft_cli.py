"""`cam-bench dynamics SCENE` with a `camshaft:` block: the coupled runs and the
camshaft JSON; a bad block is one line naming the key (exit 2)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
SHAFT = {'stations': ['sprocket', 'journal_1', 'lobe_1', 'lobe_2', 'journal_2', 'lobe_3',
                      'lobe_4', 'journal_3'],
         'sections': [{'length': 0.03, 'diameter': 0.03}] * 7,
         'lobe_inertia': 1.4e-5, 'damping_ratio': 0.05, 'journal_radius': 0.012,
         'friction': {'cam_follower': {'coefficient': 0.08}, 'bearing': {'coefficient': 0.005}}}


def _scene(tmp_path: Path, shaft: dict) -> Path:
    doc = yaml.safe_load((REPO / 'config' / 'default_scene.yaml').read_text())
    doc['camshaft'] = shaft
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_cli_camshaft_json(tmp_path: Path, capsys) -> None:
    from cam_metrology.cli import main

    out = tmp_path / 'out.json'
    rc = main(['dynamics', str(_scene(tmp_path, SHAFT)), '--rpm', '1500', '--step-deg', '0.5',
               '--json', str(out), '--plot', str(tmp_path / 'p')])
    assert rc == 0
    res = json.loads(out.read_text())
    cs = res['camshaft']
    assert cs['cam_speed_rpm'] == [1500.0] and cs['converged'] == [True]
    assert len(cs['drive_torque_nm']['orders'][0]) == 24
    # four lobes of a two-cylinder engine: order 2 of the cam torque dominates order 1
    orders = cs['drive_torque_nm']['orders'][0]
    assert orders[1] > orders[0]
    # the mean drive torque pays at least the friction (power balance, in N m)
    friction_mean = cs['friction_loss_j_per_rev'][0] / (2 * math.pi)
    assert cs['drive_torque_nm']['mean'][0] > friction_mean > 0
    assert cs['friction_power_w'][0] == pytest.approx(
        cs['friction_loss_j_per_rev'][0] * 1500 / 60, rel=1e-12)
    assert set(cs['lobes']) == {'lobe_1', 'lobe_2', 'lobe_3', 'lobe_4'}
    freqs = cs['natural_frequencies_hz']
    assert len(freqs) == 7 and all(np.diff(freqs) > 0)
    run = res['features']['lobe_1']['runs'][0]
    assert len(run['drive_torque_nm']) == len(run['alpha_deg'])
    assert max(run['friction_torque_nm']) > 0 and 'timing_shift_deg' in run
    assert (tmp_path / 'p' / 'camshaft.png').exists()
    assert 'camshaft run 1500 rpm: drive torque mean' in capsys.readouterr().out


def test_cli_bad_camshaft_block_is_one_line(tmp_path: Path, capsys) -> None:
    from cam_metrology.cli import main

    bad = {**SHAFT, 'drive': {'kind': 'chain', 'stiffness': 0.0}}
    assert main(['dynamics', str(_scene(tmp_path, bad))]) == 2
    err = capsys.readouterr().err.strip()
    assert 'camshaft.drive.stiffness' in err and '\n' not in err


def test_cli_camshaft_sweep_reports_per_speed(tmp_path: Path) -> None:
    from cam_metrology.cli import main

    out = tmp_path / 'out.json'
    assert main(['dynamics', str(_scene(tmp_path, SHAFT)), '--rpm', '1500', '--step-deg', '1',
                 '--sweep', '1500:2000:500', '--json', str(out)]) == 0
    cs = json.loads(out.read_text())['camshaft']
    sw = cs['sweep']
    assert sw['cam_speed_rpm'] == [1500.0, 2000.0]
    assert all(len(v['timing_shift_deg']) == 2 for v in sw['lobes'].values())
    # the sweep's 1500 rpm is the run's 1500 rpm
    assert sw['drive_torque_nm']['mean'][0] == pytest.approx(cs['drive_torque_nm']['mean'][0],
                                                             rel=1e-9)
