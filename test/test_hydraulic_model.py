"""The hydraulic valve gear as a scene valve-train model (``valve_train.model: hydraulic``):
scene validation names the key, and the dynamics route (library, node core, CLI) gives
the rigid-oil closed form valve lift = (A_p / A_r) h."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.hydraulic.run import hydraulic_params, run_hydraulic
from cam_design.lift_laws import from_spec
from cam_metrology.scene.parse import parse_scene

REPO = Path(__file__).resolve().parent.parent
LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lobe')

HYDRAULIC_VT = """valve_train:
  model: hydraulic
  mass: 0.1
  spring_rate: 2.0e4
  spring_preload: 300.0
  cam_speed_rpm: [300]
  hydraulic:
    plunger_diameter: 0.02
    actuator_diameter: 0.02
    pipe_length: 0.05
    pipe_diameter: 0.006
    bulk_modulus: 1.0e12
    friction: 0.0
    reaches: 1
"""


def _scene_text(vt: str = HYDRAULIC_VT) -> str:
    text = (REPO / 'config' / 'default_scene.yaml').read_text()
    start = text.index('valve_train:')
    end = text.index('cam_speed_rpm', start)
    end = text.index('\n', end) + 1
    return text[:start] + vt + text[end:]


def test_scene_accepts_the_hydraulic_model_with_only_valve_mass_and_spring() -> None:
    scene = parse_scene(_scene_text())
    assert scene.valve_train.model == 'hydraulic'
    assert scene.valve_train.hydraulic['plunger_diameter'] == 0.02


@pytest.mark.parametrize('edit, key', [
    (('plunger_diameter: 0.02', 'plunger_diameter: -0.02'),
     'valve_train.hydraulic.plunger_diameter'),
    (('    reaches: 1\n', '    reaches: 1\n    relief_pressure: 1.0e5\n'),
     'valve_train.hydraulic.relief_pressure'),
    (('    reaches: 1\n', '    reachs: 3\n'), 'valve_train.hydraulic.reachs'),
    (('    pipe_length: 0.05\n', ''), 'valve_train.hydraulic.pipe_length'),
    (('  mass: 0.1\n', '  mass: 0\n'), 'valve_train.mass'),
    (('  spring_preload: 300.0\n', '  spring_preload: 50.0\n'), 'valve_train.spring_preload'),
    (('    reaches: 1\n', '    reaches: 1.5\n'), 'valve_train.hydraulic.reaches'),
])
def test_bad_hydraulic_block_names_the_scene_key(edit: tuple[str, str], key: str) -> None:
    vt = HYDRAULIC_VT.replace(*edit)
    assert vt != HYDRAULIC_VT
    with pytest.raises(InputError) as err:
        parse_scene(_scene_text(vt))
    assert err.value.key == key


def test_missing_block_is_named() -> None:
    vt = re.sub(r'  hydraulic:\n(    .*\n)+', '', HYDRAULIC_VT)
    with pytest.raises(InputError) as err:
        parse_scene(_scene_text(vt))
    assert err.value.key == 'valve_train.hydraulic'


def test_rigid_oil_run_follows_the_plunger_and_reports_pressures() -> None:
    prm = hydraulic_params({'plunger_diameter': 0.02, 'actuator_diameter': 0.025,
                            'pipe_length': 0.05, 'pipe_diameter': 0.006,
                            'bulk_modulus': 1e12, 'friction': 0.0, 'reaches': 1},
                           mass=0.1, spring_rate=2e4, spring_preload=300.0)
    run = run_hydraulic(LAW, prm, 300.0)
    ratio = prm.plunger_area / prm.actuator_area
    expected = ratio * LAW(run.alpha, 0)
    assert np.max(np.abs(run.lift - expected)) / expected.max() < 1e-4
    assert run.events['rigid_valve_lift_m'] == pytest.approx(ratio * LAW.max_lift(), rel=1e-6)
    # the actuator holds the spring + inertia: mean pressure on the open valve balances
    # F0 + c' y + M y'' (quasi-static at 300 rpm: inertia ~1 % of the spring force)
    i = int(np.argmax(run.lift))
    spring = 300.0 + 2e4 * run.lift[i]
    assert prm.actuator_area * run.actuator_pressure[i] == pytest.approx(spring, rel=0.05)
    assert run.pressure_table().shape == (run.alpha.size, 3)
    assert not run.events['cavitation'] and abs(run.events['oil_volume_residual']) < 1e-6


def test_cli_dynamics_runs_the_hydraulic_scene(tmp_path: Path) -> None:
    scene = tmp_path / 'hyd.yaml'
    scene.write_text(_scene_text())
    proc = subprocess.run([sys.executable, '-m', 'cam_metrology', 'dynamics', str(scene),
                           '--feature', 'lobe_1', '--json', '-'], capture_output=True,
                          text=True, timeout=300, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    run = report['features']['lobe_1']['runs'][0] if 'runs' in report['features'][
        'lobe_1'] else report['features']['lobe_1']
    text = json.dumps(run)
    assert '"model": "hydraulic"' in text and 'peak_pump_pressure_pa' in text
    lobe = parse_scene(_scene_text()).lobe('lobe_1')
    lift = float(re.search(r'"max_valve_lift_m": ([0-9.e+-]+)', text).group(1))
    assert lift == pytest.approx(lobe.lift.max_lift(), rel=1e-3)   # A_p = A_r
