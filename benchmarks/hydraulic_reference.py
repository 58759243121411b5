"""An independent solution of the hydraulic valve gear's equations for the benchmark:
the pipe by the method of lines and everything by scipy's ``solve_ivp`` (Radau) with
events, instead of the product's method of characteristics with trapezoidal chambers.
Same physics and parameters (``cam_design.hydraulic.actuation.HydraulicParams``): the
pump chamber (V_p = V_p0 - A_p h) with the check valve (orifice law from the supply),
the relief valve and laminar leakage, the pipe dp/dt = -(K/A) dQ/dx,
dQ/dt = -(A/rho) dp/dx - f Q|Q| / (2 D A) whose end pressures are the chambers', the
actuator chamber (V_a = V_a0 + A_r y) and the valve on its seat. Pure oil (entrained
air is refused); the product's cavitation and gas force are not modelled (the benchmark
case has neither).

The pipe by Chebyshev collocation: p and Q at the N + 1 Chebyshev-Gauss-Lobatto points;
the end pressures are the chamber pressures (their balances replace the continuity
equation there), the end flows obey the momentum equation with the one-sided spectral
derivative; spectral accuracy for a smooth solution. The seat impact stops the valve at
once and sends a kink (a jump of dp/dt) down the pipe, which no polynomial resolves: the
top Chebyshev modes it excites would ring undamped and hold Radau to sub-microsecond
steps for the rest of the revolution. A spectral filter (vanishing viscosity) damps
them: the Chebyshev coefficient of degree k decays at the rate
FILTER_RATE N^2 (a/L) (k/N)^FILTER_ORDER. It damps the first three pipe modes (500,
1030, 1600 Hz) at 4e-9, 1e-6 and 5e-5 1/s for N = 32, 1e-10, 2e-8 and 8e-7 1/s for
N = 48 (eigenvalues of the linearised pipe), falling as N^(2 - FILTER_ORDER) for a fixed
mode; the benchmark's sequence of N shows what it and the grid leave.

Switches are located as events and the integration restarted in the new mode, so that
Radau never steps across a kink of the right-hand side: the valve's lift-off (A_r p_a
rises through the preload) and seat impact (y falls through 0; the speed is reversed
times the restitution, below 1e-9 m/s the valve stays held), and the check valve's
opening and closing (p_pump through the supply pressure, +-1e-6 Pa). The cam drive
h(alpha) is a quintic Hermite interpolant of the law's h, h', h'' on nodes every
0.05 deg and at the law's segment junctions (on the benchmark's lobe: 4e-18 m in h,
7e-13 of the largest h' in h'), so that the right-hand side costs microseconds instead
of the law's array evaluation.

State: the pressures (pump chamber, pipe interior, actuator chamber) [Pa gauge], the
flows [m^3/s], the valve lift y [m] and velocity v [m/s]. SI units.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

#: the check valve opens when the pump pressure falls CHECK_HYSTERESIS [Pa] below the
#: supply pressure and closes when it rises as far above it: an event function that is
#: identically zero (the system at rest at the supply pressure) would fire at every step
CHECK_HYSTERESIS = 1e-6

#: spacing of the cam-drive interpolation nodes [deg]
DRIVE_STEP_DEG = 0.05


def cam_drive(law: Any, lo: float, hi: float) -> Callable[[float], tuple[float, float]]:
    """h [m] and dh/dalpha [m/rad] of ``law`` at a cam angle in [lo, hi] [rad], by a
    quintic Hermite interpolant of h, h', h'' on nodes every DRIVE_STEP_DEG and at the
    law's segment junctions (each interval takes its derivatives from the segment that
    holds it, so a jump of h'' at a junction is kept)."""
    step = math.radians(DRIVE_STEP_DEG)
    segs = [s for s in getattr(law, 'segments', ()) if lo < s.hi and s.lo < hi]
    cuts = [x for s in segs for x in (s.lo, s.hi) if lo < x < hi]
    nodes = np.unique(np.concatenate((np.linspace(lo, hi, int(math.ceil((hi - lo) / step))
                                                  + 1), cuts)))
    a, b = nodes[:-1], nodes[1:]
    ends = np.zeros((2, 3, a.size))           # (start/end, derivative order, interval)
    mid = 0.5 * (a + b)
    if segs:
        for s in segs:
            sel = (mid >= s.lo) & (mid <= s.hi)
            for nu in range(3):
                ends[0, nu, sel] = s(a[sel], nu)
                ends[1, nu, sel] = s(b[sel], nu)
    else:
        for nu in range(3):
            ends[0, nu] = law(a, nu)
            ends[1, nu] = law(b, nu)
    dx = b - a
    y0, y1 = ends[0, 0], ends[1, 0]
    d0, d1 = ends[0, 1] * dx, ends[1, 1] * dx
    s0, s1 = ends[0, 2] * dx * dx, ends[1, 2] * dx * dx
    dy = y1 - y0
    coef = np.stack([y0, d0, 0.5 * s0,
                     10 * dy - 6 * d0 - 4 * d1 - 0.5 * (3 * s0 - s1),
                     -15 * dy + 8 * d0 + 7 * d1 + 0.5 * (3 * s0 - 2 * s1),
                     6 * dy - 3 * (d0 + d1) - 0.5 * (s0 - s1)], axis=1)[:, ::-1]
    knots, rows, widths = nodes.tolist(), coef.tolist(), dx.tolist()

    def drive(alpha: float) -> tuple[float, float]:
        i = min(max(bisect.bisect_right(knots, alpha) - 1, 0), len(rows) - 1)
        t = (alpha - knots[i]) / widths[i]
        val = der = 0.0
        for c in rows[i]:
            der = der * t + val
            val = val * t + c
        return val, der / widths[i]

    return drive


def chebyshev_points(n: int, length: float) -> tuple[NDArray[np.float64],
                                                     NDArray[np.float64]]:
    """The n + 1 Chebyshev-Gauss-Lobatto points on [0, length] [m] and the spectral
    first-derivative matrix there [1/m] (Trefethen's construction, rows summing to 0)."""
    k = np.arange(n + 1)
    xi = np.cos(np.pi * k / n)                         # 1 .. -1
    c = np.where((k == 0) | (k == n), 2.0, 1.0) * (-1.0) ** k
    diff = xi[:, None] - xi[None, :] + np.eye(n + 1)
    d = np.outer(c, 1.0 / c) / diff
    d -= np.diag(d.sum(axis=1))
    x = 0.5 * length * (1.0 - xi)                      # 0 .. length
    return x, -2.0 / length * d


def chebyshev_filter(n: int, rate: float, order: int) -> NDArray[np.float64]:
    """Damping matrix [1/s] at the n + 1 Gauss-Lobatto points: the Chebyshev coefficient
    of degree k decays at ``rate`` (k/n)^order (values -> coefficients -> damped ->
    values), a spectral vanishing viscosity acting on the top modes only."""
    k = np.arange(n + 1)
    vand = np.cos(np.pi * np.outer(k, k) / n)          # T_k at the points
    return vand @ np.diag(rate * (k / n) ** order) @ np.linalg.inv(vand)


@dataclass
class Discretisation:
    """Pipe operators: dp_int/dt = -(K/A) dq @ Q - damp @ P (interior pressures),
    dQ/dt = -(A/rho) dp @ P - damp @ Q - fr Q|Q| (all flows); P[0], P[-1] are the
    chambers, Q[0] leaves the pump chamber, Q[-1] enters the actuator chamber."""

    n_p: int
    n_q: int
    dq: NDArray[np.float64]
    dp: NDArray[np.float64]
    damp: NDArray[np.float64]


#: spectral filter of the Chebyshev scheme: rate (FILTER_RATE n^2 a / L) (k/n)^FILTER_ORDER
FILTER_RATE = 1.0
FILTER_ORDER = 12


def discretise(degree: int, length: float, wave_speed: float) -> Discretisation:
    """The pipe of ``length`` [m] on the ``degree`` + 1 Chebyshev points (``wave_speed``
    [m/s] sets the filter's rate)."""
    _, d = chebyshev_points(degree, length)
    damp = chebyshev_filter(degree, FILTER_RATE * degree ** 2 * wave_speed / length,
                            FILTER_ORDER)
    return Discretisation(degree + 1, degree + 1, d[1:-1, :], d, damp)


@dataclass
class Reference:
    """Valve lift [m] and pump pressure [Pa gauge] at the requested cam angles, the
    event times [s from the start] and the integrator's work."""

    lift: NDArray[np.float64]
    pump: NDArray[np.float64]
    events: list[tuple[float, str]]
    steps: int
    rhs_calls: int
    jac_calls: int
    peak_pump: float


def solve_mol(law: Any, prm: Any, rpm: float, degree: int, alpha_out: NDArray[np.float64],
              rtol: float = 1e-10, max_events: int = 2000) -> Reference:
    """The gear ``prm`` driven by ``law`` at ``rpm`` (camshaft), from the first angle of
    ``alpha_out`` [rad] (increasing; at rest, filled at the supply pressure, valve
    seated, as the product starts) to its last, the pipe on the ``degree`` + 1
    Chebyshev points. Radau with
    ``rtol`` and absolute tolerances ``rtol`` times a scale of each variable (pressure
    1 MPa, flow A_p omega max h', lift (A_p/A_r) max h, speed that times omega)."""
    from scipy.integrate import solve_ivp

    from cam_design.hydraulic.actuation import _relief
    from cam_design.hydraulic.oil import orifice_flow

    if prm.air_fraction != 0.0:
        raise ValueError('the reference models pure oil only')
    alpha_out = np.asarray(alpha_out, dtype=float)
    omega = rpm * 2 * math.pi / 60
    lo = float(alpha_out[0])
    t_out = (alpha_out - lo) / omega
    drive = cam_drive(law, lo, float(alpha_out[-1]))
    k, rho = prm.bulk_modulus, prm.oil_density
    disc = discretise(degree, prm.pipe_length, math.sqrt(k / rho))
    n_p, n_q = disc.n_p, disc.n_q
    n = n_p + n_q + 2
    iy, iv = n - 2, n - 1
    area = math.pi * prm.pipe_diameter ** 2 / 4
    ap, ar, g, mass = prm.plunger_area, prm.actuator_area, prm.leak_conductance, prm.mass
    fr = prm.friction / (2 * prm.pipe_diameter * area)
    supply = prm.supply_pressure
    cq, cp = -k / area, -area / rho

    def check_flow(p: float, open_: bool) -> float:
        return orifice_flow(supply - p, prm.check_area, rho) if open_ else 0.0

    def rhs(t: float, s: NDArray[np.float64], seated: bool, open_: bool
            ) -> NDArray[np.float64]:
        h, h1 = drive(lo + omega * t)
        p, q = s[:n_p], s[n_p:n_p + n_q]
        out = np.empty(n)
        out[1:n_p - 1] = cq * (disc.dq @ q)
        out[1:n_p - 1] -= (disc.damp @ p)[1:-1]
        out[n_p:n_p + n_q] = cp * (disc.dp @ p) - fr * q * np.abs(q) - disc.damp @ q
        pp, pa, y, v = float(p[0]), float(p[-1]), float(s[iy]), float(s[iv])
        vel = 0.0 if seated else v
        out[0] = k / (prm.pump_volume - ap * h) * (ap * omega * h1 - float(q[0]) - g * pp
                                                   + check_flow(pp, open_)
                                                   - _relief(pp, prm))
        out[n_p - 1] = k / (prm.actuator_volume + ar * y) * (float(q[-1]) - ar * vel - g * pa)
        if seated:
            out[iy] = out[iv] = 0.0
        else:
            out[iy] = v
            out[iv] = (ar * pa - prm.spring_preload - prm.spring_rate * y
                       - prm.valve_damping * v) / mass
        return out

    base = np.zeros((n, n))
    base[1:n_p - 1, n_p:n_p + n_q] = cq * disc.dq
    base[n_p:n_p + n_q, :n_p] = cp * disc.dp
    base[1:n_p - 1, :n_p] -= disc.damp[1:-1]
    base[n_p:n_p + n_q, n_p:n_p + n_q] -= disc.damp

    def jac(t: float, s: NDArray[np.float64], seated: bool, open_: bool
            ) -> NDArray[np.float64]:
        h, _ = drive(lo + omega * t)
        pp, pa, y, v = float(s[0]), float(s[n_p - 1]), float(s[iy]), float(s[iv])
        q = s[n_p:n_p + n_q]
        vp, va = prm.pump_volume - ap * h, prm.actuator_volume + ar * y
        dpp = 1.0
        dflow = ((check_flow(pp + dpp, open_) - check_flow(pp - dpp, open_))
                 - (_relief(pp + dpp, prm) - _relief(pp - dpp, prm))) / (2 * dpp)
        out = base.copy()
        out[0, 0] += k / vp * (dflow - g)
        out[0, n_p] += -k / vp
        out[n_p - 1, n_p - 1] += -k * g / va
        out[n_p - 1, n_p + n_q - 1] += k / va
        out[n_p - 1, iy] += -k * ar / va ** 2 * (float(q[-1]) - ar * (0.0 if seated else v)
                                                 - g * pa)
        if not seated:
            out[n_p - 1, iv] += -k * ar / va
            out[iy, iv] += 1.0
            out[iv, n_p - 1] += ar / mass
            out[iv, iy] += -prm.spring_rate / mass
            out[iv, iv] += -prm.valve_damping / mass
        idx = np.arange(n_p, n_p + n_q)
        out[idx, idx] += -2.0 * fr * np.abs(q)
        return out

    def lift_off(t: float, s: NDArray[np.float64], seated: bool, open_: bool) -> float:
        return ar * float(s[n_p - 1]) - prm.spring_preload

    def touch(t: float, s: NDArray[np.float64], seated: bool, open_: bool) -> float:
        return float(s[iy])

    def check_switch(t: float, s: NDArray[np.float64], seated: bool, open_: bool) -> float:
        return supply - float(s[0]) + (CHECK_HYSTERESIS if open_ else -CHECK_HYSTERESIS)

    lift_off.terminal, lift_off.direction = True, 1        # type: ignore[attr-defined]
    touch.terminal, touch.direction = True, -1             # type: ignore[attr-defined]
    scale = np.empty(n)
    qscale = ap * omega * max(abs(drive(float(a))[1])
                              for a in np.linspace(lo, float(alpha_out[-1]), 2001))
    scale[:n_p] = 1e6
    scale[n_p:n_p + n_q] = qscale
    scale[iy] = ap / ar * max(abs(drive(float(a))[0])
                              for a in np.linspace(lo, float(alpha_out[-1]), 2001))
    scale[iv] = scale[iy] * omega
    atol = rtol * scale
    state = np.zeros(n)
    state[:n_p] = supply
    t, t_end = 0.0, float(t_out[-1])
    seated, open_ = True, False
    lift = np.zeros_like(t_out)
    pump = np.zeros_like(t_out)
    events: list[tuple[float, str]] = []
    steps = rhs_calls = jac_calls = 0
    peak = supply
    while t < t_end:
        check_switch.terminal = True                       # type: ignore[attr-defined]
        check_switch.direction = -1 if open_ else 1        # type: ignore[attr-defined]
        valve_event = lift_off if seated else touch
        sol = solve_ivp(rhs, (t, t_end), state, method='Radau', rtol=rtol, atol=atol,
                        events=[valve_event, check_switch], args=(seated, open_),
                        dense_output=True, jac=jac)
        if not sol.success:
            raise RuntimeError(f'{sol.message} at t = {sol.t[-1]:.6g} s')
        steps += sol.t.size - 1
        rhs_calls += sol.nfev
        jac_calls += sol.njev
        peak = max(peak, float(sol.y[0].max()))
        t_stop = float(sol.t[-1])
        sel = (t_out >= t) & (t_out <= t_stop)
        if np.any(sel):
            values = sol.sol(t_out[sel])
            pump[sel] = values[0]
            lift[sel] = 0.0 if seated else values[iy]
        state = sol.y[:, -1].copy()
        t = t_stop
        if sol.status != 1:
            break
        if sol.t_events[0].size:                           # the valve switches
            if seated:
                seated = False
                events.append((t, 'lift-off'))
            else:
                state[iy] = 0.0
                state[iv] = -prm.restitution * state[iv]
                seated = state[iv] <= 1e-9
                if seated:
                    state[iv] = 0.0
                events.append((t, 'seat'))
        else:
            open_ = not open_
            events.append((t, 'check opens' if open_ else 'check closes'))
        if len(events) > max_events:
            raise RuntimeError(f'more than {max_events} events by t = {t:.6g} s '
                               '(a switch chattering)')
    return Reference(np.maximum(lift, 0.0), pump, events, steps, rhs_calls, jac_calls, peak)
