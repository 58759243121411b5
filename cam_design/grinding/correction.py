"""Measure -> correct: fit machining errors to a measured lift error and write a corrected
wheel-centre table (docs/grinding.md).

The measured lift error e(alpha) (measured minus design lift of the measuring follower,
at design angles) is modelled as sum_k x_k S_k(alpha) + c: S_k the sensitivities of
``machining_error`` and c a constant (the lift is referenced to a measured base circle,
so a uniform offset is not an error of the shape). Least squares on columns scaled to
unit norm gives x_k, their standard uncertainties from the residual scatter, and the
condition number; nearly indistinguishable sources are named and the fit is marked
unsettled (never a silent number).

The corrected table pre-compensates the estimates: the wheel path for the estimated
actual wheel radius R_w + dR, minus the estimated run-out, turned back by the estimated
index error, moved back by the estimated centre-distance error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, unit_slip
from cam_design.follower import Follower
from cam_design.grinding.curve import PolarCurveLift, jet_cos_sin, polar_jets
from cam_design.grinding.machining_error import (SOURCES, TableCurve, path_curve,
                                                 sensitivities)
from cam_design.grinding.master_cam import Cradle, MasterCam
from cam_design.grinding.wheel_path import WheelPath

#: scaled condition number above which the fit is marked unsettled
CONDITION_LIMIT = 1e4
#: largest plausible measured lift error [m]: a larger one is a unit slip (um as m)
MAX_LIFT_ERROR_M = 2e-3
#: below this fraction of the error rms explained by the fit, a warning is given
EXPLAINED_LIMIT = 0.8
#: default sources of a fit (the CNC centre distance is a wheel-radius change plus an
#: offset: indistinguishable from them, so it is fitted only on a cradle)
DEFAULT_SOURCES = ('wheel_radius', 'index', 'run_out_x', 'run_out_y')


@dataclass
class ErrorFit:
    """Least-squares estimates [m or rad] with standard uncertainties."""

    values: dict[str, float]
    std: dict[str, float]
    offset_m: float
    residual_rms_m: float
    condition: float
    points: int
    settled: bool
    warnings: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, object]:
        return {'values': self.values, 'std': self.std, 'offset_m': self.offset_m,
                'residual_rms_m': self.residual_rms_m, 'condition': self.condition,
                'points': self.points, 'settled': self.settled, 'warnings': self.warnings}


def fit_errors(path: WheelPath, alpha: ArrayLike, lift_error: ArrayLike, *,
               sources: tuple[str, ...] = DEFAULT_SOURCES, cradle: Cradle | None = None,
               master: MasterCam | None = None, probe: Follower | None = None,
               key: str = 'lift_error', exact_iterations: int = 0) -> ErrorFit:
    """Fit the error ``sources`` (plus a constant) to ``lift_error`` [m] at ``alpha``.

    ``exact_iterations`` > 0: after the linear fit, that many Gauss-Newton steps whose
    model is the exact grinding simulation (removes the bias of the linearisation for
    large errors, e.g. 2.4 % of a 5 mm wheel-radius error on a 200 mm wheel); not with
    ``master_follower_radius``, which the simulation does not model."""
    a = np.asarray(alpha, dtype=float).reshape(-1)
    e = np.asarray(lift_error, dtype=float).reshape(-1)
    if a.size != e.size:
        raise InputError(key, f'{e.size} values for {a.size} angles', 'one error per angle')
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(e))):
        raise InputError(key, 'non-finite values', 'finite angles [rad] and errors [m]')
    worst = float(np.max(np.abs(e))) if e.size else 0.0
    if worst > MAX_LIFT_ERROR_M:   # a machining error is microns, not millimetres
        slip = unit_slip(worst, MAX_LIFT_ERROR_M)
        hint = '' if slip is None else f'; the values look like {slip[0]}'
        raise InputError(key, f'a largest lift error of {worst:g} m', 'lift errors in metres '
                         f'(at most {MAX_LIFT_ERROR_M * 1e3:g} mm){hint}')
    names = tuple(sources)
    if len(set(names)) != len(names) or not names:
        raise InputError('sources', names, 'distinct names among ' + ', '.join(SOURCES))
    if a.size < len(names) + 3:
        raise InputError(key, f'{a.size} points', f'at least {len(names) + 3} points')
    sens = sensitivities(path, a, cradle=cradle, master=master, sources=names, probe=probe)
    cols = [sens[n] for n in names] + [np.ones_like(a)]
    mat = np.column_stack(cols)
    scale = np.linalg.norm(mat, axis=0)
    scale[scale == 0] = 1.0
    ms = mat / scale
    coef, *_ = np.linalg.lstsq(ms, e, rcond=None)
    resid = e - ms @ coef
    dof = a.size - mat.shape[1]
    sigma2 = float(resid @ resid) / dof
    sv = np.linalg.svd(ms, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    warnings = []
    settled = cond < CONDITION_LIMIT
    cov = np.full((mat.shape[1], mat.shape[1]), np.nan)
    if math.isfinite(cond):
        cov = sigma2 * np.linalg.inv(ms.T @ ms)
    if not settled:
        with np.errstate(invalid='ignore', divide='ignore'):
            corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
        labels = list(names) + ['offset']
        np.fill_diagonal(corr, 0.0)
        i, j = np.unravel_index(int(np.nanargmax(np.abs(corr))) if np.any(np.isfinite(corr))
                                else 0, corr.shape)
        warnings.append(f'ill-conditioned fit (condition {cond:.3g}): {labels[i]} and '
                        f'{labels[j]} are nearly indistinguishable on this cam; fit fewer '
                        'sources')
    values = coef / scale
    diag = np.diag(cov)
    std = np.sqrt(np.where(diag >= 0, diag, np.nan)) / scale   # NaN: not determined
    if exact_iterations and settled:
        if 'master_follower_radius' in names:
            raise InputError('exact_iterations', exact_iterations,
                             '0 when fitting master_follower_radius (not simulated)')
        values, resid = _refine(path, a, e, names, values, ms, scale, cradle, probe,
                                exact_iterations)
        sigma2 = float(resid @ resid) / dof
        std = np.sqrt(np.diag(sigma2 * np.linalg.inv(ms.T @ ms))) / scale
    spread = float(np.std(e))
    explained = 1.0 - float(np.sqrt(np.mean(resid ** 2))) / spread if spread > 0 else 1.0
    if explained < EXPLAINED_LIMIT:
        warnings.append(f'the fitted sources explain only {100 * max(explained, 0):.0f} % '
                        'of the measured error (rms of residual vs error): another source, '
                        'a different probe, or a non-systematic error; the correction '
                        'removes only the fitted part')
    return ErrorFit({n: float(v) for n, v in zip(names, values[:-1])},
                    {n: float(s) for n, s in zip(names, std[:-1])}, float(values[-1]),
                    float(math.sqrt(sigma2)), cond, int(a.size), settled, warnings)


def _refine(path: WheelPath, a: NDArray[np.float64], e: NDArray[np.float64],
            names: tuple[str, ...], values: NDArray[np.float64], ms: NDArray[np.float64],
            scale: NDArray[np.float64], cradle: Cradle | None, probe: Follower | None,
            iterations: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss-Newton on the exact simulation, Jacobian = the sensitivities."""
    from cam_design.follower import convert_lift
    from cam_design.grinding.machining_error import GroundCam, MachineErrors

    ref = path.design_law if probe is None else convert_lift(
        path.design_law, path.base_radius, path.design_follower, probe, key='probe')
    design = ref(a)
    values = values.copy()
    resid = e
    for _ in range(iterations):
        errors = MachineErrors(**dict(zip(names, (float(v) for v in values[:-1]))))
        sim = GroundCam(path, errors, cradle=cradle, probe=probe).lift(a)[0] - design
        resid = e - sim - values[-1]
        step, *_ = np.linalg.lstsq(ms, resid, rcond=None)
        values = values + step / scale
    resid = resid - ms @ step
    return values, resid


def corrected_curve(path: WheelPath, fit: ErrorFit, *, cradle: Cradle | None = None
                    ) -> tuple[TableCurve, float]:
    """(table curve, table wheel radius [m]) that pre-compensate ``fit``'s estimates."""
    v = fit.values
    radius = path.wheel_radius + v.get('wheel_radius', 0.0)
    if not radius > 0:
        raise InputError('wheel_radius', radius, 'a corrected wheel radius > 0')
    fresh = WheelPath(path.design_law, path.base_radius, _inline_design(path), radius)
    base = path_curve(fresh)
    ci, si = math.cos(-v.get('index', 0.0)), math.sin(-v.get('index', 0.0))
    tx, ty = v.get('run_out_x', 0.0), v.get('run_out_y', 0.0)
    dc = v.get('centre_distance', 0.0)

    def curve(s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        x, y = base(s)
        x = x - tx
        y = y - ty
        x, y = ci * x - si * y, si * x + ci * y
        if dc:
            rad, ang = polar_jets(x, y)
            if cradle is not None:
                ang = ang - cradle.wheel_jets(rad)['phi']
            c, sn = jet_cos_sin(ang)
            x, y = x - dc * c, y - dc * sn
        return x, y
    return curve, radius


def _inline_design(path: WheelPath) -> Any:
    from cam_design.grinding.wheel_path import Design

    f = path.design_follower
    return Design(f.kind, f.radius if f.kind == 'roller' else 0.0)


def curve_table(curve: TableCurve, base: float, alpha: ArrayLike,
                key: str = 'corrected table') -> dict[str, NDArray[np.float64]]:
    """Polar table of a table curve: ``angle_rad``, ``wheel_centre_distance_m``."""
    lift = PolarCurveLift(curve, base, key=key)
    a = np.asarray(alpha, dtype=float).reshape(-1)
    return {'angle_rad': a, 'wheel_centre_distance_m': base + lift.solve(a)[0]}
