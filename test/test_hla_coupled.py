"""The hydraulic lash adjuster coupled into the SDOF and MDOF trains
(cam_design.hydraulic.hla_coupled, scene ``valve_train.hla``).

* Leak-down under a constant load, through the coupled train: with the cam held at a
  lift and no spring rate the plunger carries F0, and its extension falls at the rate
  of laminar flow through the plunger gap, X' = -pi d c^3 dp / (12 mu L A) with
  dp = (r F0 - F_s)/A - p_g (closed form).
* Low speed, many revolutions: the leak-down of each lift is refilled on the base
  circle and no more: the extension's change per revolution dies out, the valve seats.
  The leak-down of the last revolution equals the gap-flow integral of the recorded
  chamber pressure.
* Overspeed: the train separates near the nose, the unloaded plunger refills during the
  lift: pump-up, the valve held off its seat on the base circle (reported).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.hydraulic.hla_coupled import (_Train, hla_from_mapping, integrate,
                                              simulate_hla)
from cam_design.hydraulic.lash_adjuster import LashAdjuster
from cam_design.lift_laws.registry import from_spec
from cam_design.valve_train.params import SdofParams

LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lift_law')
REPO = Path(__file__).resolve().parent.parent


def _params(**kw) -> SdofParams:
    base = dict(mass=0.12, stiffness=1.2e7, damping=60.0, spring_rate=3.0e4,
                spring_preload=250.0, rocker_ratio=1.5, lash=0.25e-3)
    base.update(kw)
    return SdofParams(**base)


def test_leak_down_of_a_constant_load_through_the_train_is_laminar_gap_flow() -> None:
    hla = LashAdjuster(plunger_diameter=0.012, clearance=5e-6, gap_length=0.01,
                       viscosity=0.02, spring_force=8.0, gallery_pressure=2e5)
    f0 = 600.0
    prm = _params(spring_rate=0.0, spring_preload=f0)
    tr = _Train(prm, hla)
    u_const = 6e-3                                     # cam held, valve open
    dp = (f0 - hla.spring_force) / hla.area - hla.gallery_pressure
    rate = -math.pi * 0.012 * 5e-6 ** 3 * dp / (12 * 0.02 * 0.01 * hla.area)
    x0 = 1.0e-3
    # the valve in equilibrium with the element force F0, moving with the plunger
    y0 = (u_const - prm.lash + x0 + hla.spring_force / tr.k_oil - f0 * tr.den / tr.k_e)
    t_end = 0.2
    z, fe, _ = integrate(tr, lambda t: (u_const, 0.0), np.linspace(0.0, t_end, 41),
                         np.array([y0, rate, x0]), rtol=1e-11)
    assert np.allclose(fe, f0, rtol=2e-5)          # a small train vibration about F0
    sunk = x0 - z[2, -1]
    assert sunk == pytest.approx(-rate * t_end, rel=1e-6)
    # the standalone element's closed form: the same time for this stroke
    assert hla.leak_down_time(f0 - hla.spring_force - hla.gallery_pressure * hla.area,
                              sunk) == pytest.approx(t_end, rel=1e-6)


def test_no_pump_up_at_low_speed_over_many_revolutions() -> None:
    hla = LashAdjuster()
    res = simulate_hla(LAW, _params(), hla, 1500.0, revolutions=8)
    assert not res.pumped_up and res.settled
    assert res.base_circle_lift < 0.0                 # on the (penalty) seat
    assert res.leak_down > 1e-7                       # it does leak during the lift ...
    assert res.refill == pytest.approx(res.leak_down, rel=1e-3)   # ... and refills
    assert max(abs(c) for c in res.per_revolution[-4:]) < 1e-9
    # leak-down = gap flow integral of the chamber pressure over the loaded part
    t = (res.alpha - res.alpha[0]) / (1500.0 * math.pi / 30)
    over = np.maximum(res.pressure - hla.gallery_pressure, 0.0)
    expect = hla.gap_conductance / hla.area * float(np.sum(0.5 * (over[1:] + over[:-1])
                                                           * np.diff(t)))
    assert res.leak_down == pytest.approx(expect, rel=2e-3)


def test_pump_up_is_detected_at_overspeed() -> None:
    res = simulate_hla(LAW, _params(), LashAdjuster(), 4000.0, revolutions=3)
    assert res.pumped_up
    assert res.base_circle_lift > 1e-4                # the valve cannot close any more
    assert res.refill > 100 * res.leak_down
    assert np.any(res.element_force[(res.alpha > LAW.support[0])
                                    & (res.alpha < LAW.support[1])] == 0.0)   # separated
    slow = simulate_hla(LAW, _params(), LashAdjuster(), 1500.0, revolutions=2)
    assert np.all(slow.element_force > 0.0)           # never separates at 1500 rpm


def test_mdof_train_with_hla_pumps_up_only_at_overspeed() -> None:
    from cam_design.valve_train.mdof import mdof_from_mapping

    mp = mdof_from_mapping({'springs': [{'rate': 3.0e4, 'mass': 0.05, 'coils': 2,
                                         'preload_share': 1.0}]}, _params())   # 6 DOF
    low = simulate_hla(LAW, _params(), LashAdjuster(), 1500.0, mdof=mp, revolutions=3,
                       step_deg=1.0)
    high = simulate_hla(LAW, _params(), LashAdjuster(), 4000.0, mdof=mp, revolutions=2,
                        step_deg=1.0)
    assert not low.pumped_up and low.base_circle_lift < 0.0
    assert low.refill == pytest.approx(low.leak_down, rel=0.2)
    assert high.pumped_up and high.base_circle_lift > 1e-4


HLA_BLOCK = """  hla:
    plunger_diameter: 0.012
    clearance: 4.0e-6
    revolutions: 3
"""


def _scene(tmp_path, block: str = HLA_BLOCK, name: str = 'hla.yaml') -> Path:
    text = (REPO / 'config' / 'default_scene.yaml').read_text()
    i = text.index('  cam_speed_rpm:')
    path = tmp_path / name
    path.write_text(text[:i] + block + text[i:])
    return path


def test_scene_hla_reports_pump_up_in_json_and_human_output(tmp_path, capsys) -> None:
    from cam_metrology.cli import main

    out = tmp_path / 'h.json'
    assert main(['dynamics', str(_scene(tmp_path)), '--feature', 'lobe_2', '--rpm',
                 '4000', '--json', str(out)]) == 0
    high = json.loads(out.read_text())['features']['lobe_2']['runs'][0]
    assert high['hla_pump_up'] is True and 'HLA pump-up' in high['note']
    assert high['hla_base_circle_valve_lift_m'] > 1e-4
    capsys.readouterr()
    assert main(['dynamics', str(_scene(tmp_path)), '--feature', 'lobe_2', '--rpm',
                 '1500']) == 0
    text = capsys.readouterr().out
    assert 'HLA no pump-up' in text and 'PUMP-UP' not in text


@pytest.mark.parametrize('edit, key', [
    (('clearance: 4.0e-6', 'clearance: -4.0e-6'), 'valve_train.hla.clearance'),
    (('revolutions: 3', 'revolutions: 1'), 'valve_train.hla.revolutions'),
    (('revolutions: 3', 'chamber_volume: -1.0e-7'), 'valve_train.hla.chamber_volume'),
])
def test_bad_hla_block_names_the_key(tmp_path, edit, key) -> None:
    from cam_metrology.scene.parse import load_scene

    with pytest.raises(InputError) as err:
        load_scene(_scene(tmp_path, HLA_BLOCK.replace(*edit)))
    assert err.value.key == key


def test_hla_refused_with_the_hard_seat_and_the_hydraulic_model(tmp_path) -> None:
    from cam_metrology.scene.parse import load_scene

    hard = HLA_BLOCK + '  seat: {restitution: 0.3}\n'
    text = _scene(tmp_path, hard).read_text()
    # the default scene has a seat block: replace it by the hard seat
    text = text.replace('  seat:                           # penalty seat\n'
                        '    stiffness: 1.0e9              # N/m: k_s\n'
                        '    damping: 2000.0               # N s/m: b_s\n', '')
    path = tmp_path / 'hard.yaml'
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_scene(path)
    assert err.value.key == 'valve_train.hla'
    with pytest.raises(InputError) as err:
        hla_from_mapping({'bore': 1.0})
    assert err.value.key == 'valve_train.hla.bore'


def test_sweep_refuses_a_train_with_an_hla(tmp_path, capsys) -> None:
    """The speed sweep runs the plain SDOF train: with an HLA it would be silently wrong,
    so it is refused naming the option."""
    from cam_metrology.cli import main

    rc = main(['dynamics', str(_scene(tmp_path)), '--feature', 'lobe_2', '--sweep',
               '1000:2000:500'])
    assert rc != 0
    assert '--sweep' in capsys.readouterr().err


def test_a_still_changing_extension_is_not_settled_and_said(monkeypatch) -> None:
    """With a tolerance below the measured change (5e-9 m in the second revolution) the
    run says it is not settled and why, without claiming pump-up."""
    import cam_design.hydraulic.hla_coupled as hc

    monkeypatch.setattr(hc, 'GROWTH_TOL', 1e-12)
    run = hc.run_with_hla(LAW, _params(), {'revolutions': 2}, 1500.0)
    assert run.events['settled'] is False and run.events['hla_pump_up'] is False
    assert 'pump-up is not excluded' in run.events['note']
    assert abs(run.events['hla_extension_change_last_rev_m']) > 1e-12
