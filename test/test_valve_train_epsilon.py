"""Epsilon criterion (methods.md §4.3) and speed sweeps."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.valve_train import SdofParams, simulate
from cam_design.valve_train.epsilon import FAMILIES, assess, epsilon, natural_frequency_hz
from cam_design.valve_train.sweep import parse_range, runs_figure, sweep
from cam_design.valve_train.report import ContactGeometry, run_sdof

from test_valve_train_sdof import BASE, ramp_law


def test_epsilon_magnitudes_of_methods() -> None:
    """M = 0.12 kg, c = 1.2e7 N/m, 1500 rpm: eps = 2.467e-4 (book's c), f_n 1591.5 Hz,
    natural period 5.65 cam degrees (methods.md §4.3)."""
    p = SdofParams(**BASE)
    assert epsilon(p, 1500.0, use_spring=False) == pytest.approx(2.467e-4, rel=1e-3)
    p0 = SdofParams(**{**BASE, 'spring_rate': 0.0})
    assert natural_frequency_hz(p0) == pytest.approx(1591.5, rel=1e-4)
    rep = assess(ramp_law(), p0, 1500.0)
    assert rep.natural_period_deg == pytest.approx(5.65, abs=0.01)


def test_predicted_amplitude_matches_simulation() -> None:
    """Velocity mismatch at the opening on the constant-velocity ramp: predicted
    sqrt(eps) |Delta q'| against the simulated undamped opening transient."""
    law = ramp_law()
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    rep = assess(law, p, 1500.0)
    res = simulate(law, p, 1500.0, step_deg=0.05)
    a_open = res.events.opening
    sel = (res.alpha > a_open) & (res.alpha < a_open + math.radians(8.0))
    u = 1.5 * law(res.alpha[sel]) - p.lash
    q = (p.stiffness * u - p.spring_preload) / (p.stiffness + p.spring_rate)
    amp = (np.max(res.y[sel] - q) - np.min(res.y[sel] - q)) / 2
    assert rep.amplitudes_m[1] == pytest.approx(amp, rel=0.02)


def test_recommendation_changes_with_speed() -> None:
    law = ramp_law()
    p = SdofParams(**BASE)
    slow = assess(law, p, 100.0, allowed_amplitude=1e-5)
    fast = assess(law, p, 6000.0, allowed_amplitude=1e-7)
    assert slow.recommendation == FAMILIES[1]
    assert fast.recommendation != FAMILIES[1]
    assert fast.as_dict()['epsilon'] > slow.as_dict()['epsilon']
    with pytest.raises(InputError, match='allowed_amplitude'):
        assess(law, p, 100.0, allowed_amplitude=0.0)


def test_sweep_jump_speed_bracketed(tmp_path) -> None:
    law = ramp_law()
    p = SdofParams(**BASE)
    res = sweep(law, p, parse_range('1000:2600:100'), step_deg=0.5, tol_rpm=0.5)
    assert res.jump_speed_rpm is not None
    below = simulate(law, p, res.jump_speed_rpm - 1.0, step_deg=0.5, max_revolutions=1)
    above = simulate(law, p, res.jump_speed_rpm + 0.01, step_deg=0.5, max_revolutions=1)
    assert not below.events.separations and above.events.separations
    # the kinematic check (F_spring + F_inertia > 0) gives an upper bound of the same order
    omega_kin = math.sqrt((p.spring_preload + p.spring_rate * 1e-3) / (
        p.mass * 1.5 * abs(law(0.0, 2))))
    assert 0.3 < res.jump_speed_rpm / (omega_kin * 30 / math.pi) < 3
    runs = [run_sdof(law, p, r, step_deg=0.5, geometry=ContactGeometry(0.04))
            for r in (1500.0, 2500.0)]
    fig = runs_figure(runs, 'two speeds')
    assert [len(ax.lines) for ax in fig.axes[:2]] == [2, 2]   # lift and force per run
    out = tmp_path / 'runs.png'
    fig.savefig(out)
    assert out.stat().st_size > 1000
    assert res.as_dict()['jump_speed_rpm'] == res.jump_speed_rpm


@pytest.mark.parametrize('text', ['1:2', 'a:b:c', '0:10:1', '10:5:1', '1:10:0'])
def test_parse_range_rejects(text: str) -> None:
    with pytest.raises(InputError, match='--sweep'):
        parse_range(text)


def test_hertz_stress_flat_and_undercut() -> None:
    """Flat tappet: sigma = 0.418 sqrt(E F / (W rho1)) with rho1 = R0 + h + h'' (2.11);
    an undercut profile (rho1 <= 0) reports no maximum instead of a grid-dependent one."""
    law = ramp_law()
    p = SdofParams(**BASE)
    big = run_sdof(law, p, 1500.0, step_deg=0.5, geometry=ContactGeometry(0.04))
    i = int(np.argmax(big.stress))
    rho1 = 0.04 + law(big.alpha[i]) + law(big.alpha[i], 2)
    expect = 0.418 * math.sqrt(2.06e11 * big.force[i] / (0.012 * rho1))
    assert big.stress[i] == pytest.approx(expect, rel=1e-12)
    assert big.events['max_contact_stress_pa'] == pytest.approx(expect, rel=1e-12)
    small = run_sdof(law, p, 1500.0, step_deg=0.5, geometry=ContactGeometry(0.0165))
    assert small.events['profile_undercut'] is True
    assert small.events['max_contact_stress_pa'] is None
    assert np.all(np.isfinite(small.stress[np.abs(small.alpha) > 0.6]))
