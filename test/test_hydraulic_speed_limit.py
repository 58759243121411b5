"""The speed above which the hydraulic valve gear can no longer open the valve fully
(cam_design.hydraulic.speed_limit), against a closed form.

Rigid oil (bulk modulus 1e11 Pa, a 5 cm pipe of one reach, no friction, no leakage): the
actuator follows the plunger volume for volume, y = (A_p/A_r) h, and the pump pressure
that pushes the valve after the cam is

    p(theta, w) = (F0 + c' y + F_gas(theta) + M y'' w^2) / A_r + rho L (A_p/A_pipe) h'' w^2

(valve: M y'' w^2 = A_r p_act - F0 - c' y - F_gas; the pipe's oil column, length L and
area A_pipe, carries the flow A_p w h' and needs rho L / A_pipe times its rate of change
between the pump and the actuator). The relief valve (at the pump) starts to spill when
p exceeds p_relief, so the valve follows the cam up to

    w*^2 = min over theta with the inertia term > 0 of (p_relief - static(theta)) / B(theta)

provided the static part stays below p_relief on the whole lift. The lift law is
h = H cos^4(pi alpha / (2 beta)) (acceleration and jerk continuous), so the quasi-static
closed form holds up to the lift-off transient. Tolerance: the located speed lies in
[w*, 1.015 w*], one-sided because it is where the spill before the peak lift passes
``spill_tol`` = 3e-4 of the displacement: the spill rises from zero at w* and reaches 3e-4
0.7-0.8 % above it (measured located / w* - 1: 0.69 % without gas, 0.72 % with the
blow-down, 0.80 % with the raised preload; 1.6-1.7 % at the default spill_tol 1e-3);
below w* the lift-off transient (the valve set moving against the stiff oil column)
spills 5e-5 to 8e-5, under the threshold; the relief valve opens over 5 % of its
pressure, and the pump pressure exceeds p_relief by < 0.03 % at the limit.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.hydraulic.actuation import HydraulicParams
from cam_design.hydraulic.gas import gas_force, on_cam_angle
from cam_design.hydraulic.speed_limit import hydraulic_sweep
from cam_design.lift_laws.base import LiftLaw


class Cos4Law(LiftLaw):
    """h = H cos^4(w alpha), w = pi / (2 beta), on |alpha| <= beta (h, h', h'', h''' zero
    at the ends)."""

    continuity_order = 3

    def __init__(self, lift: float = 0.008, beta: float = 1.4) -> None:
        self.lift, self.beta = lift, beta

    @property
    def support(self) -> tuple[float, float]:
        return (-self.beta, self.beta)

    def _evaluate(self, alpha: np.ndarray, nu: int) -> np.ndarray:
        w = math.pi / (2 * self.beta)
        c, s = np.cos(w * alpha), np.sin(w * alpha)
        return self.lift * [c ** 4, -4 * w * c ** 3 * s,
                            w * w * (12 * c * c * s * s - 4 * c ** 4),
                            w ** 3 * (24 * c * s ** 3 - 40 * c ** 3 * s)][nu]


LAW = Cos4Law()
GRID = np.arange(2000.0, 5001.0, 500.0)      # rpm
TOL = 3e-4


def _params(**kw) -> HydraulicParams:
    base = dict(plunger_diameter=0.02, actuator_diameter=0.016, pipe_length=0.05,
                pipe_diameter=0.01, mass=0.1, spring_rate=4e4, spring_preload=1000.0,
                bulk_modulus=1e11, friction=0.0, reaches=1, relief_pressure=9e6,
                relief_area=2e-5)
    base.update(kw)
    return HydraulicParams(**base)


def closed_form_rpm(prm: HydraulicParams, gas=None) -> float:
    """w* of the module docstring [rpm], on a 2e5-point grid of the lift."""
    alpha = np.linspace(*LAW.support, 200001)
    ratio = prm.plunger_area / prm.actuator_area
    h, h2 = LAW(alpha, 0), LAW(alpha, 2)
    f_gas = np.zeros(alpha.size) if gas is None else np.array([gas(a) for a in alpha])
    static = (prm.spring_preload + prm.spring_rate * ratio * h + f_gas) / prm.actuator_area
    pipe_area = math.pi * prm.pipe_diameter ** 2 / 4
    inertia = (prm.mass * ratio / prm.actuator_area
               + prm.oil_density * prm.pipe_length * prm.plunger_area / pipe_area) * h2
    assert static.max() < prm.relief_pressure           # the gear opens at low speed
    pos = inertia > 0
    w2 = np.min((prm.relief_pressure - static[pos]) / inertia[pos])
    return math.sqrt(w2) * 30 / math.pi


def _near(located: float | None, truth: float) -> bool:
    """The located speed within [w*, 1.015 w*] (module docstring)."""
    return located is not None and truth < located < 1.015 * truth


def _blow_down():
    """Cylinder pressure 6 bar at the lobe start, falling linearly to 0 at 150 deg crank
    (a 30 mm valve head): about 424 N at the opening."""
    table = gas_force([0.0, 150.0, 700.0], [6e5, 0.0, 0.0], 0.03)
    return on_cam_angle(table, 0.0, LAW.support[0])


def test_no_open_speed_matches_the_rigid_oil_closed_form() -> None:
    prm = _params()
    truth = closed_form_rpm(prm)
    res = hydraulic_sweep(LAW, prm, GRID, spill_tol=TOL)
    lo, hi = res.no_open.bracket
    assert _near(res.no_open.speed, truth)
    assert hi - lo <= 0.5 and lo < res.no_open.speed <= hi
    ok = res.rpm < lo
    # below the limit the valve follows the cam to the rigid-oil lift (1e-3: the stiff
    # oil's compression and the lift-off transient)
    assert np.all(np.abs(res.lift_ratio[ok] - 1.0) < 1e-3)
    assert np.all(res.spill_before_peak[ok] <= TOL)
    assert np.all(res.peak_pump_pressure[ok] < prm.relief_pressure * 1.001)
    assert np.all(res.spill_before_peak[res.rpm > hi] > TOL)
    d = res.as_dict()
    assert d['no_open_speed_rpm'] == res.no_open.speed and d['no_open_bracket_rpm'] == [lo, hi]


def test_a_gas_force_lowers_the_limit_as_the_closed_form_says() -> None:
    prm = _params()
    gas = _blow_down()
    truth = closed_form_rpm(prm, gas)
    assert truth < 0.97 * closed_form_rpm(prm)              # the gas force matters here
    res = hydraulic_sweep(LAW, prm, GRID, gas=gas, spill_tol=TOL)
    assert _near(res.no_open.speed, truth)
    # the force to overcome at the opening: F0 + the gas force at the lift-off, which
    # the stiff oil reaches within the lift's first 10 deg (crank 20 deg)
    opened = np.isfinite(res.opening_force)
    head = math.pi * 0.03 ** 2 / 4
    assert opened.sum() == GRID.size
    assert np.all(res.opening_force > prm.spring_preload + 6e5 * (1 - 20 / 150) * head)
    assert np.all(res.opening_force <= prm.spring_preload + 6e5 * head + 1e-9)


def test_constant_gas_pressure_acts_as_a_preload_increase_on_the_limit() -> None:
    p_gas, head = 4e5, 0.03
    gas = on_cam_angle(gas_force([0.0, 360.0, 719.0], [p_gas] * 3, head), 0.0)
    extra = p_gas * math.pi * head ** 2 / 4
    with_gas = hydraulic_sweep(LAW, _params(), GRID, gas=gas, spill_tol=TOL)
    raised = hydraulic_sweep(LAW, _params(spring_preload=1000.0 + extra), GRID,
                             spill_tol=TOL)
    assert with_gas.no_open.speed == pytest.approx(raised.no_open.speed, abs=0.5)
    assert np.allclose(with_gas.max_lift, raised.max_lift, rtol=0, atol=1e-12)
    truth = closed_form_rpm(_params(spring_preload=1000.0 + extra))
    assert _near(with_gas.no_open.speed, truth)
    assert truth < 0.95 * closed_form_rpm(_params())


def test_gas_force_above_the_relief_pressure_never_opens() -> None:
    """F0 + F_gas above p_relief A_r at the opening: no speed opens the valve; the
    no-open speed is below the range and a note says why."""
    gas = on_cam_angle(gas_force([0.0, 360.0, 719.0], [3e6] * 3, 0.03), 0.0)
    res = hydraulic_sweep(LAW, _params(), [2000.0, 3000.0], gas=gas, spill_tol=TOL)
    assert res.no_open.speed is None and res.no_open.bracket == [None, 2000.0]
    assert 'below the sweep range' in res.no_open.text(2000.0, 3000.0)
    assert any('at any speed' in n for n in res.notes)
    assert np.all(res.max_lift < 0.01 * res.rigid_lift)


def test_a_spring_too_strong_near_the_nose_opens_only_in_a_speed_window() -> None:
    """The spring alone needs more than the relief pressure near the nose, where the
    valve decelerates: static(theta) + B(theta) w^2 <= p_relief holds only for
    w_lo < w < w*, w_lo^2 = max over theta with B < 0 and static > p_relief of
    (static - p_relief)/(-B). The lowest speed fails (below the range, note: at low
    speed), and the note lists as opening again exactly the grid speeds in the window
    (closed form 2291-3410 rpm; grid 1500:4000:250, no speed within 1.5 % of an edge)."""
    prm = _params(spring_preload=800.0, spring_rate=1e5, relief_pressure=8e6)
    alpha = np.linspace(*LAW.support, 200001)
    ratio = prm.plunger_area / prm.actuator_area
    static = (prm.spring_preload + prm.spring_rate * ratio * LAW(alpha, 0)) / prm.actuator_area
    pipe_area = math.pi * prm.pipe_diameter ** 2 / 4
    inertia = (prm.mass * ratio / prm.actuator_area
               + prm.oil_density * prm.pipe_length * prm.plunger_area / pipe_area) * LAW(alpha, 2)
    high = (inertia < 0) & (static > prm.relief_pressure)
    assert not np.any(static[inertia >= 0] > prm.relief_pressure)
    w_lo = math.sqrt(np.max((static[high] - prm.relief_pressure) / -inertia[high])) * 30 / math.pi
    pos = inertia > 0
    w_hi = math.sqrt(np.min((prm.relief_pressure - static[pos]) / inertia[pos])) * 30 / math.pi
    grid = np.arange(1500.0, 4001.0, 250.0)
    assert np.all(np.abs(grid / w_lo - 1) > 0.015) and np.all(np.abs(grid / w_hi - 1) > 0.015)
    res = hydraulic_sweep(LAW, prm, grid, spill_tol=TOL)
    assert res.no_open.bracket == [None, 1500.0]
    assert any('at low speed' in n for n in res.notes)
    again = next(n for n in res.notes if n.startswith('the valve opens fully again at '))
    listed = [float(v) for v in again.split(' at ')[1].split(' rpm')[0].split(', ')]
    assert listed == [g for g in grid if w_lo < g < w_hi]


def test_limit_above_the_range_is_an_open_end() -> None:
    res = hydraulic_sweep(LAW, _params(), [1000.0, 2000.0], spill_tol=TOL)
    assert res.no_open.speed is None and res.no_open.bracket == [2000.0, None]
    assert 'above the sweep range' in res.no_open.text(1000.0, 2000.0)


@pytest.mark.parametrize('rpms, kw, key', [
    ([0.5, 1000.0], {}, '--sweep.LO'),             # a pass would need > 5e6 pipe steps
    (np.arange(20.0, 3000.0, 0.5), {}, '--sweep'),  # the grid's steps exceed the budget
    ([3000.0, 2000.0], {}, 'cam_speed_rpm'),
    ([2000.0], {'spill_tol': 1.5}, 'spill_tol'),
])
def test_bad_sweep_input_names_the_option(rpms, kw, key) -> None:
    with pytest.raises(InputError) as info:
        hydraulic_sweep(LAW, _params(), rpms, **kw)
    assert info.value.key == key


SCENE_VT = """valve_train:
  model: hydraulic
  mass: 0.1
  spring_rate: 2.0e4
  spring_preload: 300.0
  cam_speed_rpm: [400]
  gas:
    crank_deg: [0.0, 150.0, 700.0]
    pressure_pa: [3.0e5, 0.0, 0.0]
    head_diameter: 0.03
    lobe_start_crank_deg: 0.0
  hydraulic:
    plunger_diameter: 0.02
    actuator_diameter: 0.02
    pipe_length: 1.5
    pipe_diameter: 0.006
    relief_pressure: 4.0e6
"""


def test_cli_sweeps_the_hydraulic_scene_with_gas(tmp_path: Path, capsys) -> None:
    """`dynamics --sweep` with model hydraulic and a gas force: per-speed fields in the
    JSON, the sweep's 400 rpm is the --rpm 400 run, the bracket's ends fail / pass as
    the per-speed values say, and the human lines say it."""
    from cam_metrology.cli import main
    from test_hydraulic_model import _scene_text

    scene = tmp_path / 'hyd.yaml'
    scene.write_text(_scene_text(SCENE_VT))
    out = tmp_path / 'sweep.json'
    assert main(['dynamics', str(scene), '--feature', 'lobe_1', '--sweep', '200:800:200',
                 '--json', str(out)]) == 0
    feat = json.loads(out.read_text())['features']['lobe_1']
    sw, run = feat['sweep'], feat['runs'][0]
    assert sw['model'] == 'hydraulic' and sw['sweep_rpm'] == [200.0, 400.0, 600.0, 800.0]
    assert run['gas_force_at_opening_n'] > 0
    i = sw['sweep_rpm'].index(400.0)
    assert sw['max_valve_lift_m'][i] == pytest.approx(run['max_valve_lift_m'], rel=1e-12)
    assert sw['peak_pump_pressure_pa'][i] == pytest.approx(run['peak_pump_pressure_pa'],
                                                           rel=1e-12)
    assert sw['opening_force_n'][i] == pytest.approx(300.0 + run['gas_force_at_opening_n'])
    for name in ('valve_lift_ratio', 'relief_spilled', 'relief_spill_before_peak',
                 'cavitation', 'settled'):
        assert len(sw[name]) == 4
    lo, hi = feat['no_open_bracket_rpm']
    assert feat['jump_speed_rpm'] is None and feat['bounce_onset_rpm'] is None
    tol = sw['spill_tol']
    failing = [s > tol and r < 1 - tol for s, r in
               zip(sw['relief_spill_before_peak'], sw['valve_lift_ratio'])]
    first = failing.index(True)
    assert first > 0 and sw['sweep_rpm'][first - 1] <= lo < hi <= sw['sweep_rpm'][first]
    assert feat['no_open_speed_rpm'] == hi
    text = capsys.readouterr().out
    assert 'lobe_1 sweep 600 rpm (hydraulic): valve lift' in text
    assert f"no-open speed {hi:.1f} rpm" in text
