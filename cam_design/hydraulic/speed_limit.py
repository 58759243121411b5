"""The hydraulic valve gear over a speed range, and the speed above which it can no longer
open the valve fully against the spring, the valve's inertia and the gas force.

Every speed is one lobe pass of ``run_hydraulic`` (the same run as ``cam-bench dynamics
--rpm``, on the scene's pipe grid). Definition: a speed fails (the gear no longer opens
the valve fully) when both (a) the relief valve spilled more than ``tol`` of the plunger
displacement A_p h_max before the valve reached its peak lift and (b) the peak valve lift
is below (1 - ``tol``) of the rigid-oil lift (A_p/A_r) h_max. The spilled oil is lift lost
for good (a), and (b) keeps a valve that flies past the rigid-oil lift on its own inertia
(it pulls a vapour cavity) from counting as not opened; the compression of the oil alone
lowers the lift without a spill and is reported (``valve_lift_ratio``), not counted. With
rigid oil the two conditions coincide. The relief spills when the pump pressure needed
to push the valve after the cam exceeds the relief pressure: with rigid oil
(docs/hydraulic.md) p = (F0 + c'y + F_gas + M y'' w^2)/A_r + rho L (A_p/A_pipe) h'' w^2
(the second term: the pipe's oil column). The no-open speed is the lowest failing
speed: bracketed on the grid by the last good and the first failing speed and bisected to
``tol_rpm`` (``no_open_bracket_rpm`` [last_ok, first_failing], None for an open end; the
speed itself None unless bracketed inside the range).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive
from cam_design.hydraulic.actuation import (MAX_PASS_STEPS, HydraulicParams, pass_range,
                                            pass_steps, pipe_of)
from cam_design.hydraulic.run import run_hydraulic
from cam_design.valve_train.sweep import Bracket, bisect_speed, require_speeds

#: default ``tol``: the relief spill before the peak lift (per plunger displacement) and
#: the shortfall of the peak lift (per rigid-oil lift) that make a speed fail
SPILL_TOL = 1e-3
#: largest number of pipe steps of a whole sweep's grid (about 20 us of CPU each)
MAX_SWEEP_STEPS = 50_000_000


@dataclass
class HydraulicSweep:
    """Per-speed results [SI] of a hydraulic sweep and its no-open speed."""

    rpm: NDArray[np.float64]
    max_lift: NDArray[np.float64]            # m, peak valve lift
    rigid_lift: float                        # m, (A_p/A_r) h_max
    lift_ratio: NDArray[np.float64]          # peak valve lift / rigid-oil lift
    peak_pump_pressure: NDArray[np.float64]  # Pa gauge
    relief_spilled: NDArray[np.bool_]        # the relief valve opened during the pass
    spill_before_peak: NDArray[np.float64]   # spill before the peak lift / displacement
    cavitation: NDArray[np.bool_]
    settled: NDArray[np.bool_]               # the valve was back on its seat at the end
    opening_force: NDArray[np.float64]       # N, F0 + gas force at the opening (nan: none)
    no_open: Bracket
    seconds: float                           # CPU time of the whole sweep [s]
    runs: int                                # passes simulated (grid and bisection)
    spill_tol: float = SPILL_TOL
    pipe_time_step: float = 0.0              # s
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        def opt(values: NDArray[np.float64]) -> list[float | None]:
            return [float(v) if math.isfinite(v) else None for v in values]

        return {
            'sweep_rpm': self.rpm.tolist(), 'max_valve_lift_m': self.max_lift.tolist(),
            'rigid_valve_lift_m': self.rigid_lift,
            'valve_lift_ratio': self.lift_ratio.tolist(),
            'peak_pump_pressure_pa': self.peak_pump_pressure.tolist(),
            'relief_spilled': self.relief_spilled.tolist(),
            'relief_spill_before_peak': self.spill_before_peak.tolist(),
            'cavitation': self.cavitation.tolist(), 'settled': self.settled.tolist(),
            'opening_force_n': opt(self.opening_force),
            'no_open_speed_rpm': self.no_open.speed,
            'no_open_bracket_rpm': self.no_open.bracket,
            'spill_tol': self.spill_tol, 'pipe_time_step_s': self.pipe_time_step,
            'sweep_cpu_seconds': self.seconds, 'runs': self.runs, 'notes': list(self.notes),
        }


def static_pressure(law: Any, prm: HydraulicParams,
                    gas: Callable[[float], float] | None = None,
                    samples: int = 2001) -> tuple[float, float]:
    """Actuator pressure [Pa gauge] that holds the valve on the rigid-oil lift at
    vanishing speed, (F0 + c' y + F_gas)/A_r with y = (A_p/A_r) h: its largest value over
    the lift, and its largest value where h'' >= 0 (there no speed lowers it: the valve's
    inertia adds to it)."""
    alpha = np.linspace(law.support[0], law.support[1], samples)
    y = prm.plunger_area / prm.actuator_area * law(alpha, 0)
    force = prm.spring_preload + prm.spring_rate * y
    if gas is not None:
        force = force + np.array([float(gas(float(a))) for a in alpha])
    need = force / prm.actuator_area
    return float(np.max(need)), float(np.max(need[law(alpha, 2) >= 0.0]))


def hydraulic_sweep(law: Any, prm: HydraulicParams, rpms: Sequence[float], *,
                    gas: Callable[[float], float] | None = None,
                    spill_tol: float = SPILL_TOL, tol_rpm: float = 0.5,
                    refine: bool = True, key: str = '--sweep') -> HydraulicSweep:
    """Run the gear ``prm`` at every speed of ``rpms`` [rpm] (increasing) and locate the
    no-open speed (module docstring): the lowest speed at which the relief valve spills
    more than ``spill_tol`` of the plunger displacement before the peak valve lift and
    the peak valve lift is below (1 - ``spill_tol``) of the rigid-oil lift.
    ``gas(alpha)`` [N]: the cylinder-gas force on the valve. A grid that would take more
    than MAX_SWEEP_STEPS pipe steps is refused naming ``key``."""
    speeds = require_speeds(rpms)
    require_positive('tol_rpm', tol_rpm)
    if not 0.0 < spill_tol < 1.0:
        raise InputError('spill_tol', spill_tol, 'a share of the displacement in (0, 1)')
    step_s = pipe_of(prm).dt
    steps = [pass_steps(pass_range(law), float(r), step_s) for r in speeds]
    if steps[0] > MAX_PASS_STEPS:
        lowest = speeds[0] * steps[0] / MAX_PASS_STEPS
        raise InputError(f'{key}.LO', float(speeds[0]),
                         f'a lowest speed of at least {lowest:.4g} rpm (a pass needs '
                         f'{steps[0]:.3g} pipe steps at {speeds[0]:g} rpm, at most '
                         f'{MAX_PASS_STEPS // 10**6}e6; or '
                         'fewer valve_train.hydraulic.reaches)')
    if sum(steps) > MAX_SWEEP_STEPS:
        raise InputError(key, f'{speeds.size} speeds, {sum(steps):.3g} pipe steps',
                         f'fewer speeds (a larger STEP) or fewer valve_train.hydraulic.'
                         f'reaches: a sweep takes at most {MAX_SWEEP_STEPS:.0e} pipe steps '
                         '(about 20 us of CPU each)')
    t0 = time.process_time()
    n = speeds.size
    out = {name: np.zeros(n) for name in ('lift', 'ratio', 'pump', 'spill', 'force')}
    flags = {name: np.zeros(n, dtype=bool) for name in ('relief', 'cav', 'closed')}
    runs = 0
    dt = 0.0
    rigid = 0.0

    def failing(ev: dict[str, Any]) -> bool:
        ratio = ev['valve_lift_ratio']
        return ev['relief_spill_before_peak'] > spill_tol and (
            ratio is None or ratio < 1.0 - spill_tol)

    def fails_at(rpm: float) -> bool:
        nonlocal runs
        runs += 1
        return failing(run_hydraulic(law, prm, rpm, gas=gas).events)

    fails = np.zeros(n, dtype=bool)
    for i, rpm in enumerate(speeds):
        ev = run_hydraulic(law, prm, float(rpm), gas=gas).events
        runs += 1
        rigid = ev['rigid_valve_lift_m']
        dt = ev['pipe_time_step_s'] or 0.0
        out['lift'][i] = ev['max_valve_lift_m']
        out['ratio'][i] = ev['valve_lift_ratio'] if ev['valve_lift_ratio'] is not None \
            else math.nan
        out['pump'][i] = ev['peak_pump_pressure_pa']
        out['spill'][i] = ev['relief_spill_before_peak']
        opening = ev.get('gas_force_at_opening_n', 0.0) if gas is not None else 0.0
        out['force'][i] = math.nan if opening is None or ev['max_valve_lift_m'] <= 0.0 \
            else prm.spring_preload + opening
        flags['relief'][i] = ev['relief_spilled']
        flags['cav'][i] = ev['cavitation']
        flags['closed'][i] = ev['valve_closed']
        fails[i] = failing(ev)
    notes: list[str] = []
    hits = np.nonzero(fails)[0]
    if hits.size == 0:
        bracket = Bracket(None, [float(speeds[-1]), None])
    elif hits[0] == 0:
        bracket = Bracket(None, [None, float(speeds[0])])
        need, need_acc = static_pressure(law, prm, gas)
        if need > prm.relief_pressure:
            where = ('at any speed (where the valve accelerates, which its inertia only '
                     'makes worse)' if need_acc > prm.relief_pressure else
                     'at low speed (only the valve\'s deceleration near the nose lowers '
                     'the pressure it needs)')
            notes.append(f'the spring and the gas force alone need {need * 1e-5:.1f} bar on '
                         f'the actuator, above the relief pressure '
                         f'{prm.relief_pressure * 1e-5:.1f} bar: the gear cannot open the '
                         f'valve fully {where}')
    else:
        lo, hi = float(speeds[hits[0] - 1]), float(speeds[hits[0]])
        if refine:
            lo, hi = bisect_speed(fails_at, lo, hi, tol_rpm)
        bracket = Bracket(hi, [lo, hi])
    flew = (out['spill'] > spill_tol) & ~fails
    above = np.arange(n) > (hits[0] if hits.size else n)
    again = speeds[above & ~fails & ~flew]
    if again.size:
        notes.append('the valve opens fully again at ' + ', '.join(f'{v:g}' for v in again[:10])
                     + ' rpm, above the first failing speed (its deceleration lowers the '
                     'pressure it needs; the no-open speed is the lowest failing speed)')
    if np.any(flew):
        notes.append(f'{int(flew.sum())} speed(s) where the relief spilled more than '
                     f'{spill_tol:g} of the displacement but the valve flew to the rigid-oil '
                     'lift or past it on its own inertia (counted as opened; no lift stop '
                     'is modelled): ' + ', '.join(f'{v:g}' for v in speeds[flew][:10]) + ' rpm')
    if not np.all(flags['closed']):
        bad = speeds[~flags['closed']]
        notes.append(f'{bad.size} speed(s) where the valve had not closed by the end of the '
                     'pass (settled: false; its peak lift still counts): '
                     + ', '.join(f'{v:g}' for v in bad[:10]) + ' rpm')
    if np.any(flags['cav']):
        notes.append('cavitation from ' + f'{speeds[np.argmax(flags["cav"])]:g} rpm '
                     '(the valve motion after it is uncertain)')
    return HydraulicSweep(rpm=speeds, max_lift=out['lift'], rigid_lift=float(rigid),
                          lift_ratio=out['ratio'], peak_pump_pressure=out['pump'],
                          relief_spilled=flags['relief'], spill_before_peak=out['spill'],
                          cavitation=flags['cav'], settled=flags['closed'],
                          opening_force=out['force'], no_open=bracket,
                          seconds=time.process_time() - t0, runs=runs, spill_tol=spill_tol,
                          pipe_time_step=dt, notes=notes)
