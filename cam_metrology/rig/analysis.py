"""One rig run from samples to cam angle, and its comparison with the dynamics.

``prepare_run``: encoder speed (``encoder``), cycle averaging with the laser zero and
noise (``cycles``). ``initial_nose``: the nose angle that best lays the rigid lift over
the averaged lift (a start for the fit). ``compare_run``: measured events, the
prediction's events and the residual measured - predicted (rms, max, where).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_metrology.rig.cycles import TWO_PI, Cycles, average_cycles, bin_means
from cam_metrology.rig.encoder import Speed, encoder_speed
from cam_metrology.rig.events import measured_events
from cam_metrology.rig.model import Prediction, lobe_alpha
from cam_metrology.rig.ripple import run_bins
from cam_metrology.rig.runs import RigRun
from cam_metrology.rig.spec import RigSpec


@dataclass
class RunData:
    """A run ready for comparison: the samples, the speed, the averaged cycles."""

    run: RigRun
    speed: Speed
    cycles: Cycles

    @property
    def omega(self) -> float:
        """Mean camshaft speed [rad/s]."""
        return self.speed.rpm * math.pi / 30.0


def prepare_run(run: RigRun, spec: RigSpec) -> RunData:
    """Speed from the encoder, then the cycle-averaged lift on encoder-angle bins."""
    speed = encoder_speed(run.time, run.angle, run.name, spec.max_speed_variation)
    cyc = average_cycles(speed.encoder, run.lift, run.velocity, spec.step, run.name)
    return RunData(run=run, speed=speed, cycles=cyc)


def rigid_lift(law: Any, vt: Any, alpha: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rigid valve lift k h(alpha) - x0 [m] (negative on the base circle)."""
    return vt.rocker_ratio * law(alpha) - vt.lash


def rigid_bins(data: RunData, law: Any, vt: Any, nose: float, direction: int
               ) -> NDArray[np.float64]:
    """The rigid lift averaged into the run's bins like the measurement [m]."""
    cyc = data.cycles
    u = rigid_lift(law, vt, lobe_alpha(cyc.enc, nose, direction))
    return bin_means(cyc.index, u, cyc.phi.size)[0]


def initial_nose(data: RunData, law: Any, vt: Any, direction: int) -> float:
    """Encoder angle [rad] of the nose that best matches the rigid lift to the averaged
    lift, searched over every bin (the fit refines it)."""
    cyc = data.cycles
    m = np.nan_to_num(cyc.lift)
    best, best_sse = 0.0, math.inf
    for nose in cyc.phi:
        u = np.maximum(rigid_lift(law, vt, lobe_alpha(cyc.phi_mean, nose, direction)), 0.0)
        sse = float(np.sum((m - u) ** 2))
        if sse < best_sse:
            best, best_sse = float(nose), sse
    return best


def residual_stats(data: RunData, pbins: NDArray[np.float64], nose: float,
                   direction: int) -> dict[str, Any]:
    """rms and largest |measured - predicted| [m] over the bins, and where (lobe deg)."""
    r = data.cycles.lift - pbins
    ok = np.isfinite(r)
    i = int(np.nanargmax(np.abs(r)))
    alpha = lobe_alpha(data.cycles.phi_mean[i], nose, direction)
    return {'rms_m': float(np.sqrt(np.mean(r[ok] ** 2))), 'max_m': float(r[i]),
            'max_deg': math.degrees(float(alpha))}


def compare_run(data: RunData, pred: Prediction, law: Any, vt: Any, nose: float,
                direction: int, spec: RigSpec) -> dict[str, Any]:
    """The JSON entry of a run: speed, revolutions, measured events, the prediction's
    events at the measured speed, and the residual."""
    cyc = data.cycles
    alpha = lobe_alpha(cyc.phi_mean, nose, direction)
    ev = measured_events(alpha, cyc.lift, cyc.stderr, rigid_bins(data, law, vt, nose, direction),
                         data.omega,
                         spec.checking_height, spec.separation_sigmas, spec.separation_min,
                         cyc.velocity)
    pbins = run_bins(pred, data, nose, direction)
    pev = pred.run.events
    sp = data.speed
    out: dict[str, Any] = {
        'name': data.run.name, 'rpm': sp.rpm, 'rpm_std': sp.rpm_std,
        'rpm_min': sp.rpm_min, 'rpm_max': sp.rpm_max,
        'speed_variation': sp.variation, 'revolutions': sp.revolutions,
        'cycles': cyc.cycles, 'samples': int(data.run.time.size),
        'encoder_quantum_deg': math.degrees(sp.quantum),
        'laser_zero_m': cyc.zero, 'laser_noise_m': cyc.noise,
        'bin_deg': math.degrees(cyc.step),
        'scatter_rms_m': float(np.sqrt(np.nanmean(cyc.scatter ** 2)))
        if np.any(np.isfinite(cyc.scatter)) else None,
        'vibrometer': cyc.velocity is not None,
        'channels': sorted(data.run.channels),
    }
    out.update(ev.as_dict())
    if ev.notes:
        out['notes'] = list(ev.notes)
    out['input_notes'] = list(data.run.notes)
    out['predicted'] = {
        'separated': bool(pev.get('jump')),
        'separation_angle_deg': (pev['separations'][0][0] if pev.get('separations')
                                 else None),
        'seating_velocity_m_s': pev.get('seating_velocity_m_s'),
        'bounce_count': pev.get('bounce_count'), 'bounce_height_m': pev.get('bounce_height_m'),
        'max_lift_m': pev.get('max_valve_lift_m'), 'settled': pev.get('settled'),
        'note': pev.get('note')}
    stats = residual_stats(data, pbins, nose, direction)
    out['residual_rms_m'] = stats['rms_m']
    out['residual_max_m'] = stats['max_m']
    out['residual_max_deg'] = stats['max_deg']
    return out


def curves(data: RunData, pbins: NDArray[np.float64], nose: float, direction: int
           ) -> dict[str, NDArray[np.float64]]:
    """Arrays of the overlay plot, sorted by lobe angle: alpha_deg, measured, scatter,
    predicted [m]."""
    cyc = data.cycles
    a = np.degrees(lobe_alpha(cyc.phi_mean, nose, direction))
    o = np.argsort(a)
    return {'alpha_deg': a[o], 'measured_m': cyc.lift[o], 'scatter_m': cyc.scatter[o],
            'predicted_m': pbins[o]}


__all__ = ['RunData', 'prepare_run', 'initial_nose', 'compare_run', 'residual_stats',
           'rigid_lift', 'curves', 'TWO_PI']
