"""``rig analyze`` and ``rig calibrate`` as functions of a parsed scene and runs: the JSON
result and the curves of the plots (the CLI, the rig node and the tests call these).

JSON (docs/contract.md "Valve-train rig"): ``lobe``, ``nose_angle_deg`` with
``nose_angle_std_deg`` and ``nose_angle_source`` (scene | fitted), ``runs[i]`` (speed,
revolutions, measured events, ``predicted`` events, ``residual_rms_m`` /
``residual_max_m`` / ``residual_max_deg`` each with ``nominal`` and, after a
calibration, ``calibrated``), ``jump_speed_rpm`` {nominal[, calibrated]}; calibrate adds
``parameters.<name>`` {value, std, nominal, unit}, ``correlation``, ``chi2``, ``dof``,
``reduced_chi2``, ``warnings``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from cam_design.errors import InputError
from cam_metrology.rig.analysis import RunData, compare_run, curves, initial_nose, prepare_run
from cam_metrology.rig.calibrate import (Fit, Problem, calibrate, check_identifiable,
                                         corr_dict)
from cam_metrology.rig.ripple import run_bins
from cam_metrology.rig.runs import RigRun
from cam_metrology.rig.spec import RigSpec, rig_of_scene

UNITS = {'stiffness': 'N/m', 'damping': 'N s/m', 'mass': 'kg', 'spring_rate': 'N/m',
         'spring_preload': 'N', 'lash': 'm', 'valve_damping': 'N s/m',
         'seat_stiffness': 'N/m', 'seat_damping': 'N s/m', 'nose_angle': 'deg'}


@dataclass
class RigSetup:
    """What every rig command needs from the scene: the rig block, the lobe's design law,
    the nominal valve train, the direction."""

    spec: RigSpec
    law: Any
    train: Any
    direction: int
    lobe_key: str

    @classmethod
    def of_scene(cls, scene: Any) -> 'RigSetup':
        """From a parsed scene (InputError without a rig block or valve_train)."""
        from cam_metrology.dynamics.core import lobe_key

        spec = rig_of_scene(scene)
        if scene.valve_train is None:
            raise InputError('valve_train', None, 'a valve_train block in the scene (the '
                             'nominal train the rig runs are compared with)')
        if scene.valve_train.model not in ('sdof', 'mdof'):
            raise InputError('valve_train.model', scene.valve_train.model,
                             'sdof or mdof for the rig (a cam-driven valve train)')
        return cls(spec=spec, law=scene.lobe(spec.lobe).lift, train=scene.valve_train,
                   direction=scene.direction, lobe_key=lobe_key(scene, spec.lobe))


@dataclass
class RigOutcome:
    """The JSON result and, per run, the plot curves (nominal and calibrated)."""

    result: dict[str, Any]
    curves: list[dict[str, Any]] = field(default_factory=list)


def prepare_runs(runs: Sequence[RigRun], setup: RigSetup) -> list[RunData]:
    """Every run prepared (the first bad one raises its one-line InputError)."""
    if not runs:
        raise InputError('RUN', 'none', 'one or more rig runs (CSV files or bags)')
    return [prepare_run(r, setup.spec) for r in runs]


def fit_nose(datas: Sequence[RunData], setup: RigSetup) -> tuple[float, float, Problem]:
    """Nose angle [rad] and its standard uncertainty fitted with the nominal train."""
    start = initial_nose(min(datas, key=lambda d: d.speed.rpm), setup.law, setup.train,
                         setup.direction)
    pr = Problem(datas, setup.law, setup.train, start, setup.direction, ('nose_angle',),
                 setup.lobe_key)
    fit = calibrate(pr)
    return fit.value['nose_angle'], fit.std['nose_angle'], pr


def _nose_fields(nose: float, std: float | None, source: str) -> dict[str, Any]:
    return {'nose_angle_deg': math.degrees(nose) % 360.0,
            'nose_angle_std_deg': None if std is None else math.degrees(std),
            'nose_angle_source': source}


def jump_speed(setup: RigSetup, train: Any, datas: Sequence[RunData], points: int = 28
               ) -> float | None:
    """Jump speed [rpm] of ``train``: the speed sweep of ``cam-bench dynamics --sweep``
    (SDOF, or the exact MDOF model for ``model: mdof``) over ``points`` speeds from 0.3
    to 3 times the run speeds, refined to 1 rpm; None above the range, or for a train
    with a lash adjuster or cylinder gas (no sweep)."""
    from cam_design.train.run import train_from_valve_train
    from cam_design.valve_train.sweep import sweep

    if train.model not in ('sdof', 'mdof') or train.hla is not None or train.gas is not None:
        return None
    rpms = [d.speed.rpm for d in datas]
    grid = np.linspace(0.3 * min(rpms), 3.0 * max(rpms), points)
    res = sweep(setup.law, train_from_valve_train(train).sweep_params(), grid.tolist(),
                step_deg=0.25, tol_rpm=1.0, check=False, key=setup.lobe_key)
    return res.jump_speed_rpm


def _jumps(setup: RigSetup, datas: Sequence[RunData], jump: bool, calibrated: Any
           ) -> dict[str, Any]:
    """``jump_speed_rpm``: {nominal[, calibrated]} (None: no jump in the swept range,
    or ``skipped``)."""
    out: dict[str, Any] = {'nominal': jump_speed(setup, setup.train, datas) if jump else None}
    if calibrated is not None:
        out['calibrated'] = jump_speed(setup, calibrated, datas) if jump else None
    if not jump:
        out['skipped'] = True
    return out


def _run_entry(data: RunData, problem: Problem, setup: RigSetup, train: Any, nose: float
               ) -> dict[str, Any]:
    pred = problem.prediction(train, data, nose)
    return compare_run(data, pred, setup.law, train, nose, setup.direction, setup.spec)


def _curve(data: RunData, problem: Problem, setup: RigSetup, train: Any, nose: float
           ) -> dict[str, Any]:
    pred = problem.prediction(train, data, nose)
    return curves(data, run_bins(pred, data, nose, setup.direction), nose, setup.direction)


def _split(entry: dict[str, Any], before: dict[str, Any] | None) -> dict[str, Any]:
    """residual_* fields as {nominal[, calibrated]}."""
    for k in ('residual_rms_m', 'residual_max_m', 'residual_max_deg'):
        if before is None:
            entry[k] = {'nominal': entry[k]}
        else:
            entry[k] = {'nominal': before[k], 'calibrated': entry[k]}
    return entry


def analyze(scene: Any, runs: Sequence[RigRun], *, jump: bool = True) -> RigOutcome:
    """``rig analyze``: per run the measured speed, events and residual against the
    nominal train's prediction at the measured speed."""
    setup = RigSetup.of_scene(scene)
    datas = prepare_runs(runs, setup)
    if setup.spec.nose_angle is None:
        nose, std, problem = fit_nose(datas, setup)
        nose_fields = _nose_fields(nose, std, 'fitted')
    else:
        nose = setup.spec.nose_angle
        problem = Problem(datas, setup.law, setup.train, nose, setup.direction, (),
                          setup.lobe_key)
        nose_fields = _nose_fields(nose, None, 'scene')
    entries = [_split(_run_entry(d, problem, setup, setup.train, nose), None) for d in datas]
    result: dict[str, Any] = {'lobe': setup.spec.lobe, **nose_fields, 'runs': entries,
                              'jump_speed_rpm': _jumps(setup, datas, jump, None)}
    crv = [{'name': d.run.name, 'rpm': d.speed.rpm,
            'nominal': _curve(d, problem, setup, setup.train, nose)} for d in datas]
    return RigOutcome(result=result, curves=crv)


def calibrate_runs(scene: Any, runs: Sequence[RigRun], names: Sequence[str], *,
                   jump: bool = True) -> tuple[RigOutcome, Fit]:
    """``rig calibrate``: fit ``names`` over all runs (the nose angle too when the scene
    does not give it), with uncertainties, correlations, identifiability warnings,
    residuals before/after and the jump speeds."""
    setup = RigSetup.of_scene(scene)
    datas = prepare_runs(runs, setup)
    names = tuple(names)
    notes = []
    if setup.spec.nose_angle is None:
        nose0, _, _ = fit_nose(datas, setup)
        if 'nose_angle' not in names:
            names = names + ('nose_angle',)
            notes.append('rig.nose_angle_deg not in the scene: the nose angle is fitted '
                         'with the valve-train parameters')
    else:
        nose0 = setup.spec.nose_angle
    problem = Problem(datas, setup.law, setup.train, nose0, setup.direction, names,
                      setup.lobe_key)
    check_identifiable(problem)
    fit = calibrate(problem)
    before = [_run_entry(d, problem, setup, setup.train, nose0) for d in datas]
    after = [_run_entry(d, problem, setup, fit.train, fit.nose) for d in datas]
    entries = [_split(a, b) for a, b in zip(after, before)]
    for e, b in zip(entries, before):
        e['predicted_nominal'] = b['predicted']
    params = {}
    for n in names:
        conv = math.degrees if n == 'nose_angle' else float
        params[n] = {'value': conv(fit.value[n]), 'std': conv(fit.std[n]),
                     'nominal': conv(fit.nominal[n]), 'unit': UNITS[n]}
    nose_std = fit.std.get('nose_angle')
    result: dict[str, Any] = {
        'lobe': setup.spec.lobe,
        **_nose_fields(fit.nose, nose_std, 'fitted' if 'nose_angle' in names else 'scene'),
        'fit': list(names), 'parameters': params,
        'correlation': corr_dict(names, fit.corr),
        'chi2': fit.chi2, 'dof': fit.dof, 'reduced_chi2': fit.s2,
        'model_evaluations': fit.nfev,
        'warnings': fit.warnings, 'notes': notes, 'runs': entries,
        'jump_speed_rpm': _jumps(setup, datas, jump, fit.train)}
    crv = [{'name': d.run.name, 'rpm': d.speed.rpm,
            'nominal': _curve(d, problem, setup, setup.train, nose0),
            'calibrated': _curve(d, problem, setup, fit.train, fit.nose)} for d in datas]
    return RigOutcome(result=result, curves=crv), fit
