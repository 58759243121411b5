"""4+N1+N2 valve-train model: reduction to SDOF, surge frequencies, parameters."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.valve_train import SdofParams, simulate
from cam_design.valve_train.mdof import mdof_from_mapping, simulate_mdof

from test_valve_train_sdof import BASE, ramp_law


@pytest.fixture(scope='module')
def law():
    return ramp_law()


def reduced_spec(big: float, p: SdofParams, small: float) -> dict:
    """Extra stiffnesses ``big``, tiny lumped masses, one coil: the SDOF limit (the
    rocker-valve stiffness makes the series stiffness exactly c)."""
    k_rv = 1.0 / (1.0 / p.stiffness - 3.0 / big)
    return {'masses': [small, small, small, p.mass - 3 * small],
            'stiffness': [big, big, big, k_rv],
            'springs': [{'rate': p.spring_rate, 'mass': 1e-6, 'coils': 1,
                         'preload_share': 1.0}],
            'follower_rate': 0.0, 'follower_preload': 1e-3}


def test_mdof_reduces_to_sdof(law) -> None:
    p = SdofParams(**BASE)
    sdof = simulate(law, p, 1500.0, step_deg=0.1)
    errs = []
    for big, small in ((1e9, 1e-3), (1e10, 1e-5)):
        res = simulate_mdof(law, mdof_from_mapping(reduced_spec(big, p, small), p), 1500.0,
                            step_deg=0.1, span_deg=140.0, method='Radau', rtol=1e-7,
                            atol=1e-11)
        ys = np.interp(res.alpha, sdof.alpha, sdof.y)
        errs.append(float(np.max(np.abs(ys - res.y))))
    assert errs[1] < 0.2 * errs[0]
    assert errs[1] < 1e-5 * np.max(sdof.y)


def test_surge_frequencies_of_lumped_chain() -> None:
    """N masses m/N between N+1 springs (N+1)c', both ends fixed:
    f_j = (1/pi) sqrt(k_e/m_e) sin(j pi / (2 (N+1)))."""
    p = SdofParams(**BASE)
    n, rate, mass = 8, 1.2e4, 0.03
    mp = mdof_from_mapping({'springs': [{'rate': rate, 'mass': mass, 'coils': n,
                                         'preload_share': 1.0}]}, p)
    from cam_design.valve_train.mdof import MdofAssembly
    surge = np.array(MdofAssembly(mp).surge_hz[0])
    ke, me = (n + 1) * rate, mass / n
    j = np.arange(1, n + 1)
    exact = np.sqrt(ke / me) * np.sin(j * math.pi / (2 * (n + 1))) / math.pi
    assert np.allclose(surge, exact, rtol=1e-10)
    # continuous spring limit f1 = (1/2) sqrt(rate/mass), approached from below
    assert 0.93 < surge[0] / (0.5 * math.sqrt(rate / mass)) < 1.0


def test_default_mdof_runs_and_reports(law) -> None:
    p = SdofParams(**BASE)
    mp = mdof_from_mapping(None, p)
    assert mp.n_dof == 4 + 8 + 8
    assert mp.series_stiffness == pytest.approx(p.stiffness)
    res = simulate_mdof(law, mp, 1500.0, step_deg=0.2, span_deg=180.0)
    assert np.all(np.isfinite(res.y)) and res.events['opening_deg'] is not None
    assert res.events['closing_deg'] == pytest.approx(58.0, abs=1.0)
    assert res.natural_frequencies_hz.size == mp.n_dof
    assert np.all(res.cam_force >= 0)


@pytest.mark.parametrize('spec, key', [
    ({'masses': [1, 2, 3]}, 'valve_train.mdof.masses'),
    ({'stiffness': [1e7, 1e7, -1, 1e7]}, 'valve_train.mdof.stiffness[2]'),
    ({'springs': [{'rate': 1e4, 'mass': 0.02, 'coils': 0}]}, 'valve_train.mdof.springs[0].coils'),
    ({'springs': [{'rate': -1, 'mass': 0.02}]}, 'valve_train.mdof.springs[0].rate'),
    ({'bogus': 1}, 'valve_train.mdof.bogus'),
])
def test_invalid_mdof_named(spec: dict, key: str) -> None:
    with pytest.raises(InputError) as info:
        mdof_from_mapping(spec, SdofParams(**BASE))
    assert key in str(info.value)


def test_sampled_events_of_a_window_that_starts_open() -> None:
    """The ODE paths' event rule (mdof.sampled_events) follows the exact solvers': a revolution
    that starts with the valve in the air opened at its last lift-off, one revolution
    earlier; lift-off and seating between nodes are interpolated. Truth by construction:
    sine lifts over [-210.2, -60.2] and [149.8, 299.8] deg on 0.5 deg nodes."""
    from cam_design.valve_train.mdof import sampled_events

    a = np.linspace(-math.pi, math.pi, 721)
    deg = np.degrees(a)

    def lobe(start: float) -> np.ndarray:   # on the seat: compressed 0.1 mm (penalty)
        x = np.radians(deg - start) * 1.2
        return np.where((x > -0.1) & (x < math.pi + 0.1), 1e-3 * np.sin(x), -1e-4)

    y = np.maximum(lobe(-210.2), lobe(149.8))
    ev = sampled_events(a, y, np.zeros_like(y), np.ones_like(y), y)
    assert ev['opening_deg'] == pytest.approx(-210.2, abs=2e-3)
    assert ev['closing_deg'] == pytest.approx(-60.2, abs=2e-3)
    y = lobe(-100.2)
    ev = sampled_events(a, y, np.zeros_like(y), np.ones_like(y), y)
    assert ev['opening_deg'] == pytest.approx(-100.2, abs=2e-3)
