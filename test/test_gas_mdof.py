"""Cylinder-gas force on the MDOF train (``valve_train.gas`` with ``model: mdof``), by the
ODE path of cam_design.hydraulic.hla_coupled (the exact MDOF solver takes no
time-varying external force).

* A constant gas force G is a preload raised by G: one revolution from the base-circle
  equilibrium equals the exact MDOF solver's first revolution with F0 + G (1e-8 of the
  lift; measured 6e-9).
* Through the scene and the CLI: the valve opens later against a blow-down table than
  without it, and the largest gas force is the table's peak times the head area.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cam_design.hydraulic.hla_coupled import simulate_gas_train
from cam_design.lift_laws.registry import from_spec
from cam_design.valve_train.mdof import mdof_from_mapping, simulate_mdof
from cam_design.valve_train.params import SdofParams

LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lift_law')
REPO = Path(__file__).resolve().parent.parent


def _params(**kw) -> SdofParams:
    base = dict(mass=0.12, stiffness=1.2e7, damping=60.0, spring_rate=3.0e4,
                spring_preload=250.0, rocker_ratio=1.5, lash=0.25e-3)
    base.update(kw)
    return SdofParams(**base)


def test_constant_gas_on_the_mdof_train_is_a_preload_increase() -> None:
    g = 120.0
    res = simulate_gas_train(LAW, _params(), 2000.0, mdof=mdof_from_mapping(None, _params()),
                             gas=lambda a: g, revolutions=1, step_deg=0.5, start='rest')
    raised = _params(spring_preload=250.0 + g)
    ex = simulate_mdof(LAW, mdof_from_mapping(None, raised), 2000.0, step_deg=0.5,
                       max_revolutions=1)
    assert np.allclose(res['alpha'], ex.alpha, atol=1e-12, rtol=0.0)
    assert np.max(np.abs(res['y'] - ex.y)) < 1e-8 * float(np.max(ex.y))
    assert np.max(ex.y) > 5e-3


GAS_BLOCK = """  gas:
    crank_deg: [0, 120, 140, 160, 200, 240, 720]
    pressure_pa: [2.0e5, 2.0e5, 8.0e5, 6.0e5, 2.0e5, 1.2e5, 2.0e5]
    head_diameter: 0.03
    back_pressure_pa: 1.0e5
    lobe_start_crank_deg: 140
"""


def test_scene_gas_on_the_mdof_model_runs_through_the_cli(tmp_path) -> None:
    from cam_metrology.cli import main

    text = (REPO / 'config' / 'default_scene.yaml').read_text()
    text = text.replace('  model: sdof ', '  model: mdof ')
    i = text.index('  cam_speed_rpm:')      # one coil mass per spring: seconds, not minutes
    text = (text[:i] + '  mdof:\n    springs: [{rate: 3.0e4, mass: 0.05, coils: 1, '
            'preload_share: 1.0}]\n' + text[i:])
    i = text.index('  cam_speed_rpm:')
    scene = tmp_path / 'gas.yaml'
    scene.write_text(text[:i] + GAS_BLOCK + text[i:])
    out = tmp_path / 'gas.json'
    assert main(['dynamics', str(scene), '--feature', 'lobe_2', '--rpm', '1500',
                 '--json', str(out)]) == 0
    gas = json.loads(out.read_text())['features']['lobe_2']['runs'][0]
    plain = tmp_path / 'plain.json'       # the exact MDOF solver without the gas
    scene.write_text(text)
    assert main(['dynamics', str(scene), '--feature', 'lobe_2', '--rpm', '1500',
                 '--json', str(plain)]) == 0
    plain = json.loads(plain.read_text())['features']['lobe_2']['runs'][0]
    assert gas['model'] == 'mdof' and plain['model'] == 'mdof'
    assert gas['settled'] and gas['periodic_residual_m'] < 1e-6     # seen 1.1e-7 m
    assert abs(gas['gas_force_max_n'] - 7e5 * math.pi * 0.03 ** 2 / 4) < 1e-9
    assert gas['opening_deg'] > plain['opening_deg']
    assert gas['gas_force_at_opening_n'] > 0


def test_constant_gas_with_the_hard_seat_is_a_preload_increase() -> None:
    """SDOF with the hard seat (restitution 0.3, bouncing): the ODE path with a constant
    gas force equals the exact solver's first revolution with F0 + G (measured 1e-13 m)."""
    from cam_design.valve_train.sdof import simulate

    g = 120.0
    hard = _params(restitution=0.3)
    res = simulate_gas_train(LAW, hard, 2000.0, gas=lambda a: g, revolutions=1,
                             step_deg=0.5)
    ex = simulate(LAW, _params(restitution=0.3, spring_preload=250.0 + g), 2000.0,
                  step_deg=0.5, max_revolutions=1)
    a, y = ex.alpha[ex.uniform], ex.y[ex.uniform]
    assert ex.events.bounce_count > 0
    assert np.allclose(res['alpha'], a, atol=1e-12, rtol=0.0)
    assert np.max(np.abs(res['y'] - y)) < 1e-9 * float(np.max(y))
