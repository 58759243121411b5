"""Scene lengths typed in millimetres (16.5 for a 16.5 mm base-circle radius, 0.25 for a
0.25 mm lash) are refused naming the key, the unit the number looks like and the value
in metres; plausible metre values of large engines pass."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from cam_metrology.cli import main
from cam_metrology.host.paths import default_scene_path


def _scene(tmp_path: Path, edit) -> Path:
    doc = yaml.safe_load(Path(default_scene_path()).read_text(encoding='utf-8'))
    edit(doc)
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(doc), encoding='utf-8')
    return path


@pytest.mark.parametrize('edit, key, fix', [
    (lambda d: d.__setitem__('base_circle_radius', 16.5), 'base_circle_radius', '0.0165'),
    (lambda d: d['valve_train'].__setitem__('lash', 0.25), 'valve_train.lash', '0.00025'),
    (lambda d: d['dowel_pin'].__setitem__('pin_radius', 4.0), 'dowel_pin.pin_radius',
     '0.004'),
    (lambda d: d['probe'].__setitem__('radius', 12500.0), 'probe.radius', '0.0125'),
])
def test_millimetre_lengths_are_named(tmp_path: Path, capsys, edit, key, fix) -> None:
    assert main(['scene', 'check', str(_scene(tmp_path, edit))]) == 2
    err = capsys.readouterr().err
    assert f'{key}: got' in err and f'write {fix}' in err, err


def test_large_engine_lengths_pass(tmp_path: Path) -> None:
    def big(d):
        d['base_circle_radius'] = 0.2          # marine diesel camshaft
        d['valve_train']['lash'] = 0.0008
    assert main(['scene', 'check', str(_scene(tmp_path, big))]) == 0
