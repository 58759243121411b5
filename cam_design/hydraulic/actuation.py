"""Cam-driven hydraulic valve actuation: plunger pump -> high-pressure pipe -> actuator
chamber -> valve (single DOF, spring, hard seat, gas force).

Pump chamber (volume V_p = V_p0 - A_p h): (V_p / K) dp/dt = A_p omega h' - Q_pipe
- Q_leak + Q_check - Q_relief; the check valve refills from the supply when the chamber
falls below the supply pressure, the relief valve spills above its opening pressure
(both by the orifice law); leakage is laminar (Q = g p). Actuator chamber (V_a = V_a0 +
A_r y): (V_a / K) dp/dt = Q_pipe - A_r y' - g p. Valve: M y'' = A_r p - F0 - c' y -
b y' - F_gas + R_seat, seated (y = 0) with restitution at impact. The pipe couples the
two chambers by its characteristics (pipe.py); every step is dt = dx / a. The chambers
and the valve are advanced implicitly (backward Euler, exact for the flow balance).
K is the effective bulk modulus with entrained air at the chamber pressure (lagged one
step). Pressures are gauge [Pa]; the vapour pressure is therefore about -1e5 Pa.
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


def _pump_pressure(p_old: float, cm: float, b: float, coef: float, q_in: float,
                   prm: HydraulicParams) -> tuple[float, float, float, float]:
    """Backward-Euler pressure of the pump chamber (node 0 of the pipe) and its flows:
    coef (p - p_old) = q_in - (p - cm)/b - g p + Q_check(p) - Q_relief(p)."""
    g = prm.leak_conductance

    def residual(p: float) -> float:
        return (q_in - (p - cm) / b - g * p + _check(p, prm) - _relief(p, prm)
                - coef * (p - p_old))

    p = (q_in + cm / b + coef * p_old) / (1.0 / b + g + coef)      # valves closed
    if not (prm.supply_pressure <= p <= prm.relief_pressure):
        lo, hi = min(p, prm.supply_pressure) - 1.0, max(p, prm.relief_pressure) + 1.0
        while residual(lo) < 0:
            lo -= 2.0 * abs(lo) + 1e5
        while residual(hi) > 0:
            hi += 2.0 * abs(hi) + 1e5
        from scipy.optimize import brentq
        p = brentq(residual, lo, hi, xtol=1e-9, rtol=1e-14)
    return p, _check(p, prm), _relief(p, prm), g * p


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


def simulate_hydraulic(law: Any, prm: HydraulicParams, rpm: float, *,
                       alpha_range: tuple[float, float] | None = None,
                       gas_force: Callable[[float], float] | None = None,
                       record_every: int = 1) -> HydraulicResult:
    """One pass of the lobe at ``rpm`` (camshaft) from the base circle before it to the
    base circle after it (``alpha_range`` rad; default the law's support +-10 deg).
    ``gas_force(alpha)`` [N] opposes the opening (exhaust valve). Starts at rest, the
    system filled at supply pressure and the valve seated."""
    omega = require_positive('cam_speed_rpm', rpm) * 2 * math.pi / 60
    lo, hi = alpha_range or (law.support[0] - math.radians(10),
                             law.support[1] + math.radians(10))
    k0 = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction, prm.supply_pressure + P_ATM)
    pipe = Pipe(prm.pipe_length, prm.pipe_diameter, wave_speed(k0, prm.oil_density),
                prm.oil_density, prm.friction, prm.reaches, prm.vapour_pressure)
    if pipe.dx <= 0 or not math.isfinite(pipe.dt):
        raise InputError('pipe_length', prm.pipe_length, 'a pipe of at least one reach')
    dt = pipe.dt
    steps = int(math.ceil((hi - lo) / (omega * dt)))
    if steps > 5_000_000:
        raise InputError('pipe_length', prm.pipe_length,
                         f'a time step that does not need {steps:.3g} steps for one lobe '
                         f'(dt = {dt:.3g} s; use a longer pipe, fewer reaches or a '
                         'lower bulk modulus)')
    ap, ar, b, mass = prm.plunger_area, prm.actuator_area, pipe.impedance, prm.mass
    pipe.fill(prm.supply_pressure)
    p_pump = p_act = prm.supply_pressure
    y = v = 0.0
    seated = True
    opened = False
    v_seat: float | None = None
    cav = False
    alphas = lo + omega * dt * np.arange(steps + 1)
    h_all = law(alphas, 0)
    h1_all = law(alphas, 1)
    n_rec = steps // record_every + 1
    rec = np.zeros((n_rec, 5))
    rec[0] = (y, v, p_pump, p_act, 0.0)
    vol = {'plunger_in': 0.0, 'check_in': 0.0, 'relief_out': 0.0, 'leak_out': 0.0,
           'actuator_swept': 0.0}
    pipe_stored0 = pipe.stored_volume(k0)
    chamber_stored = 0.0
    g = prm.leak_conductance
    for i in range(1, steps + 1):
        cp, cm = pipe.c_plus(), pipe.c_minus()
        h, h1 = float(h_all[i]), float(h1_all[i])
        k_p = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction, p_pump + P_ATM)
        k_a = effective_bulk_modulus(prm.bulk_modulus, prm.air_fraction, p_act + P_ATM)
        vp = prm.pump_volume - ap * h
        if vp <= 0:
            raise InputError('pump_volume', prm.pump_volume,
                             f'a dead volume larger than the plunger displacement '
                             f'({ap * float(h_all.max()):.3g} m^3)')
        q_plunger = ap * omega * h1
        p_new, q_chk, q_rel, q_lp = _pump_pressure(p_pump, float(cm[0]), b, vp / (k_p * dt),
                                                   q_plunger, prm)
        q0 = (p_new - float(cm[0])) / b
        # actuator chamber + valve, backward Euler (linear in p, v)
        fg = gas_force(float(alphas[i])) if gas_force is not None else 0.0
        va = prm.actuator_volume + ar * y
        coef = va / (k_a * dt)
        c_end = float(cp[-1])
        a_den = 1.0 + dt * prm.valve_damping / mass + dt * dt * prm.spring_rate / mass
        v0 = (v + dt / mass * (-prm.spring_preload - prm.spring_rate * y - fg)) / a_den
        gain = dt * ar / (mass * a_den)
        rhs = coef * p_act + c_end / b
        lhs = coef + 1.0 / b + g
        p_a = (rhs - ar * v0) / (lhs + ar * gain)
        v_new = v0 + gain * p_a
        if seated and v_new <= 0.0:            # stays on the seat: no motion
            v_new = 0.0
            p_a = rhs / lhs
        y_new = y + dt * v_new
        if y_new < 0.0:                          # seat impact within the step
            if opened and v_seat is None:
                v_seat = -v_new
            y_new = 0.0
            v_new = -prm.restitution * v_new
            seated = v_new <= 1e-9
            if seated:
                v_new = 0.0
            p_a = (rhs - ar * (y_new - y) / dt) / lhs     # the volume really swept
        elif y_new > 0.0:
            seated = False
            opened = True
        chamber_stored += vp / k_p * (p_new - p_pump) + va / k_a * (p_a - p_act)
        q_n = (c_end - p_a) / b
        pipe.step(p_new, q0, p_a, q_n, cp, cm)
        cav = cav or bool(np.any(pipe.cavity > 0)) or p_a <= prm.vapour_pressure \
            or p_new <= prm.vapour_pressure
        vol['plunger_in'] += q_plunger * dt
        vol['check_in'] += q_chk * dt
        vol['relief_out'] += q_rel * dt
        vol['leak_out'] += (q_lp + g * p_a) * dt
        vol['actuator_swept'] += ar * (y_new - y)
        p_pump, p_act, y, v = p_new, p_a, y_new, v_new
        if i % record_every == 0:
            rec[i // record_every] = (y, v, p_pump, p_act, 0.0)
    vol['stored_change'] = chamber_stored + pipe.stored_volume(k0) - pipe_stored0
    vol['residual'] = (vol['plunger_in'] + vol['check_in'] - vol['relief_out']
                       - vol['leak_out'] - vol['actuator_swept'] - vol['stored_change'])
    idx = np.arange(n_rec) * record_every
    return HydraulicResult(t=idx * dt, alpha=alphas[idx], valve_lift=rec[:, 0],
                           valve_velocity=rec[:, 1], pump_pressure=rec[:, 2],
                           actuator_pressure=rec[:, 3], cavitation=cav,
                           seating_velocity=v_seat, volumes=vol)
