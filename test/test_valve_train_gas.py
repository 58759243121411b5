"""Cylinder-gas force on the valve in the exact SDOF model (``simulate(..., gas=)``).

* A constant gas force G is a preload raised by G: the motion is the same to 1e-12 m.
* A pressure table versus crank angle (piecewise linear, blow-down shape) gives the
  same valve motion as scipy DOP853 (rtol 1e-11) of the same equation with the force
  evaluated exactly, started from the exact solver's periodic state.
* The exact solver does not take a gas force with the hard seat: refused with the key
  (the scene runs that case by the ODE path, test/test_gas_mdof.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.hydraulic.gas import gas_force, on_cam_angle
from cam_design.lift_laws.registry import from_spec
from cam_design.valve_train.params import SdofParams
from cam_design.valve_train.reference import reference_solve
from cam_design.valve_train.sdof import simulate

LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lift_law')


def _params(**kw) -> SdofParams:
    base = dict(mass=0.12, stiffness=1.2e7, damping=60.0, spring_rate=3.0e4,
                spring_preload=250.0, rocker_ratio=1.5, lash=0.25e-3,
                seat_stiffness=1e9, seat_damping=2000.0)
    base.update(kw)
    return SdofParams(**base)


def test_constant_gas_force_is_a_preload_increase() -> None:
    g = 120.0
    with_gas = simulate(LAW, _params(), 3000.0, step_deg=0.5, gas=lambda a: g)
    raised = simulate(LAW, _params(spring_preload=250.0 + g), 3000.0, step_deg=0.5)
    assert np.max(np.abs(with_gas.y - raised.y)) < 1e-12
    assert with_gas.events.opening == pytest.approx(raised.events.opening, abs=1e-12)


def test_blow_down_table_matches_a_scipy_reference() -> None:
    # exhaust blow-down: 8 bar at the valve opening falling to 1 bar, back pressure 1 bar
    crank = [0.0, 120.0, 140.0, 160.0, 200.0, 240.0, 720.0]
    pressure = [2e5, 2e5, 8e5, 6e5, 2e5, 1.2e5, 2e5]
    force = on_cam_angle(gas_force(crank, pressure, 0.03, back_pressure=1e5),
                         phi0_deg=140.0, alpha0=LAW.support[0])
    res = simulate(LAW, _params(), 2500.0, step_deg=0.25, gas=force)
    assert res.settled
    # from 5 deg before the lobe to its end (the stiff seat phase outside costs the reference
    # minutes and no information), started from the exact solver's state there
    lo, hi = LAW.support
    idx = np.flatnonzero(res.uniform & (res.alpha >= lo - math.radians(5))
                         & (res.alpha <= hi))
    ref = reference_solve(LAW, _params(), 2500.0, res.alpha[idx], method='DOP853',
                          rtol=1e-11, atol=1e-15,
                          z0=(float(res.y[idx[0]]), float(res.v[idx[0]])),
                          r0=int(res.regime[idx[0]]), gas=force)
    err = np.max(np.abs(res.y[idx] - ref.y))
    assert err < 1e-9 * float(np.max(res.y))          # seen: 1e-12 relative
    # the gas force delays the opening against the same cam without it
    free = simulate(LAW, _params(), 2500.0, step_deg=0.25)
    assert res.events.opening > free.events.opening


def test_hard_seat_exact_solver_refuses_gas_by_key() -> None:
    """The exact SDOF solver has no gas force with the hard seat (the scene routes that
    case to the ODE path, test/test_gas_mdof.py)."""
    with pytest.raises(InputError) as err:
        simulate(LAW, _params(restitution=0.5), 1500.0, gas=lambda a: 10.0)
    assert err.value.key == 'valve_train.gas'


GAS_BLOCK = """  gas:
    crank_deg: [0, 120, 140, 160, 200, 240, 720]
    pressure_pa: [2.0e5, 2.0e5, 8.0e5, 6.0e5, 2.0e5, 1.2e5, 2.0e5]
    head_diameter: 0.03
    back_pressure_pa: 1.0e5
    lobe_start_crank_deg: 140
"""


def _scene(tmp_path, block: str = GAS_BLOCK):
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml'
            ).read_text()
    i = text.index('  cam_speed_rpm:')
    path = tmp_path / 'gas.yaml'
    path.write_text(text[:i] + block + text[i:])
    return path


def test_scene_gas_block_runs_through_the_cli(tmp_path) -> None:
    import json

    from cam_metrology.cli import main

    scene = _scene(tmp_path)
    out = tmp_path / 'g.json'
    assert main(['dynamics', str(scene), '--feature', 'lobe_2', '--rpm', '2500',
                 '--json', str(out)]) == 0
    run = json.loads(out.read_text())['features']['lobe_2']['runs'][0]
    assert run['gas_force_max_n'] == pytest.approx(7e5 * math.pi * 0.03 ** 2 / 4, rel=1e-9)
    plain = tmp_path / 'p.json'
    assert main(['dynamics', str(_scene(tmp_path, '')), '--feature', 'lobe_2', '--rpm',
                 '2500', '--json', str(plain)]) == 0
    free = json.loads(plain.read_text())['features']['lobe_2']['runs'][0]
    assert run['opening_deg'] > free['opening_deg']      # opens later against the gas


@pytest.mark.parametrize('edit, key', [
    (('    head_diameter: 0.03\n', '    head_diameter: -0.03\n'),
     'valve_train.gas.head_diameter'),
    (('    lobe_start_crank_deg: 140\n', ''), 'valve_train.gas.lobe_start_crank_deg'),
    (('pressure_pa: [2.0e5, ', 'pressure_pa: ['), 'valve_train.gas.pressure_pa'),
])
def test_bad_gas_block_names_the_key(tmp_path, edit, key) -> None:
    from cam_metrology.scene.parse import load_scene

    with pytest.raises(InputError) as err:
        load_scene(_scene(tmp_path, GAS_BLOCK.replace(*edit)))
    assert err.value.key == key


def test_unknown_gas_key_is_a_warning_like_every_scene_key(tmp_path) -> None:
    from cam_metrology.scene.parse import load_scene

    scene = load_scene(_scene(tmp_path, GAS_BLOCK.replace('  gas:\n', '  gas:\n    bore: 0.08\n')))
    assert any('valve_train.gas.bore' in w for w in scene.warnings)
