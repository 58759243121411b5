"""Cam-driven hydraulic valve actuation: plunger pump -> high-pressure pipe -> actuator
chamber -> valve (single DOF, spring, hard seat, gas force).

Pump chamber (volume V_p = V_p0 - A_p h): (V_p / K) dp/dt = A_p omega h' - Q_pipe
- Q_leak + Q_check - Q_relief; the check valve refills from the supply when the chamber
falls below the supply pressure, the relief valve spills above its opening pressure
(both by the orifice law); leakage is laminar (Q = g p). Actuator chamber (V_a = V_a0 +
A_r y): (V_a / K) dp/dt = Q_pipe - A_r y' - g p. Valve: M y'' = A_r p - F0 - c' y -
b y' - F_gas + R_seat, seated (y = 0) with restitution at impact. The pipe couples the
two chambers by its characteristics (pipe.py); every step is dt = dx / a. The chambers
and the valve are advanced by the trapezoidal rule on the mid-step volume (second order;
the chambers exchange exactly the volume the pipe's balance sees), the lift-off and the
seat impact located inside the step; the actuator chamber is held at the vapour
pressure while a vapour volume takes up its imbalance. K is the effective bulk modulus
with entrained air at the mid-step pressure (extrapolated from the last two steps).
Pressures are gauge [Pa]; the vapour pressure is therefore about -1e5 Pa.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive
from cam_design.hydraulic.oil import P_ATM, effective_bulk_modulus, orifice_flow, wave_speed
from cam_design.hydraulic.pipe import Pipe


@dataclass(frozen=True)
class HydraulicParams:
    """Every dimension of the hydraulic valve gear (SI). Keys as in the scene's
    ``valve_train.hydraulic`` block (docs/hydraulic.md)."""

    plunger_diameter: float          # m
    actuator_diameter: float         # m
    pipe_length: float               # m
    pipe_diameter: float             # m
    mass: float                      # kg, valve + actuator piston
    spring_rate: float               # N/m
    spring_preload: float            # N at the closed valve
    oil_density: float = 850.0       # kg/m^3
    bulk_modulus: float = 1.5e9      # Pa, pure oil
    air_fraction: float = 0.0        # free air volume fraction at atmospheric pressure
    pump_volume: float = 5.0e-6      # m^3, pump chamber dead volume at h = 0
    actuator_volume: float = 5.0e-6  # m^3, actuator chamber volume at y = 0
    supply_pressure: float = 3.0e5   # Pa (gauge), refill through the check valve
    check_area: float = 2.0e-6       # m^2
    relief_pressure: float = 4.0e7   # Pa (gauge)
    relief_area: float = 2.0e-6      # m^2
    leak_conductance: float = 0.0    # m^3/(s Pa), laminar leakage of each chamber
    friction: float = 0.02           # Darcy friction factor of the pipe
    reaches: int = 4                 # pipe reaches (the time step is length/(reaches a))
    valve_damping: float = 0.0       # N s/m
    restitution: float = 0.0         # valve seat
    vapour_pressure: float = -P_ATM + 2.0e3   # Pa (gauge)

    def __post_init__(self) -> None:
        for name in ('plunger_diameter', 'actuator_diameter', 'pipe_length', 'pipe_diameter',
                     'mass', 'oil_density', 'bulk_modulus', 'pump_volume', 'actuator_volume'):
            require_positive(name, getattr(self, name))
        for name in ('spring_rate', 'spring_preload', 'check_area', 'relief_area',
                     'leak_conductance', 'friction', 'valve_damping'):
            require_positive(name, getattr(self, name), allow_zero=True)
        if not 0.0 <= self.restitution <= 1.0:
            raise InputError('restitution', self.restitution, 'a value in [0, 1]')
        if self.relief_pressure <= self.supply_pressure:
            raise InputError('relief_pressure', self.relief_pressure,
                             f'an opening pressure above supply_pressure '
                             f'({self.supply_pressure:g} Pa)')
        if int(self.reaches) < 1:
            raise InputError('reaches', self.reaches, 'an integer >= 1')

    @property
    def plunger_area(self) -> float:
        """A_p [m^2]."""
        return math.pi * self.plunger_diameter ** 2 / 4

    @property
    def actuator_area(self) -> float:
        """A_r [m^2]."""
        return math.pi * self.actuator_diameter ** 2 / 4


@dataclass
class HydraulicResult:
    """Time histories (one row per pipe time step) and the events of one run."""

    t: NDArray[np.float64]           # s
    alpha: NDArray[np.float64]       # rad, cam angle
    valve_lift: NDArray[np.float64]  # m
    valve_velocity: NDArray[np.float64]   # m/s
    pump_pressure: NDArray[np.float64]    # Pa (gauge)
    actuator_pressure: NDArray[np.float64]
    cavitation: bool
    seating_velocity: float | None   # m/s at the first seat impact after opening
    volumes: dict[str, float]        # oil volume balance over the run [m^3]

    @property
    def peak_pressure(self) -> float:
        """Largest pump or actuator pressure [Pa]."""
        return float(max(self.pump_pressure.max(), self.actuator_pressure.max()))

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {'max_valve_lift_m': float(self.valve_lift.max()),
                'peak_pressure_pa': self.peak_pressure,
                'seating_velocity_m_s': self.seating_velocity,
                'cavitation': self.cavitation,
                'volume_balance_m3': self.volumes}


def _pump_pressure(p_old: float, cm: float, b: float, coef: float, known: float,
                   prm: HydraulicParams) -> float:
    """Pressure of the pump chamber (node 0 of the pipe) at the end of a step, from its
    trapezoidal balance coef (p - p_old) = known - (p - cm)/(2b) - g p/2
    + Q_check(p)/2 - Q_relief(p)/2 (``known`` holds the plunger flow and the halves of
    the flows at the start of the step)."""
    g = prm.leak_conductance

    def residual(p: float) -> float:
        return (known - 0.5 * (p - cm) / b - 0.5 * g * p + 0.5 * _check(p, prm)
                - 0.5 * _relief(p, prm) - coef * (p - p_old))

    p = (known + 0.5 * cm / b + coef * p_old) / (0.5 / b + 0.5 * g + coef)   # valves shut
    if not (prm.supply_pressure <= p <= prm.relief_pressure):
        lo, hi = min(p, prm.supply_pressure) - 1.0, max(p, prm.relief_pressure) + 1.0
        while residual(lo) < 0:
            lo -= 2.0 * abs(lo) + 1e5
        while residual(hi) > 0:
            hi += 2.0 * abs(hi) + 1e5
        from scipy.optimize import brentq
        p = brentq(residual, lo, hi, xtol=1e-9, rtol=1e-14)
    return p


def _check(p: float, prm: HydraulicParams) -> float:
    dp = prm.supply_pressure - p
    return orifice_flow(dp, prm.check_area, prm.oil_density) if dp > 0 else 0.0


#: pressure rise over the opening pressure at which the relief valve is fully open
RELIEF_OVERRIDE = 0.05


def _relief(p: float, prm: HydraulicParams) -> float:
    """Relief flow to the drain [m^3/s]: the valve opens in proportion to the pressure
    above its opening pressure, fully at (1 + RELIEF_OVERRIDE) times it, so the flow is
    continuous in p (an on/off valve has no pressure that balances the chamber)."""
    dp = p - prm.relief_pressure
    if dp <= 0:
        return 0.0
    opening = min(1.0, dp / (RELIEF_OVERRIDE * prm.relief_pressure))
    return orifice_flow(p, prm.relief_area * opening, prm.oil_density)


def relief_spilled(pump_pressure: NDArray[np.float64], dt: float,
                   prm: HydraulicParams) -> NDArray[np.float64]:
    """Oil spilled by the relief valve from the start of a run to each step [m^3], from
    the pump pressure of every pipe step (``record_every=1``) by the trapezoidal rule
    the run itself uses (its last value is the run's ``relief_out``)."""
    p = np.asarray(pump_pressure, dtype=float)
    q = np.zeros(p.size)
    for i in np.nonzero(p > prm.relief_pressure)[0]:      # the valve is shut below it
        q[i] = _relief(float(p[i]), prm)
    out = np.zeros(q.size)
    out[1:] = np.cumsum(0.5 * (q[1:] + q[:-1])) * dt
    return out


@dataclass
class _Actuator:
    """State of the actuator chamber and the valve at a (sub-)step boundary."""

    p: float        # chamber pressure [Pa gauge]
    q: float        # pipe flow into the chamber [m^3/s]
    y: float        # valve lift [m]
    v: float        # valve velocity [m/s]
    cav: float = 0.0      # vapour volume in the chamber [m^3]
    stored: float = 0.0   # oil stored by compression so far [m^3]
    leak: float = 0.0     # leakage so far [m^3]


def _actuator_substep(st: _Actuator, d: float, c1: float, f_old: float, fg1: float,
                      seated: bool, k: float, b: float, prm: HydraulicParams) -> _Actuator:
    """Advance the actuator chamber and the valve by ``d`` seconds with the trapezoidal
    rule: (V_mid/K)(p1 - p0) = d/2 (Q0 + Q1) - d g (p0 + p1)/2 - A_r (y1 - y0)
    + (Vc1 - Vc0) and M (v1 - v0) = d/2 (F0 + F1), y1 = y0 + d (v0 + v1)/2, with the
    pipe's characteristic Q1 = (c1 - p1)/B at the end of the step. ``f_old`` is the net
    force on the valve at the start (0 on the seat); seated, the valve does not move.
    Vc is the vapour volume of the chamber: below the vapour pressure the pressure is
    held there and the vapour volume takes up the imbalance until it collapses."""
    ar, g, mass = prm.actuator_area, prm.leak_conductance, prm.mass
    c_rate, f0, damp = prm.spring_rate, prm.spring_preload, prm.valve_damping
    y_pred = 0.0 if seated else max(st.y + d * st.v, 0.0)
    vmid = prm.actuator_volume + ar * 0.5 * (st.y + y_pred)
    coef = vmid / (k * d)
    lhs = coef + 0.5 / b + 0.5 * g
    den = 1.0 + 0.5 * d * damp / mass + 0.25 * d * d * c_rate / mass
    v0 = (st.v + 0.5 * d / mass * (-f0 - c_rate * (st.y + 0.5 * d * st.v) - fg1
                                   + f_old)) / den
    gain = 0.5 * d * ar / (mass * den)

    def motion(p1: float) -> tuple[float, float]:
        if seated:
            return 0.0, 0.0
        v1 = v0 + gain * p1
        return st.y + 0.5 * d * (st.v + v1), v1

    vap = prm.vapour_pressure
    cav1 = 0.0
    if st.cav > 0.0:            # vapour in the chamber: held at the vapour pressure
        y1, v1 = motion(vap)
        cav1 = (st.cav + ar * (y1 - st.y) - 0.5 * d * (st.q + (c1 - vap) / b)
                + 0.5 * g * d * (st.p + vap) + vmid / k * (vap - st.p))
        p1 = vap
    if cav1 <= 0.0:
        rhs = coef * st.p + 0.5 * c1 / b + 0.5 * st.q - 0.5 * g * st.p - st.cav / d
        p1 = (rhs if seated else rhs - 0.5 * ar * (v0 + st.v)) \
            / (lhs if seated else lhs + 0.5 * ar * gain)
        cav1 = 0.0
        if p1 < vap:            # cavitates within the step
            y1, v1 = motion(vap)
            cav1 = (st.cav + ar * (y1 - st.y) - 0.5 * d * (st.q + (c1 - vap) / b)
                    + 0.5 * g * d * (st.p + vap) + vmid / k * (vap - st.p))
            p1 = vap
            cav1 = max(cav1, 0.0)
        y1, v1 = motion(p1)
    return _Actuator(p=p1, q=(c1 - p1) / b, y=y1, v=v1, cav=cav1,
                     stored=st.stored + vmid / k * (p1 - st.p) - (cav1 - st.cav),
                     leak=st.leak + 0.5 * g * (st.p + p1) * d)


def _valve_force(st: _Actuator, fg: float, prm: HydraulicParams) -> float:
    """Net force on the free valve [N] (opening positive)."""
    return (prm.actuator_area * st.p - prm.spring_preload - prm.spring_rate * st.y
            - prm.valve_damping * st.v - fg)


def _actuator_step(st: _Actuator, dt: float, c0: float, c1: float, fg0: float, fg1: float,
                   seated: bool, k: float, b: float,
                   prm: HydraulicParams) -> tuple[_Actuator, bool, float | None, bool]:
    """One pipe step of the actuator and the valve, with the lift-off and the seat impact
    located inside the step (the step is split there, the pipe's characteristic and the
    gas force interpolated linearly), so that the events cost no order of accuracy.
    Returns the new state, whether the valve is seated, the impact speed (or None) and
    whether the step was split."""
    if seated:
        end = _actuator_substep(st, dt, c1, 0.0, fg1, True, k, b, prm)
        f_start = _valve_force(st, fg0, prm)
        f_end = _valve_force(end, fg1, prm)
        if f_end <= 0.0:
            return end, True, None, False
        theta = f_start / (f_start - f_end) if f_start < 0.0 else 0.0
        mid = st
        if theta > 0.0:
            mid = _actuator_substep(st, theta * dt, c0 + theta * (c1 - c0), 0.0,
                                    fg0 + theta * (fg1 - fg0), True, k, b, prm)
        end = _actuator_substep(mid, (1.0 - theta) * dt, c1, 0.0, fg1, False, k, b, prm)
        if end.y <= 0.0:
            end.y = end.v = 0.0
            return end, True, None, True
        return end, False, None, True
    f_start = _valve_force(st, fg0, prm)
    end = _actuator_substep(st, dt, c1, f_start, fg1, False, k, b, prm)
    if end.y >= 0.0:
        return end, False, None, False
    # impact: y(s) = y0 + s v0 + s^2 (v1 - v0)/(2 dt) on the trapezoidal path
    y0, v0, dv = st.y, st.v, end.v - st.v
    disc = v0 * v0 - 2.0 * dv * y0 / dt
    if abs(dv) > 1e-300 and disc >= 0.0:
        theta = (-v0 - math.sqrt(disc)) / dv
    else:
        theta = y0 / (y0 - end.y)
    if not 0.0 < theta <= 1.0:
        theta = y0 / (y0 - end.y)
    c_hit, fg_hit = c0 + theta * (c1 - c0), fg0 + theta * (fg1 - fg0)
    hit = _actuator_substep(st, theta * dt, c_hit, f_start, fg_hit, False, k, b, prm)
    v_hit = min(hit.v, 0.0)
    hit.y, hit.v = 0.0, -prm.restitution * v_hit
    rest = (1.0 - theta) * dt
    if hit.v <= 1e-9:
        hit.v = 0.0
        return (_actuator_substep(hit, rest, c1, 0.0, fg1, True, k, b, prm) if rest > 0.0
                else hit), True, -v_hit, True
    end = _actuator_substep(hit, rest, c1, _valve_force(hit, fg_hit, prm), fg1, False, k, b,
                            prm) if rest > 0.0 else hit
    if end.y < 0.0:
        end.y = end.v = 0.0
        return end, True, -v_hit, True
    return end, False, -v_hit, True


def _whole_step_balance(st: _Actuator, end: _Actuator, dt: float, c1: float, k: float,
                        b: float, prm: HydraulicParams) -> _Actuator:
    """The chamber pressure at the end of a split step from the balance over the whole
    step with the valve's swept volume of the split solution: the pipe exchanges
    dt (Q0 + Q1)/2 with the chamber (its own conservation), so the oil volume balance
    stays exact; the change to the split solution is O(dt^3) in volume."""
    ar, g = prm.actuator_area, prm.leak_conductance
    if st.cav > 0.0 or end.cav > 0.0:
        return end
    vmid = prm.actuator_volume + ar * 0.5 * (st.y + end.y)
    coef = vmid / (k * dt)
    p1 = ((coef * st.p + 0.5 * st.q + 0.5 * c1 / b - 0.5 * g * st.p
           - ar * (end.y - st.y) / dt) / (coef + 0.5 / b + 0.5 * g))
    return _Actuator(p=p1, q=(c1 - p1) / b, y=end.y, v=end.v,
                     stored=st.stored + vmid / k * (p1 - st.p),
                     leak=st.leak + 0.5 * g * (st.p + p1) * dt)


#: pipe steps one pass may take (a pipe so short or stiff that it needs more is refused)
MAX_PASS_STEPS = 5_000_000


def pass_steps(alpha_range: tuple[float, float], rpm: float, dt: float) -> int:
    """Pipe steps of a pass over the cam angles ``alpha_range`` [rad] at ``rpm``
    (camshaft) with the pipe's time step ``dt`` [s]."""
    lo, hi = alpha_range
    return int(math.ceil((hi - lo) / (rpm * 2 * math.pi / 60 * dt)))


def pass_range(law: Any) -> tuple[float, float]:
    """Cam angles [rad] of a default pass: the law's support +- 10 deg."""
    return law.support[0] - math.radians(10), law.support[1] + math.radians(10)


def pipe_of(prm: HydraulicParams) -> Pipe:
    """The gear's pipe filled with nothing yet; its ``dt`` [s] is the run's time step
    (wave speed at the supply pressure)."""
    k0 = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction, prm.supply_pressure + P_ATM)
    pipe = Pipe(prm.pipe_length, prm.pipe_diameter, wave_speed(k0, prm.oil_density),
                prm.oil_density, prm.friction, prm.reaches, prm.vapour_pressure)
    if pipe.dx <= 0 or not math.isfinite(pipe.dt):
        raise InputError('pipe_length', prm.pipe_length, 'a pipe of at least one reach')
    return pipe


def simulate_hydraulic(law: Any, prm: HydraulicParams, rpm: float, *,
                       alpha_range: tuple[float, float] | None = None,
                       gas_force: Callable[[float], float] | None = None,
                       record_every: int = 1) -> HydraulicResult:
    """One pass of the lobe at ``rpm`` (camshaft) from the base circle before it to the
    base circle after it (``alpha_range`` rad; default the law's support +-10 deg).
    ``gas_force(alpha)`` [N] opposes the opening (exhaust valve). Starts at rest, the
    system filled at supply pressure and the valve seated."""
    omega = require_positive('cam_speed_rpm', rpm) * 2 * math.pi / 60
    lo, hi = alpha_range or pass_range(law)
    k0 = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction, prm.supply_pressure + P_ATM)
    pipe = pipe_of(prm)
    dt = pipe.dt
    steps = pass_steps((lo, hi), rpm, dt)
    if steps > MAX_PASS_STEPS:
        raise InputError('pipe_length', prm.pipe_length,
                         f'a time step that does not need {steps:.3g} steps for one lobe '
                         f'(dt = {dt:.3g} s; use a longer pipe, fewer reaches or a '
                         'lower bulk modulus)')
    ap, ar, b = prm.plunger_area, prm.actuator_area, pipe.impedance
    pipe.fill(prm.supply_pressure)
    p_pump = p_act = p_pump_prev = p_act_prev = prm.supply_pressure
    act = _Actuator(p=p_act, q=0.0, y=0.0, v=0.0)
    seated = True
    opened = False
    v_seat: float | None = None
    cav = False
    alphas = lo + omega * dt * np.arange(steps + 1)
    h_all = law(alphas, 0)
    if float(h_all.max()) * ap >= prm.pump_volume:
        raise InputError('pump_volume', prm.pump_volume,
                         f'a dead volume larger than the plunger displacement '
                         f'({ap * float(h_all.max()):.3g} m^3)')
    fg_all = np.array([gas_force(float(a)) for a in alphas]) if gas_force is not None \
        else np.zeros(steps + 1)
    n_rec = steps // record_every + 1
    rec = np.zeros((n_rec, 4))
    rec[0] = (act.y, act.v, p_pump, p_act)
    vol = {'plunger_in': 0.0, 'check_in': 0.0, 'relief_out': 0.0, 'leak_out': 0.0,
           'actuator_swept': 0.0}
    pipe_stored0 = pipe.stored_volume(k0)
    chamber_stored = 0.0
    g = prm.leak_conductance
    air = prm.air_fraction > 0.0
    k_p = k_a = k0
    chk_old, rel_old = _check(p_pump, prm), _relief(p_pump, prm)
    for i in range(1, steps + 1):
        cp, cm = pipe.c_plus(), pipe.c_minus()
        q0_old, qn_old = float(pipe.q[0]), float(pipe.q[-1])
        p_act = act.p
        h_old, h = float(h_all[i - 1]), float(h_all[i])
        if air:     # K at the mid-step pressure, extrapolated from the last two steps
            k_p = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction,
                                         1.5 * p_pump - 0.5 * p_pump_prev + P_ATM)
            k_a = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction,
                                         1.5 * p_act - 0.5 * p_act_prev + P_ATM)
        # pump chamber: trapezoidal balance on the mid-step volume (conservative)
        vp_mid = prm.pump_volume - ap * 0.5 * (h_old + h)
        coef_p = vp_mid / (k_p * dt)
        q_plunger = ap * (h - h_old) / dt
        known = q_plunger + 0.5 * (-q0_old - g * p_pump + chk_old - rel_old)
        p_new = _pump_pressure(p_pump, float(cm[0]), b, coef_p, known, prm)
        chk_new, rel_new = _check(p_new, prm), _relief(p_new, prm)
        q0 = (p_new - float(cm[0])) / b
        # actuator chamber + valve: trapezoidal, events located inside the step
        c_end = float(cp[-1])
        y_old = act.y
        act0 = _Actuator(p=act.p, q=qn_old, y=act.y, v=act.v, cav=act.cav)
        act, seated, hit, split = _actuator_step(act0, dt, act.p + b * qn_old, c_end,
                                                 float(fg_all[i - 1]), float(fg_all[i]),
                                                 seated, k_a, b, prm)
        if split:       # balance the chamber over the whole step, as the pipe sees it
            act = _whole_step_balance(act0, act, dt, c_end, k_a, b, prm)
        if hit is not None and opened and v_seat is None:
            v_seat = hit
        opened = opened or act.y > 0.0
        p_a = act.p
        chamber_stored += coef_p * dt * (p_new - p_pump) + act.stored
        pipe.step(p_new, q0, p_a, act.q, cp, cm)
        cav = cav or bool(np.any(pipe.cavity > 0)) or act.cav > 0.0 \
            or p_new <= prm.vapour_pressure
        vol['plunger_in'] += q_plunger * dt
        vol['check_in'] += 0.5 * (chk_old + chk_new) * dt
        vol['relief_out'] += 0.5 * (rel_old + rel_new) * dt
        vol['leak_out'] += 0.5 * g * (p_pump + p_new) * dt + act.leak
        vol['actuator_swept'] += ar * (act.y - y_old)
        p_pump_prev, p_act_prev = p_pump, p_act
        p_pump = p_new
        chk_old, rel_old = chk_new, rel_new
        if i % record_every == 0:
            rec[i // record_every] = (act.y, act.v, p_pump, act.p)
    vol['stored_change'] = chamber_stored + pipe.stored_volume(k0) - pipe_stored0
    vol['residual'] = (vol['plunger_in'] + vol['check_in'] - vol['relief_out']
                       - vol['leak_out'] - vol['actuator_swept'] - vol['stored_change'])
    idx = np.arange(n_rec) * record_every
    return HydraulicResult(t=np.asarray(idx * dt, dtype=np.float64),
                           alpha=np.asarray(alphas[idx], dtype=np.float64), valve_lift=rec[:, 0],
                           valve_velocity=rec[:, 1], pump_pressure=rec[:, 2],
                           actuator_pressure=rec[:, 3], cavitation=cav,
                           seating_velocity=v_seat, volumes=vol)
