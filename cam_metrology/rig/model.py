"""The dynamics' prediction of a rig run and the valve-train parameters a fit may move.

The prediction is the periodic valve motion of the scene's valve train at the run's
measured mean speed, computed by the valve-train run the dynamics node uses
(``cam_design.train.run.run_train``: the same solver as ``cam-bench dynamics`` and the
live node). It is evaluated at every
sample's lobe angle and averaged into the run's bins exactly as the measurement is, and
referenced to its own seated level over the same base-circle bins, so averaging and
the laser zero cancel between measured and predicted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.rig.cycles import TWO_PI, Cycles, bin_means

#: names ``rig calibrate --fit`` accepts: valve_train keys, the seat's, the nose angle
FIT_NAMES = ('stiffness', 'damping', 'mass', 'spring_rate', 'spring_preload', 'lash',
             'valve_damping', 'seat_stiffness', 'seat_damping', 'nose_angle')
#: the scale of a parameter whose nominal value is 0 (its unit: SI)
ZERO_SCALE = {'damping': 10.0, 'valve_damping': 10.0, 'lash': 1.0e-4,
              'seat_damping': 100.0, 'nose_angle': math.radians(1.0)}
#: output step [deg] of the predictions (the solver is exact between nodes)
PREDICT_STEP_DEG = 0.1


def parse_fit_names(text: str) -> tuple[str, ...]:
    """'stiffness,damping' -> ('stiffness', 'damping'); InputError for other names."""
    names = tuple(n.strip() for n in str(text).split(',') if n.strip())
    if not names:
        raise InputError('--fit', text, 'one or more of ' + ', '.join(FIT_NAMES))
    for n in names:
        if n not in FIT_NAMES:
            raise InputError('--fit', n, 'a parameter that can be fitted: '
                             + ', '.join(FIT_NAMES))
    if len(set(names)) != len(names):
        raise InputError('--fit', text, 'each name once')
    return names


def train_value(vt: Any, name: str) -> float:
    """The value [SI] of a fit name in a ValveTrain (not the nose angle)."""
    if name == 'seat_stiffness':
        return float(vt.seat.stiffness)
    if name == 'seat_damping':
        return float(vt.seat.damping)
    return float(getattr(vt, name))


def with_value(vt: Any, name: str, value: float) -> Any:
    """A copy of ValveTrain ``vt`` with parameter ``name`` set to ``value`` [SI]."""
    if name == 'seat_stiffness':
        return replace(vt, seat=replace(vt.seat, stiffness=float(value)))
    if name == 'seat_damping':
        return replace(vt, seat=replace(vt.seat, damping=float(value)))
    return replace(vt, **{name: float(value)})


@dataclass(frozen=True)
class Prediction:
    """Periodic valve motion at one speed on the lobe angle: ``alpha`` [rad] (one
    revolution, both ends), ``lift`` [m], ``slope`` d lift / d alpha [m/rad]; ``run`` the
    dynamics Run (events)."""

    rpm: float
    alpha: NDArray[np.float64]
    lift: NDArray[np.float64]
    slope: NDArray[np.float64]
    run: Any

    def at(self, alpha: NDArray[np.float64]) -> NDArray[np.float64]:
        """Lift [m] at lobe angles ``alpha`` [rad] (any, wrapped onto the revolution):
        cubic Hermite between the solver's nodes."""
        a0 = self.alpha[0]
        a = a0 + np.mod(alpha - a0, TWO_PI)
        k = np.clip(np.searchsorted(self.alpha, a, side='right') - 1, 0, self.alpha.size - 2)
        h = self.alpha[k + 1] - self.alpha[k]
        t = (a - self.alpha[k]) / h
        y0, y1 = self.lift[k], self.lift[k + 1]
        m0, m1 = self.slope[k] * h, self.slope[k + 1] * h
        t2, t3 = t * t, t * t * t
        return ((2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + t) * m0
                + (-2 * t3 + 3 * t2) * y1 + (t3 - t2) * m1)


def predict(law: Any, vt: Any, rpm: float, key: str = 'lift') -> Prediction:
    """The dynamics' periodic valve motion at ``rpm`` (the dynamics node's run)."""
    from cam_design.train.run import run_train, train_from_valve_train

    run = run_train(law, train_from_valve_train(vt), rpm, step_deg=PREDICT_STEP_DEG, key=key)
    omega = rpm * math.pi / 30.0
    alpha = np.asarray(run.alpha, dtype=float)
    if alpha[-1] - alpha[0] < TWO_PI - 1e-9:
        raise InputError('valve_train.model', getattr(vt, 'model', 'sdof'),
                         'a model whose run covers a whole revolution (sdof or mdof)')
    return Prediction(rpm=float(rpm), alpha=alpha, lift=np.asarray(run.lift, dtype=float),
                      slope=np.asarray(run.velocity, dtype=float) / omega, run=run)


def lobe_alpha(enc: NDArray[np.float64], nose: float, direction: int) -> NDArray[np.float64]:
    """Lobe angle [rad] in (-pi, pi] of encoder angles ``enc`` (contract convention)."""
    a = direction * (np.asarray(enc) - nose)
    return np.pi - np.mod(np.pi - a, TWO_PI)


def predicted_bins(pred: Prediction, cyc: Cycles, nose: float, direction: int,
                   phase: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """The prediction averaged into the run's bins like the measurement [m], referenced
    to its seated level over the run's base-circle bins. ``phase``: the samples' angle
    on the prediction's clock (``ripple.sample_phase``; default their lobe angle)."""
    y = pred.at(lobe_alpha(cyc.enc, nose, direction) if phase is None else phase)
    mean, _ = bin_means(cyc.index, y, cyc.phi.size)
    return mean - float(np.nanmean(mean[cyc.base]))
