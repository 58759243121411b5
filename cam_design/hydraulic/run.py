"""The hydraulic valve gear as a valve-train model (scene ``valve_train.model: hydraulic``).

``hydraulic_params`` builds the parameters from the scene's ``valve_train`` keys and its
``hydraulic`` block, naming the scene key of anything wrong; ``run_hydraulic`` runs one
lobe pass at one camshaft speed and returns a ``Run`` like the mechanical models (valve
lift, velocity, the cam's force on the plunger, its Hertz stress), with the pump and
actuator pressures and the hydraulic events (peak pressure, cavitation, seating
velocity, oil-volume balance) beside them. SI units throughout.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_finite
from cam_design.hydraulic.actuation import HydraulicParams, relief_spilled, simulate_hydraulic
from cam_design.hydraulic.gas import gas_events
from cam_design.valve_train.report import ContactGeometry, Run, stress_and_undercut

#: keys of the ``valve_train.hydraulic`` block (the valve's mass, spring and damping are
#: the ``valve_train`` keys of the same name)
BLOCK_KEYS = tuple(f.name for f in dataclasses.fields(HydraulicParams)
                   if f.name not in ('mass', 'spring_rate', 'spring_preload',
                                     'valve_damping', 'restitution'))
#: keys the block must give (everything else has a default, docs/hydraulic.md)
REQUIRED = ('plunger_diameter', 'actuator_diameter', 'pipe_length', 'pipe_diameter')
#: largest output rows of a run (the pipe step is often microseconds)
MAX_ROWS = 4000


def hydraulic_params(block: Mapping[str, Any] | None, *, mass: float, spring_rate: float,
                     spring_preload: float, valve_damping: float = 0.0,
                     restitution: float | None = None,
                     key: str = 'valve_train') -> HydraulicParams:
    """HydraulicParams from the scene: ``block`` is ``valve_train.hydraulic`` (lengths
    m, pressures Pa gauge, density kg/m^3, bulk modulus Pa), the valve's ``mass`` [kg],
    ``spring_rate`` [N/m], ``spring_preload`` [N], ``valve_damping`` [N s/m] and the
    seat's ``restitution`` come from ``valve_train``. Errors name ``key.hydraulic.X``
    (or ``key.X`` for the valve keys)."""
    where = f'{key}.hydraulic'
    if not isinstance(block, Mapping):
        raise InputError(where, block, 'a mapping with at least ' + ', '.join(REQUIRED)
                         + ' (docs/hydraulic.md)')
    for k in block:
        if k not in BLOCK_KEYS:
            raise InputError(f'{where}.{k}', block[k], 'one of ' + ', '.join(BLOCK_KEYS))
    for k in REQUIRED:
        if k not in block:
            raise InputError(f'{where}.{k}', None, 'a value (docs/hydraulic.md)')
    values: dict[str, Any] = {}
    for k, v in block.items():
        values[k] = require_finite(f'{where}.{k}', v)
        if k == 'reaches':
            if values[k] != int(values[k]):
                raise InputError(f'{where}.{k}', v, 'a whole number of pipe reaches >= 1')
            values[k] = int(values[k])
    valve: dict[str, Any] = {
        'mass': mass, 'spring_rate': spring_rate, 'spring_preload': spring_preload,
        'valve_damping': valve_damping,
        'restitution': 0.0 if restitution is None else restitution}
    try:
        prm = HydraulicParams(**values, **valve)
    except InputError as exc:
        prefix = where if exc.key in BLOCK_KEYS else key
        name = 'seat.restitution' if exc.key == 'restitution' else exc.key
        raise InputError(f'{prefix}.{name}', exc.value, exc.expected) from None
    held = prm.actuator_area * prm.supply_pressure
    if prm.spring_preload <= held:
        raise InputError(f'{key}.spring_preload', spring_preload,
                         f'more than the supply pressure on the actuator piston '
                         f'({held:.4g} N = A_r x {prm.supply_pressure:g} Pa), or the '
                         'valve never closes')
    return prm


@dataclass
class HydraulicRun(Run):
    """A ``Run`` with the chamber pressures [Pa gauge] on the same angle grid."""

    pump_pressure: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    actuator_pressure: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def pressure_table(self) -> NDArray[np.float64]:
        """(rows, 3): alpha [rad], pump pressure, actuator pressure [Pa gauge]."""
        return np.column_stack([self.alpha, self.pump_pressure, self.actuator_pressure])

    def as_dict(self, arrays: bool = True) -> dict[str, Any]:
        """The mechanical run's dict plus the two pressure curves."""
        out = super().as_dict(arrays)
        if arrays:
            out['pump_pressure_pa'] = self.pump_pressure.tolist()
            out['actuator_pressure_pa'] = self.actuator_pressure.tolist()
        return out


#: pressure table columns (topic /dynamics/motion, name FEATURE/RPMrpm/pressure)
PRESSURE_COLUMNS = ('alpha_rad', 'pump_pressure_pa', 'actuator_pressure_pa')


#: the valve counts as back on its seat at the end of a pass below this lift [m]
CLOSED_LIFT = 1e-6


def run_hydraulic(law: Any, prm: HydraulicParams, rpm: float,
                  geometry: ContactGeometry | None = None,
                  gas: Callable[[float], float] | None = None) -> HydraulicRun:
    """One pass of the lobe ``law`` (lift [m] of the plunger vs cam angle [rad]) at
    ``rpm`` (camshaft) through the hydraulic gear ``prm``; ``gas(alpha)`` [N]: the
    cylinder-gas force pushing the valve shut. The cam's force on the plunger
    is A_p times the pump pressure (gauge), floored at zero (a plunger return spring is
    not modelled); its Hertz stress uses ``geometry`` when given. Events: maxima, peak
    pressures and where, cavitation, seating velocity, the oil-volume balance, the oil
    the relief valve spilled before the valve reached its peak lift (as a share of the
    plunger displacement: the lift it cost) and, as for every model, a ``note`` when
    something needs attention."""
    res = simulate_hydraulic(law, prm, rpm, record_every=1, gas_force=gas)
    every = max(1, math.ceil(res.alpha.size / MAX_ROWS))
    sel = np.arange(0, res.alpha.size, every)
    alpha = res.alpha[sel]
    force = np.maximum(prm.plunger_area * res.pump_pressure[sel], 0.0)
    stress, undercut = stress_and_undercut(law, alpha, force, geometry)
    lift = res.valve_lift[sel]
    ratio = prm.plunger_area / prm.actuator_area
    rigid = ratio * float(np.max(law(alpha, 0)))
    i_p = int(np.argmax(res.pump_pressure))
    i_a = int(np.argmax(res.actuator_pressure))
    i_f = int(np.argmax(force))
    displaced = prm.plunger_area * float(np.max(law(res.alpha, 0))) or 1.0   # m^3
    # the spill that cost lift: up to the valve's peak, or the plunger's if that is later
    # (a valve held shut or pushed back peaks early); later spills are transients
    i_y = max(int(np.argmax(res.valve_lift)), int(np.argmax(law(res.alpha, 0))))
    dt = float(res.t[1] - res.t[0]) if res.t.size > 1 else 0.0
    spilled = relief_spilled(res.pump_pressure[:i_y + 1], dt, prm)[-1]
    events: dict[str, Any] = {
        'max_valve_lift_m': float(res.valve_lift.max()),
        'rigid_valve_lift_m': rigid,
        'peak_pump_pressure_pa': float(res.pump_pressure[i_p]),
        'peak_pump_pressure_deg': math.degrees(float(res.alpha[i_p])),
        'peak_actuator_pressure_pa': float(res.actuator_pressure[i_a]),
        'peak_actuator_pressure_deg': math.degrees(float(res.alpha[i_a])),
        'min_pressure_pa': float(min(res.pump_pressure.min(), res.actuator_pressure.min())),
        'cavitation': bool(res.cavitation),
        'seating_velocity_m_s': res.seating_velocity,
        # oil-volume balance over the pass, as a fraction of the plunger displacement
        'oil_volume_residual': float(res.volumes['residual'] / displaced),
        'relief_volume_m3': float(res.volumes['relief_out']),
        'relief_spilled': bool(res.volumes['relief_out'] > 0.0),
        # oil lost to the relief valve before the peak lift, per displaced volume
        'relief_spill_before_peak': float(spilled / displaced),
        'valve_lift_ratio': float(res.valve_lift.max()) / rigid if rigid > 0 else None,
        'valve_closed': bool(lift[-1] <= CLOSED_LIFT),
        'max_contact_force_n': float(force[i_f]),
        'max_contact_force_deg': math.degrees(float(alpha[i_f])),
        'max_contact_stress_pa': None if geometry is None or undercut
        else float(np.max(stress)),
        'profile_undercut': undercut,
        'pipe_time_step_s': float(res.t[1] - res.t[0]) if res.t.size > 1 else None,
        'output_every_steps': every,
    }
    if gas is not None:
        opening = np.nonzero(res.valve_lift > 0.0)[0]
        events.update(gas_events(gas, alpha, math.degrees(float(res.alpha[opening[0]]))
                                 if opening.size else None))
    notes = []
    if res.cavitation:
        notes.append('cavitation: a chamber or the pipe fell to the vapour pressure '
                     '(the valve motion after it is uncertain)')
    if lift[-1] > CLOSED_LIFT:
        notes.append(f'the valve had not closed at the end of the pass '
                     f'({lift[-1] * 1e3:.3f} mm open)')
    elif res.seating_velocity is None and res.valve_lift.max() > 0:
        notes.append('no seat impact was found after the opening')
    if notes:
        events['note'] = '; '.join(notes)
    return HydraulicRun(rpm=float(rpm), model='hydraulic', alpha=alpha, lift=lift,
                        velocity=res.valve_velocity[sel], force=force, stress=stress,
                        events=events, pump_pressure=res.pump_pressure[sel],
                        actuator_pressure=res.actuator_pressure[sel])


def hydraulic_from_valve_train(vt: Any) -> HydraulicParams:
    """HydraulicParams of a validated scene ``ValveTrain`` (model ``hydraulic``)."""
    return hydraulic_params(vt.hydraulic, mass=vt.mass, spring_rate=vt.spring_rate,
                            spring_preload=vt.spring_preload,
                            valve_damping=vt.valve_damping,
                            restitution=vt.seat.restitution)
