"""Exact 4+N1+N2 solver against independent truth: scipy solve_ivp with event restarts
(tight tolerances), modal closed forms, the periodic map; spring margin, coil bind and
the dynamic valve-piston clearance against hand-derived numbers."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial import Polynomial as Poly
from scipy.linalg import eigh

from cam_design import checks
from cam_design.errors import InputError
from cam_design.valve_train import SdofParams
from cam_design.valve_train.examples import DEG, symmetric_law
from cam_design.valve_train.mdof import MdofAssembly, mdof_from_mapping, simulate_mdof
from cam_design.valve_train.cam_input import build_cam_input
from cam_design.valve_train.mdof_exact import CAM, RV, T, V, run_exact, static_state
from cam_design.valve_train.mdof_model import MdofModel as _Model
from cam_design.valve_train.mdof_reference import reference_mdof
from cam_design.valve_train.physics import (coil_bind, dynamic_clearance, spring_margin,
                                            train_checks_from)
from cam_design.valve_train.propagate import FACT as _FACT, NB

from test_valve_train_sdof import BASE, ramp_law

SMALL = {'springs': [{'rate': 1.2e4, 'mass': 0.03, 'coils': 2, 'preload_share': 0.4},
                     {'rate': 1.8e4, 'mass': 0.04, 'coils': 2, 'preload_share': 0.6}],
         'coil_beta': 2e-5}


def const_accel_law(height: float, beta: float):
    """Constant acceleration +-A = 4 H / beta^2 over a rise of beta rad to the nose at 0
    (independent of cam_design.lift_laws)."""
    acc = 4 * height / beta ** 2
    s = Poly([beta, 1.0])                 # angle from the rise start -beta
    a = Poly([0.0, 1.0])
    return symmetric_law([(-beta, -beta / 2, 0.5 * acc * s ** 2),
                          (-beta / 2, 0.0, height - 0.5 * acc * a ** 2)]), acc


@pytest.fixture(scope='module')
def law():
    return ramp_law()


def _window(res, lo_deg: float, hi_deg: float):
    sel = (res.alpha >= math.radians(lo_deg) - 1e-12) & (res.alpha <= math.radians(hi_deg))
    return sel


def test_exact_matches_dop853_penalty_seat(law) -> None:
    """One revolution from rest (penalty seat 1e9 N/m: seat chatter at the opening, the
    lobe, the closing with bounces), 3000 rpm: DOP853 rtol 1e-11 with restarts at
    every switch on the exact lift law, to 1e-9 of the max lift."""
    p = SdofParams(**BASE)
    mp = mdof_from_mapping(SMALL, p)
    res = simulate_mdof(law, mp, 3000.0, step_deg=0.5, max_revolutions=1,
                        span_deg=175.0)
    ref = reference_mdof(law, mp, 3000.0, res.alpha, method='DOP853', rtol=1e-11,
                         atol=1e-15)
    ymax = float(np.max(ref.y))
    err = float(np.max(np.abs(res.y - ref.y)))
    assert ymax > 5e-3
    assert err < 1e-9 * ymax, err
    # the opening seen by both: the last lift-off from the seat before the valve
    # rises above 1 um (the seat chatters before it)
    a_up = res.alpha[np.nonzero(ref.y > 1e-6)[0][0]]
    offs = [a for a, which, r in ref.switches if which == 4 and not r & 4 and a < a_up]
    assert math.radians(res.events['opening_deg']) == pytest.approx(offs[-1], abs=1e-9)
    # and the closing: the first seat contact after the nose
    closes = [a for a, which, r in ref.switches if which == 4 and r & 4 and a > 0]
    assert math.radians(res.events['closing_deg']) == pytest.approx(closes[0], abs=1e-9)
    assert res.events['seating_velocity_m_s'] > 0.1


def test_exact_hard_seat_bounces_match_radau(law) -> None:
    """Hard seat e = 0.6 at 2000 rpm: the seating impacts (angle, velocity: the bounce
    heights follow from them) and the lift between them against Radau rtol 1e-10 with
    terminal events, started from the exact state 0.3 deg before the first seating."""
    p = SdofParams(**BASE, restitution=0.6)
    mp = mdof_from_mapping(SMALL, p)
    asm = MdofAssembly(mp)
    cam = build_cam_input(law, p.rocker_ratio, 0.0, math.radians(0.05), pre=math.radians(1))
    ex = run_exact(asm, cam, 2000.0 * math.pi / 30, max_revolutions=1)
    imp = ex.events.impacts
    assert ex.events.bounce_count >= 5 and len(imp) >= 3
    a_close = imp[0][0]
    sel = cam.uniform & (cam.nodes >= a_close - math.radians(0.3)) & (
        cam.nodes <= imp[2][0] + math.radians(0.1))
    i0 = int(np.nonzero(sel)[0][0])
    ref = reference_mdof(law, mp, 2000.0, cam.nodes[sel], method='Radau', rtol=1e-10,
                         atol=1e-15, start=(ex.z[i0], int(ex.regime[i0])))
    assert len(ref.impacts) >= 3
    for (a_e, v_e), (a_r, v_r) in zip(imp[:3], ref.impacts[:3]):
        assert a_e == pytest.approx(a_r, abs=1e-9)
        assert v_e == pytest.approx(v_r, rel=1e-7)
    y = ex.z[sel][:, V]
    assert float(np.max(np.abs(y - ref.y))) < 1e-12
    # the bounce heights on the grid: max lift between consecutive impacts
    for (a0, _), (a1, _) in zip(ref.impacts[:2], ref.impacts[1:3]):
        between = (cam.nodes[sel] > a0) & (cam.nodes[sel] < a1)
        assert np.max(y[between]) == pytest.approx(np.max(ref.y[between]), rel=1e-8)
        assert np.max(y[between]) > 1e-6


def test_propagator_matches_modal_closed_form() -> None:
    """Undamped regime (cam and rocker contacts closed, valve off the seat), cam held
    at a constant u: x(t) = x_s + sum_i phi_i phi_i^T M (a cos w_i t + b sin w_i t / w_i)
    with (w_i^2, phi_i) from eigh(K, M); the exact propagator to 1e-10 relative."""
    p = SdofParams(**{**BASE, 'damping': 0.0})
    mp = mdof_from_mapping({**SMALL, 'coil_beta': 0.0}, p)
    asm = MdofAssembly(mp)
    model = _Model(asm, 1000.0)
    n = asm.n
    r = CAM | RV
    kk, _, f, _, _ = model.mats(r)
    u = 4e-3
    force = f.copy()
    force[T] += asm.k_c * u
    xs = np.linalg.solve(kk, force)
    w2, phi = eigh(kk, np.diag(asm.m))
    rng = np.random.default_rng(3)
    x0 = xs + 1e-4 * rng.standard_normal(n)
    v0 = 0.3 * rng.standard_normal(n)
    t = 2.3e-3
    w = np.sqrt(w2)
    a_m = phi.T @ (asm.m * (x0 - xs))
    b_m = phi.T @ (asm.m * v0)
    x_t = xs + phi @ (a_m * np.cos(w * t) + b_m * np.sin(w * t) / w)
    v_t = phi @ (-a_m * w * np.sin(w * t) + b_m * np.cos(w * t))
    q = np.zeros(NB)
    q[0] = asm.k_c * u * _FACT[0]
    phis, gq, g1 = model.propagator(r, t, 3)
    z = phis[-1] @ np.concatenate([x0, v0]) + gq[-1] @ q + g1[-1]
    assert np.max(np.abs(z[:n] - x_t)) < 1e-10 * np.max(np.abs(x0))
    assert np.max(np.abs(z[n:] - v_t)) < 1e-10 * np.max(np.abs(v0)) * 10
    # the natural frequencies reported are those eigenvalues (valve off the seat)
    assert np.allclose(asm.natural_frequencies(), w / (2 * math.pi), rtol=1e-12)


def test_shooting_reaches_periodic_state(law) -> None:
    """The periodic state found by Newton shooting (own residual < 1e-12 m) repeats
    after one revolution of the independent reference (DOP853 rtol 1e-11) to 1e-9 m;
    repeated revolutions alone are far from it (weakly damped coils)."""
    p = SdofParams(**BASE)
    mp = mdof_from_mapping(SMALL, p)
    asm = MdofAssembly(mp)
    cam = build_cam_input(law, p.rocker_ratio, 0.0, math.radians(0.5), pre=math.radians(1))
    ex = run_exact(asm, cam, 2000.0 * math.pi / 30, max_revolutions=10, periodic_tol=1e-12)
    assert ex.settled and ex.periodic_residual < 1e-12 and ex.revolutions <= 6
    sel = cam.uniform
    ref = reference_mdof(law, mp, 2000.0, cam.nodes[sel], method='DOP853', rtol=1e-11,
                         atol=1e-15, start=(ex.z[0], int(ex.regime[0])))
    n = asm.n
    assert float(np.max(np.abs(ref.z[-1, :n] - ex.z[0, :n]))) < 1e-9
    assert float(np.max(np.abs(ref.y - ex.z[sel][:, V]))) < 1e-9 * float(np.max(ref.y))
    plain = simulate_mdof(law, mp, 2000.0, step_deg=0.5, max_revolutions=1)
    assert plain.periodic_residual > 1e-7 and not plain.settled


def test_runaway_is_not_settled(law) -> None:
    """Far above the jump speed the valve leaves the cam: not settled, said so."""
    p = SdofParams(**BASE)
    mp = mdof_from_mapping(SMALL, p)
    res = simulate_mdof(law, mp, 9000.0, step_deg=0.5, max_revolutions=4)
    assert not res.settled and res.events['settled'] is False
    assert res.events['valve_leaves_cam'] and res.events['jump']
    assert np.max(res.y) > 2 * (1.5 * 8.3e-3 - 0.25e-3)      # twice the rigid lift k H - x0


def test_static_state_is_equilibrium(law) -> None:
    p = SdofParams(**BASE)
    asm = MdofAssembly(mdof_from_mapping(SMALL, p))
    model = _Model(asm, 100.0)
    z, r = static_state(model, 0.0)
    kk, cc, f, _, _ = model.mats(r)
    assert np.max(np.abs(f - kk @ z[:asm.n])) < 1e-9 * np.max(np.abs(f))
    assert r & CAM
    del cc


# -- physics ------------------------------------------------------------------------
def test_spring_margin_constant_acceleration_closed_form() -> None:
    """Decelerating part of a constant-acceleration lobe: margin
    (F0 + c'(k H/2 - x0)) / (M k A omega^2), smallest at the inflection h = H/2."""
    H, beta = 8e-3, 60 * DEG
    law_, acc = const_accel_law(H, beta)
    p = SdofParams(**BASE)
    omega = 3000 * math.pi / 30
    out = spring_margin(law_, p, omega)
    k, x0 = p.rocker_ratio, p.lash
    expect = (p.spring_preload + p.spring_rate * (k * H / 2 - x0)) / (
        p.mass * k * acc * omega ** 2)
    assert out['spring_margin_min'] == pytest.approx(expect, rel=1e-9)
    assert abs(abs(out['spring_margin_deg']) - 30.0) < 1e-6
    fast = spring_margin(law_, p, omega * math.sqrt(expect) * 1.01)
    assert fast['spring_margin_min'] < 1


def test_coil_bind_by_hand() -> None:
    """d = 4 mm, 7 total coils -> solid 28 mm; free 48 mm, F0 250 N, c' 30 kN/m ->
    installed 48 - 8.333 = 39.667 mm; lift 12 mm -> margin -0.333 mm (binds)."""
    p = SdofParams(**BASE)
    tc = train_checks_from({'wire_diameter': 4e-3, 'total_coils': 7, 'active_coils': 5,
                            'free_length': 48e-3}, None)
    out = coil_bind(tc.spring, p, {'rigid': 11e-3, 'dynamic': 12e-3})
    assert out['spring_solid_length_mm'] == pytest.approx(28.0, rel=1e-12)
    assert out['spring_installed_length_mm'] == pytest.approx(48 - 250 / 30.0, rel=1e-12)
    assert out['coil_bind_rigid_margin_mm'] == pytest.approx(48 - 25 / 3 - 11 - 28, rel=1e-12)
    assert out['coil_bind_dynamic_margin_mm'] == pytest.approx(48 - 25 / 3 - 12 - 28,
                                                               rel=1e-12)
    assert out['coil_gap_dynamic_mm'] == pytest.approx((48 - 25 / 3 - 12 - 28) / 5,
                                                       rel=1e-12)
    assert out['coil_bind'] is True
    tc2 = train_checks_from({'wire_diameter': 4e-3, 'total_coils': 7,
                             'free_length': 48e-3, 'installed_length': 42e-3}, None)
    out2 = coil_bind(tc2.spring, p, {'rigid': 11e-3})
    assert out2['coil_bind_rigid_margin_mm'] == pytest.approx(3.0, rel=1e-12)
    assert out2['coil_bind'] is False


def test_dynamic_clearance_uses_dynamic_lift(law) -> None:
    """With the rigid lift as 'dynamic' lift the clearance equals the static check of
    cam_design.checks on the same samples; with a lift raised by 0.1 mm it drops by
    0.1 mm where the minimum is."""
    p = SdofParams(**BASE)
    tc = train_checks_from(None, {'crank_radius': 0.04, 'rod_length': 0.14,
                                  'clearance': 1.2e-3, 'opening_crank_angle': -0.3})
    a = np.linspace(law.support[0], law.support[1], 4001)
    y = checks.rigid_valve_lift(law(a), p.rocker_ratio, p.lash)
    out = dynamic_clearance(law, p, tc.piston, a, y)
    assert out['min_valve_piston_clearance_mm'] == pytest.approx(
        out['static_min_valve_piston_clearance_mm'], abs=2e-4)
    out2 = dynamic_clearance(law, p, tc.piston, a, np.where(y > 0, y + 1e-4, y))
    assert out2['min_valve_piston_clearance_mm'] == pytest.approx(
        out['min_valve_piston_clearance_mm'] - 0.1, abs=2e-4)


@pytest.mark.parametrize('spring, piston, key', [
    ({'wire_diameter': -1, 'total_coils': 7, 'free_length': 0.05}, None,
     'valve_train.spring.wire_diameter'),
    ({'wire_diameter': 4e-3, 'total_coils': 7}, None, 'valve_train.spring.free_length'),
    ({'wire_diameter': 4e-3, 'total_coils': 20, 'free_length': 0.05}, None,
     'valve_train.spring.free_length'),
    ({'wire_diameter': 4e-3, 'total_coils': 7, 'free_length': 0.05, 'coils': 3}, None,
     'valve_train.spring.coils'),
    (None, {'crank_radius': 0.04, 'rod_length': 0.03, 'clearance': 1e-3,
            'opening_crank_angle': 0.0}, 'valve_train.piston.rod_length'),
    (None, {'crank_radius': 0.04, 'rod_length': 0.14, 'clearance': 1e-3},
     'valve_train.piston.opening_crank_angle'),
])
def test_bad_geometry_named(spring, piston, key) -> None:
    with pytest.raises(InputError) as info:
        train_checks_from(spring, piston)
    assert key in str(info.value)


def test_bad_method_named(law) -> None:
    p = SdofParams(**BASE)
    with pytest.raises(InputError) as info:
        simulate_mdof(law, mdof_from_mapping(SMALL, p), 1500.0, method='RK4')
    assert 'method' in str(info.value)


# -- through the scene and the CLI ----------------------------------------------------
def _scene(tmp_path, **vt_changes):
    import yaml

    from test_dynamics_core import SCENE

    doc = yaml.safe_load(SCENE)
    doc['lobes'] = doc['lobes'][:1]
    doc['valve_train']['cam_speed_rpm'] = [1500.0]
    doc['valve_train'].update(vt_changes)
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_cli_mdof_hard_seat_reports_physics(tmp_path) -> None:
    """The exact MDOF through `cam-bench dynamics`: settled, hard seat accepted, spring
    margin equal to the closed form on the rigid lift, coil bind and the dynamic
    clearance present (and consistent with the reported max valve lift)."""
    import json

    from cam_metrology.cli import main

    spring = {'wire_diameter': 4e-3, 'total_coils': 7, 'active_coils': 5,
              'free_length': 0.05}
    piston = {'crank_radius': 0.04, 'rod_length': 0.14, 'clearance': 1.2e-3,
              'opening_crank_angle': -0.3}
    path = _scene(tmp_path, model='mdof', seat={'restitution': 0.3}, spring=spring,
                  piston=piston)
    out = tmp_path / 'out.json'
    assert main(['dynamics', str(path), '--rpm', '1500', '--step-deg', '0.5',
                 '--json', str(out)]) == 0
    run = json.loads(out.read_text())['features']['lobe_1']['runs'][0]
    assert run['model'] == 'mdof' and run['settled'] is True
    assert run['periodic_residual_m'] < 1e-10
    assert 'note' not in run
    installed = 0.05 - 250.0 / 3.0e4
    assert run['coil_bind_dynamic_margin_mm'] == pytest.approx(
        (installed - run['max_valve_lift_m'] - 0.028) * 1e3, rel=1e-9)
    assert run['spring_margin_min'] > 1.0 and run['spring_margin_deg'] is not None
    assert run['min_valve_piston_clearance_mm'] is not None
    assert isinstance(run['valve_piston_collision'], bool)


def test_scene_spring_key_named(tmp_path, capsys) -> None:
    from cam_metrology.cli import main

    path = _scene(tmp_path, spring={'wire_diameter': 4e-3, 'total_coils': 7})
    assert main(['dynamics', str(path), '--rpm', '1500']) == 2
    assert 'valve_train.spring.free_length' in capsys.readouterr().err
