"""Hydraulic valve gear against closed forms and conservation (cam_design.hydraulic).

* Rigid-oil limit: with a nearly incompressible oil and a short pipe, the actuator
  follows the plunger volume for volume: valve lift = (A_p / A_r) h.
* Wave delay: a pressure step at one end of a pipe arrives at the closed far end after
  L / a (a = sqrt(K / rho)) and doubles there (reflection at a closed end).
* Joukowsky: stopping a steady flow v0 at once raises the pressure by rho a v0.
* Steady friction: the pressure drop is Darcy-Weisbach rho f L v^2 / (2 D); a transient
  with friction converges at second order in the reach length, and so does the whole gear.
* Oil volume over a lobe: plunger displacement + refill - relief - leakage - actuator
  swept volume - compression storage = 0, to 1e-7 of the displaced volume.
* HLA leak-down under a constant load: t = 12 mu L s A / (pi d c^3 p) (laminar annulus);
  no net pump-up without separation, pump-up when the train separates.
* Gas force: a constant pressure on the valve head acts as a preload increase.
* Independent solution: on the opening of the benchmark case the product converges at
  second order to the Chebyshev collocation + Radau solution of the same equations
  (benchmarks/hydraulic_reference.py).
* Orifice law: the square-root law above the transition pressure; below it a cubic
  tangent-matched to it (value and slope continuous, slope the analytic derivative of
  the square-root law there), odd in the pressure drop.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.hydraulic.actuation import HydraulicParams, simulate_hydraulic
from cam_design.hydraulic.gas import gas_force, on_cam_angle
from cam_design.hydraulic.lash_adjuster import LashAdjuster, cycle
from cam_design.hydraulic.oil import effective_bulk_modulus, orifice_flow, wave_speed
from cam_design.hydraulic.pipe import Pipe
from cam_design.lift_laws import from_spec

LAW = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lobe')
RHO = 850.0


def _params(**kw) -> HydraulicParams:
    base = dict(plunger_diameter=0.02, actuator_diameter=0.025, pipe_length=0.6,
                pipe_diameter=0.006, mass=0.1, spring_rate=2e4, spring_preload=100.0,
                reaches=8)
    base.update(kw)
    return HydraulicParams(**base)


def test_rigid_oil_limit_valve_follows_the_plunger_volume() -> None:
    prm = _params(actuator_diameter=0.02, pipe_length=0.05, bulk_modulus=1e12, reaches=1,
                  friction=0.0)
    res = simulate_hydraulic(LAW, prm, 300.0)
    expected = prm.plunger_area / prm.actuator_area * LAW(res.alpha, 0)
    assert np.max(np.abs(res.valve_lift - expected)) / expected.max() < 1e-5   # seen 2.4e-6
    assert not res.cavitation


def _run_step(pipe: Pipe, p_left: float, steps: int, q_right_at=lambda i: 0.0):
    b = pipe.impedance
    history = []
    for i in range(steps):
        cp, cm = pipe.c_plus(), pipe.c_minus()
        q0 = (p_left - cm[0]) / b
        qn = q_right_at(i)
        pn = cp[-1] - b * qn
        pipe.step(p_left, q0, pn, qn, cp, cm)
        history.append(pipe.p[-1])
    return np.array(history)


def test_wave_arrives_after_length_over_wave_speed_and_doubles() -> None:
    k = 1.5e9
    a = wave_speed(k, RHO)
    pipe = Pipe(length=2.0, diameter=0.006, wave_speed=a, density=RHO, reaches=20)
    pipe.fill(0.0)
    far = _run_step(pipe, 1.0e5, 40)
    arrival = (int(np.argmax(far > 1.0)) + 1) * pipe.dt
    assert arrival == pytest.approx(2.0 / a, abs=pipe.dt)
    assert far[-1] == pytest.approx(2.0e5, rel=1e-12)


def test_sudden_closure_gives_the_joukowsky_surge() -> None:
    a = wave_speed(1.5e9, RHO)
    pipe = Pipe(length=1.0, diameter=0.006, wave_speed=a, density=RHO, reaches=10)
    v0 = 2.0
    pipe.fill(1.0e6, v0 * pipe.area)
    surge = _run_step(pipe, 1.0e6, 5, q_right_at=lambda i: 0.0)   # valve shut at t = 0
    assert surge[0] - 1.0e6 == pytest.approx(RHO * a * v0, rel=0.02)


def test_steady_friction_is_darcy_weisbach() -> None:
    a = wave_speed(1.5e9, RHO)
    f, length, d, v = 0.03, 3.0, 0.006, 1.5
    pipe = Pipe(length=length, diameter=d, wave_speed=a, density=RHO, friction=f,
                reaches=12)
    q = v * pipe.area
    pipe.fill(0.0, q)
    pipe.p[:] = -pipe.resistance * q * q * np.arange(pipe.reaches + 1)
    _run_step(pipe, 0.0, 50, q_right_at=lambda i: q)
    drop = -pipe.p[-1]
    assert drop == pytest.approx(RHO * f * length * v * v / (2 * d), rel=1e-9)


def _closure_with_friction(reaches: int) -> float:
    """Far-end pressure 1.5 round trips after a valve closes a steady flow smoothly (a
    half-cosine over one round trip), with Darcy friction."""
    a = wave_speed(1.5e9, RHO)
    pipe = Pipe(length=1.0, diameter=0.006, wave_speed=a, density=RHO, friction=0.05,
                reaches=reaches)
    q = 3.0 * pipe.area
    pipe.fill(0.0, q)
    pipe.p[:] = -pipe.resistance * q * q * np.arange(reaches + 1)
    t_close = 2.0 / a

    def closing(i: int) -> float:
        return q * 0.5 * (1.0 + math.cos(math.pi * min((i + 1) * pipe.dt / t_close, 1.0)))

    hist = _run_step(pipe, 0.0, int(round(3.0 / a / pipe.dt)), q_right_at=closing)
    return float(hist[-1])


def test_friction_transient_converges_at_second_order() -> None:
    """Trapezoidal friction along the characteristics: second order (measured 1.80 and
    1.91 between 16, 32 and 64 reaches against 1024)."""
    ref = _closure_with_friction(1024)
    errs = [abs(_closure_with_friction(n) - ref) for n in (16, 32, 64)]
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    assert min(orders) > 1.7, (errs, orders)


def test_valve_gear_converges_at_second_order() -> None:
    """Grid convergence of the whole gear (pipe, trapezoidal chambers and valve, lift-off
    and seat impact inside the step): halving the step divides the change of the valve
    lift and of both pressures by about 4 (measured 3.82, 3.91, 3.94 between 16, 32 and
    64 reaches; a first-order coupling gives 2)."""
    prm = {n: _params(actuator_diameter=0.02, pipe_length=0.3, spring_preload=300.0,
                      reaches=n) for n in (16, 32, 64)}
    runs = {n: simulate_hydraulic(LAW, p, 600.0) for n, p in prm.items()}
    grid = runs[16].alpha
    assert runs[64].seating_velocity is not None and not runs[64].cavitation
    for key in ('valve_lift', 'pump_pressure', 'actuator_pressure'):
        on = {n: np.interp(grid, r.alpha, getattr(r, key)) for n, r in runs.items()}
        ratio = np.abs(on[16] - on[32]).max() / np.abs(on[32] - on[64]).max()
        assert 3.3 < ratio < 4.8, (key, ratio)


def test_valve_gear_converges_to_the_independent_method_of_lines_solution() -> None:
    """The benchmark case (1 m pipe, 300 rpm), the first 40 deg from the base circle
    (lift-off included), against the pipe by Chebyshev collocation (degree 32) and scipy
    Radau with the lift-off as an event: the lift error at 32/64/128 reaches was
    4.64e-8, 1.14e-8, 2.86e-9 m (ratios 4.08, 3.98; pump pressure 2441, 587, 149 Pa),
    i.e. second order towards a solution by a different method."""
    from benchmarks.hydraulic_reference import solve_mol

    def prm(reaches: int) -> HydraulicParams:
        return _params(actuator_diameter=0.02, pipe_length=1.0, spring_preload=300.0,
                       reaches=reaches)

    window = (LAW.support[0] - math.radians(10), LAW.support[0] + math.radians(30))
    runs = {n: simulate_hydraulic(LAW, prm(n), 300.0, alpha_range=window,
                                  record_every=n // 32) for n in (32, 64, 128)}
    alpha = runs[128].alpha                      # every 32-reach step, on all three runs
    ref = solve_mol(LAW, prm(4), 300.0, 32, alpha)
    assert [what for _, what in ref.events] == ['lift-off']
    err = {n: np.abs(r.valve_lift[:alpha.size] - ref.lift).max() for n, r in runs.items()}
    err_p = {n: np.abs(r.pump_pressure[:alpha.size] - ref.pump).max()
             for n, r in runs.items()}
    assert 3.5 < err[32] / err[64] < 4.5 and 3.5 < err[64] / err[128] < 4.5, err
    assert 3.5 < err_p[32] / err_p[64] < 4.5 and 3.5 < err_p[64] / err_p[128] < 4.5, err_p
    assert err[128] < 5e-9                      # m (the lift there is 0.33 mm)


def test_oil_volume_is_conserved_over_a_lobe() -> None:
    """Without cavitation the balance closes to roundoff: the chambers' trapezoidal
    balance uses the same boundary flows as the pipe (measured 9e-9 of the displaced
    volume; the issue asks 1e-6)."""
    prm = _params(leak_conductance=2e-13, check_area=2e-5, supply_pressure=2e5,
                  spring_preload=250.0, spring_rate=4e4)
    res = simulate_hydraulic(LAW, prm, 600.0,
                             alpha_range=(LAW.support[0] - 0.2, LAW.support[1] + 0.6))
    vol = res.volumes
    displaced = prm.plunger_area * LAW(np.array([0.0]), 0)[0]
    assert vol['leak_out'] > 0 and vol['check_in'] > 0 and not res.cavitation
    assert res.valve_lift[-1] == 0.0 and res.seating_velocity is not None   # closed again
    assert abs(vol['residual']) < 1e-7 * displaced


def test_relief_valve_caps_the_pump_pressure_and_conserves_oil() -> None:
    """Here the valve overshoots when the relief caps the pressure and the actuator
    chamber cavitates: held at the vapour pressure, flagged; the collapse of a vapour
    cavity is not volume-exact (measured 2e-4 of the displaced volume)."""
    prm = _params(check_area=2e-5, supply_pressure=2e5, spring_preload=250.0,
                  spring_rate=4e4, relief_pressure=1.2e6, relief_area=2e-5)
    res = simulate_hydraulic(LAW, prm, 600.0,
                             alpha_range=(LAW.support[0] - 0.2, LAW.support[1] + 0.6))
    assert res.volumes['relief_out'] > 0
    assert res.pump_pressure.max() < 1.2e6 * 1.06          # fully open at +5 %
    assert res.cavitation and res.actuator_pressure.min() >= prm.vapour_pressure - 1e-6
    displaced = prm.plunger_area * LAW(np.array([0.0]), 0)[0]
    assert abs(res.volumes['residual']) < 1e-3 * displaced


def test_effective_bulk_modulus_with_air() -> None:
    """One percent of air at 1 bar absolute makes the mixture almost as soft as the air
    (1/K = 0.99/K_oil + x/p); at 100 bar the air has shrunk a hundredfold."""
    k1 = effective_bulk_modulus(1.5e9, 0.01, 1.0e5 * 1.01325)
    assert k1 == pytest.approx(1.0 / (0.99 / 1.5e9 + 0.01 / 1.01325e5), rel=1e-9)
    k100 = effective_bulk_modulus(1.5e9, 0.01, 1.01325e7)
    x = 0.0001 / (0.0001 + 0.99)
    assert k100 == pytest.approx(1.0 / ((1 - x) / 1.5e9 + x / 1.01325e7), rel=1e-9)


def test_orifice_law_is_tangent_matched_at_the_transition() -> None:
    """Value and slope of the orifice flow are continuous at |dp| = dp_lin: one-sided
    difference quotients from either side agree with the square-root law's derivative
    cd A sqrt(2 / rho) / (2 sqrt(dp_lin)) (a secant-matched linear law would be off by a
    factor 2 inside); the flow is odd and the square-root law above the transition."""
    area, rho, cd, dp_lin = 2e-6, 850.0, 0.7, 1.0e4
    slope = cd * area * math.sqrt(2.0 / rho) / (2.0 * math.sqrt(dp_lin))
    q_lin = cd * area * math.sqrt(2.0 * dp_lin / rho)
    h = 1e-3                                                 # Pa
    for sign in (1.0, -1.0):
        edge = sign * dp_lin
        inside = orifice_flow(edge - sign * h, area, rho)
        outside = orifice_flow(edge + sign * h, area, rho)
        assert orifice_flow(edge, area, rho) == pytest.approx(sign * q_lin, rel=1e-12)
        assert inside == pytest.approx(sign * q_lin - slope * h, rel=1e-12)
        assert sign * (orifice_flow(edge, area, rho) - inside) / h \
            == pytest.approx(slope, rel=1e-6)
        assert sign * (outside - orifice_flow(edge, area, rho)) / h \
            == pytest.approx(slope, rel=1e-6)
    assert orifice_flow(4e6, area, rho) == pytest.approx(cd * area * math.sqrt(8e6 / rho),
                                                         rel=1e-12)
    for dp in (3e3, 7e3):
        assert orifice_flow(-dp, area, rho) == -orifice_flow(dp, area, rho)
        assert 0.0 < orifice_flow(dp, area, rho) < q_lin


def test_hla_leak_down_time_matches_laminar_gap_flow() -> None:
    hla = LashAdjuster(plunger_diameter=0.012, clearance=5e-6, gap_length=0.01,
                       viscosity=0.02, spring_force=0.0)
    load, stroke = 800.0, 0.2e-3
    pressure = load / hla.area
    t_closed = 12 * 0.02 * 0.01 * stroke * hla.area / (math.pi * 0.012 * 5e-6 ** 3 * pressure)
    assert hla.leak_down_time(load, stroke) == pytest.approx(t_closed, rel=1e-12)
    t = np.linspace(0.0, t_closed, 2001)
    res = cycle(hla, t, np.full(t.size, load), base_circle=np.zeros(t.size, bool))
    assert res.leak_down == pytest.approx(stroke, rel=1e-9)


def test_hla_no_pump_up_at_low_speed_and_pump_up_when_separated() -> None:
    hla = LashAdjuster()
    t = np.linspace(0.0, 0.04, 4001)                     # one cam revolution at 1500 rpm
    lift = (t > 0.01) & (t < 0.02)
    bc = ~lift
    loaded = np.where(lift, 600.0, 5.0)                  # contact all through the lift
    ok = cycle(hla, t, loaded, base_circle=bc)
    assert ok.leak_down > 0 and not ok.pumped_up and abs(ok.net_extension) < 1e-9
    separated = loaded.copy()
    separated[(t > 0.015) & (t < 0.017)] = 0.0            # the train separates near the nose
    bad = cycle(hla, t, separated, base_circle=bc)
    assert bad.pumped_up and bad.net_extension > 1e-6


def test_constant_gas_pressure_acts_as_a_preload_increase() -> None:
    prm = _params()
    p_gas, d_head = 3.0e5, 0.03
    force = gas_force([0.0, 360.0, 719.0], [p_gas] * 3, d_head)
    fg = math.pi * d_head ** 2 / 4 * p_gas
    with_gas = simulate_hydraulic(LAW, prm, 900.0, gas_force=on_cam_angle(force, 0.0))
    raised = simulate_hydraulic(LAW, _params(spring_preload=100.0 + fg), 900.0)
    assert np.max(np.abs(with_gas.valve_lift - raised.valve_lift)) < 1e-12
    assert with_gas.valve_lift.max() > 1e-3


@pytest.mark.parametrize('kw, key', [
    ({'relief_pressure': 1e5}, 'relief_pressure'),
    ({'pump_volume': -1.0}, 'pump_volume'),
    ({'actuator_volume': -1e-6}, 'actuator_volume'),
    ({'supply_pressure': 5e7}, 'relief_pressure'),         # relief below the supply
    ({'pipe_length': 1e-7}, 'pipe_length'),   # a step so short a pass needs > 5e6 of them
    ({'air_fraction': 1.5}, 'air_fraction'),
    ({'restitution': 2.0}, 'restitution'),
])
def test_bad_parameters_name_the_key(kw: dict, key: str) -> None:
    with pytest.raises(InputError) as info:
        prm = _params(**kw)
        simulate_hydraulic(LAW, prm, 1000.0)
    assert info.value.key == key


def test_a_pump_volume_smaller_than_the_displacement_is_refused() -> None:
    with pytest.raises(InputError) as info:
        simulate_hydraulic(LAW, _params(pump_volume=1e-6), 1000.0)
    assert info.value.key == 'pump_volume'
