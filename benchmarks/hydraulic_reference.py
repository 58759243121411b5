"""An independent solution of the hydraulic valve gear's equations for the benchmark:
the pipe by the method of lines (finite volumes, staggered flows) and everything by
scipy's ``solve_ivp`` (Radau) with seat events, instead of the product's method of
characteristics with trapezoidal chambers. Same physics and parameters
(``cam_design.hydraulic.actuation.HydraulicParams``), no air, no cavitation. The finite
volumes are second order in the cell length: the benchmark runs two grids and
extrapolates (Richardson).

State: pump pressure, M cell pressures, M + 1 face flows, actuator pressure, valve lift
y and velocity v (pressures gauge [Pa], flows [m^3/s], SI).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray


def solve_mol(law: Any, prm: Any, rpm: float, cells: int, alpha_out: NDArray[np.float64],
              rtol: float = 1e-9) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Valve lift [m] and pump pressure [Pa gauge] at the cam angles ``alpha_out`` [rad]
    (increasing, from the law's support start - 10 deg, where the product starts), with
    the pipe cut into ``cells``."""
    from scipy.integrate import solve_ivp

    from cam_design.hydraulic.actuation import _check, _relief

    if prm.air_fraction != 0.0:
        raise ValueError('the reference models pure oil only')
    omega = rpm * 2 * math.pi / 60
    lo = law.support[0] - math.radians(10)
    t_out = (np.asarray(alpha_out) - lo) / omega
    area = math.pi * prm.pipe_diameter ** 2 / 4
    dx = prm.pipe_length / cells
    k, rho, m = prm.bulk_modulus, prm.oil_density, cells
    ap, ar, g = prm.plunger_area, prm.actuator_area, prm.leak_conductance
    fr = prm.friction / (2 * prm.pipe_diameter * area)
    dist = np.full(m + 1, dx)
    dist[0] = dist[-1] = dx / 2                # chamber to first/last cell centre

    def rhs(t: float, s: NDArray[np.float64], seated: bool) -> NDArray[np.float64]:
        alpha = lo + omega * t
        h, h1 = float(law(alpha, 0)), float(law(alpha, 1))
        pp, pc, q, pa, y, v = s[0], s[1:m + 1], s[m + 1:2 * m + 2], s[2 * m + 2], \
            s[2 * m + 3], s[2 * m + 4]
        left = np.concatenate(([pp], pc))
        right = np.concatenate((pc, [pa]))
        dq = area / rho * (left - right) / dist - fr * q * np.abs(q)
        dpc = k / (area * dx) * (q[:-1] - q[1:])
        vp = prm.pump_volume - ap * h
        dpp = k / vp * (ap * omega * h1 - q[0] - g * pp + _check(pp, prm) - _relief(pp, prm))
        va = prm.actuator_volume + ar * y
        vel = 0.0 if seated else v
        dpa = k / va * (q[-1] - ar * vel - g * pa)
        if seated:
            dy = dv = 0.0
        else:
            dy = v
            dv = (ar * pa - prm.spring_preload - prm.spring_rate * y
                  - prm.valve_damping * v) / prm.mass
        return np.concatenate(([dpp], dpc, dq, [dpa, dy, dv]))

    def lift_off(t: float, s: NDArray[np.float64], seated: bool) -> float:
        return ar * s[2 * m + 2] - prm.spring_preload

    def touch(t: float, s: NDArray[np.float64], seated: bool) -> float:
        return s[2 * m + 3] if s[2 * m + 4] < 0 else 1.0

    # Jacobian pattern: each pressure couples to its two faces, each face to its two
    # pressures; the chambers to the end faces, the valve and the actuator pressure
    n = 2 * m + 5
    pattern = np.zeros((n, n), dtype=bool)
    for j in range(m):                    # cell j: faces j, j + 1
        pattern[1 + j, [m + 1 + j, m + 2 + j]] = True
    for kf in range(m + 1):               # face kf: pressures left/right, itself
        left = 0 if kf == 0 else kf
        right = 2 * m + 2 if kf == m else kf + 1
        pattern[m + 1 + kf, [left, right, m + 1 + kf]] = True
    pattern[0, [0, m + 1]] = True
    pattern[2 * m + 2, [2 * m + 1, 2 * m + 2, 2 * m + 3, 2 * m + 4]] = True
    pattern[2 * m + 3, 2 * m + 4] = True
    pattern[2 * m + 4, [2 * m + 2, 2 * m + 3, 2 * m + 4]] = True
    lift_off.terminal, lift_off.direction = True, 1     # type: ignore[attr-defined]
    touch.terminal, touch.direction = True, -1          # type: ignore[attr-defined]
    state = np.zeros(2 * m + 5)
    state[:m + 1] = prm.supply_pressure
    state[2 * m + 2] = prm.supply_pressure
    t, t_end, seated = 0.0, float(t_out[-1]), True
    out = np.zeros_like(t_out)
    pump = np.zeros_like(t_out)
    while t < t_end:
        event = lift_off if seated else touch
        sol = solve_ivp(rhs, (t, t_end), state, method='Radau', rtol=rtol,
                        atol=np.concatenate((np.full(m + 1, 1e-3), np.full(m + 1, 1e-16),
                                             [1e-3, 1e-14, 1e-12])),
                        events=event, args=(seated,), dense_output=True,
                        jac_sparsity=pattern)
        if not sol.success:
            raise RuntimeError(sol.message)
        t_stop = float(sol.t[-1])
        sel = (t_out >= t) & (t_out <= t_stop)
        if np.any(sel):
            dense = sol.sol(t_out[sel])
            pump[sel] = dense[0]
            if not seated:
                out[sel] = dense[2 * m + 3]
        state = sol.y[:, -1].copy()
        if sol.status == 1:          # an event: switch the valve's mode
            if seated:
                seated = False
            else:
                state[2 * m + 3] = 0.0
                state[2 * m + 4] = -prm.restitution * state[2 * m + 4]
                seated = state[2 * m + 4] <= 1e-9
                if seated:
                    state[2 * m + 4] = 0.0
            t = t_stop + 1e-12
        else:
            t = t_end
    return np.maximum(out, 0.0), pump
