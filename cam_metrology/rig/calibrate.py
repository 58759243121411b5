"""Calibrating the valve-train model on rig runs (docs/methods.md "Rig calibration").

Weighted least squares over all runs together: the residuals are the cycle-averaged
measured lift minus the prediction averaged into the same bins, each divided by its
bin's standard error (laser noise / sqrt(samples)). The prediction is the dynamics
node's own solver (``model.predict``) at each run's measured speed. Parameters are
moved in units of their nominal value (``x = (p - p0) / scale``); ``scipy.optimize.
least_squares`` (trust region, forward-difference Jacobian, bounds keeping the physical
ones positive) finds the minimum.

Each run also gets a free constant offset (the error of its laser zero, common to all
its bins), solved in closed form inside the residuals (``offset_free``).

Uncertainty: covariance s^2 (J^T J)^-1 at the minimum, J the Jacobian of the weighted,
offset-free residuals, s^2 = chi^2 / (m - p - runs) (so unmodelled cycle-to-cycle
variation widens the uncertainty instead of being ignored), plus what the errors of the
encoder's smoothed angle puts into the parameters (``angle_covariance``: the angle
and its ripple come from the encoder, not from this fit, so their error is propagated:
G C G^T, G the parameters' sensitivity to the angle model's coefficients, C their
covariance); the correlation matrix from the sum.

Identifiability: before any fit, the Jacobian at the nominal train is checked: a
parameter the runs do not depend on, or a pair with |correlation| >
``REFUSE_CORRELATION`` (0.99: near-singular), refuses the calibration with one line
naming the parameters and the run that would separate them. After the fit, a pair with
|correlation| > ``WARN_CORRELATION`` is reported as a warning, with the same advice.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import CliError
from cam_metrology.rig.analysis import RunData
from cam_metrology.rig.model import ZERO_SCALE, Prediction, predict, train_value, with_value
from cam_metrology.rig.ripple import has_ripple, ripple_law, run_bins

WARN_CORRELATION = 0.95
REFUSE_CORRELATION = 0.99
#: relative forward-difference step of the Jacobian (the solver is exact to rounding)
DIFF_STEP = 1e-4
#: parameters that may be zero (the others stay strictly positive)
MAY_BE_ZERO = ('damping', 'valve_damping', 'lash', 'seat_damping', 'spring_preload',
               'spring_rate')

ADVICE = {
    frozenset({'mass', 'stiffness'}): 'runs at two or more speeds far apart (the inertia '
                                      'grows with the speed squared, the stiffness does not)',
    frozenset({'mass', 'spring_rate'}): 'runs at two or more speeds far apart',
    frozenset({'mass', 'spring_preload'}): 'runs at two or more speeds far apart',
    frozenset({'spring_preload', 'lash'}): 'a known lash or preload (the lift sees them '
                                           'only together, as c x0 + F0): fit one of them',
    frozenset({'stiffness', 'lash'}): 'runs at two or more speeds, or a known lash',
    frozenset({'nose_angle', 'lash'}): 'the nose angle from the camshaft measurement '
                                       '(rig.nose_angle_deg)',
}


def advice(a: str, b: str) -> str:
    """What run (or knowledge) would separate parameters ``a`` and ``b``."""
    pair = frozenset({a, b})
    if pair in ADVICE:
        return ADVICE[pair]
    if pair & {'seat_stiffness', 'seat_damping'}:
        return 'a run with seating bounce (the seat acts only while the valve lands)'
    if pair & {'damping', 'valve_damping'}:
        return 'a run near or above the jump speed (damping shows in the vibration)'
    return 'runs at more speeds, one of them near the jump speed'


@dataclass
class Fit:
    """Result: ``names``; ``nominal``, ``value``, ``std`` [SI] per name; ``corr``
    (p, p); chi2, dof, s2; residual bins per run before/after; warnings."""

    names: tuple[str, ...]
    nominal: dict[str, float]
    value: dict[str, float]
    std: dict[str, float]
    corr: NDArray[np.float64]
    chi2: float
    dof: int
    s2: float
    nfev: int
    warnings: list[str] = field(default_factory=list)
    train: Any = None
    nose: float = 0.0


class Problem:
    """Weighted residuals of all runs as a function of the scaled parameters."""

    def __init__(self, datas: Sequence[RunData], law: Any, vt: Any, nose: float,
                 direction: int, names: Sequence[str], key: str = 'lift') -> None:
        self.datas = list(datas)
        self.law, self.vt0, self.nose0, self.direction = law, vt, nose, direction
        self.names = tuple(names)
        self.key = key
        self.nominal = {n: (nose if n == 'nose_angle' else train_value(vt, n))
                        for n in self.names}
        self.scale = {n: (abs(v) if v != 0 else ZERO_SCALE.get(n, 1.0))
                      for n, v in self.nominal.items()}
        self.cache: dict[tuple, Prediction] = {}
        self.laws: dict[tuple[int, float], Any] = {}
        self.nfev = 0
        self.ok = [np.isfinite(d.cycles.lift) & (d.cycles.count > 0) for d in self.datas]
        self.weight = [1.0 / d.cycles.stderr[k] for d, k in zip(self.datas, self.ok)]

    def values(self, x: NDArray[np.float64]) -> dict[str, float]:
        """Parameter values [SI] of the scaled vector ``x``."""
        return {n: self.nominal[n] + self.scale[n] * float(xi)
                for n, xi in zip(self.names, x)}

    def train(self, values: dict[str, float]) -> tuple[Any, float]:
        """(ValveTrain, nose angle) of parameter values."""
        vt = self.vt0
        for n, v in values.items():
            if n != 'nose_angle':
                vt = with_value(vt, n, v)
        return vt, values.get('nose_angle', self.nose0)

    def law_of(self, data: RunData, nose: float) -> tuple[Any, tuple[int, float] | None]:
        """The law that drives the run's prediction: the lobe's, or its equivalent law
        with the run's speed ripple (``ripple``), with its cache key."""
        if not has_ripple(data.speed):
            return self.law, None
        key = (id(data), nose)
        if key not in self.laws:
            if len(self.laws) > 64:
                self.laws.clear()
            self.laws[key] = ripple_law(self.law, data.speed, nose, self.direction)
        return self.laws[key], key

    def prediction(self, vt: Any, data: RunData, nose: float) -> Prediction:
        """The (cached) prediction of ``vt`` for a run: at its mean speed, with its
        speed ripple."""
        law, lkey = self.law_of(data, nose)
        key = (vt.mass, vt.stiffness, vt.damping, vt.spring_rate, vt.spring_preload,
               vt.lash, vt.valve_damping, vt.seat.stiffness, vt.seat.damping,
               data.speed.rpm, lkey)
        if key not in self.cache:
            if len(self.cache) > 256:
                self.cache.clear()
            self.cache[key] = predict(law, vt, data.speed.rpm, self.key)
        return self.cache[key]

    def run_bins(self, vt: Any, nose: float) -> list[NDArray[np.float64]]:
        """Predicted bins of every run."""
        return [run_bins(self.prediction(vt, d, nose), d, nose, self.direction)
                for d in self.datas]

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Weighted residuals (measured - predicted - offset) / standard error of every
        bin, the offset of each run (the laser zero's error) fitted with them."""
        self.nfev += 1
        vt, nose = self.train(self.values(x))
        parts = []
        for d, p, k, w in zip(self.datas, self.run_bins(vt, nose), self.ok, self.weight):
            parts.append(offset_free(d.cycles.lift[k] - p[k], w))
        r = np.concatenate(parts)
        return np.where(np.isfinite(r), r, 1e6)

    def jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Forward-difference Jacobian of ``residuals`` at ``x``."""
        r0 = self.residuals(x)
        jac = np.empty((r0.size, x.size))
        for j in range(x.size):
            xp = x.copy()
            h = DIFF_STEP * max(1.0, abs(x[j]))
            xp[j] += h
            jac[:, j] = (self.residuals(xp) - r0) / h
        return jac


def offset_free(diff: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Weighted residuals ``(diff - c) * w`` of one run with the constant ``c`` [m] that
    minimises them (the weighted mean of ``diff``).

    Measured and predicted lift are both referenced to their base circle, but the
    measured zero is a mean of noisy samples: its error is common to every bin of the
    run. Left in, it is a correlated residual that the weighted least squares would
    read as a deflection (stiffness, mass) without counting it in the uncertainty.
    Fitting a free offset per run (variable projection: the linear parameter solved in
    closed form inside the residual) gives the other parameters their honest
    covariance; its degree of freedom is taken off in ``calibrate``.
    """
    w2 = w * w
    ok = np.isfinite(diff)
    c = float(np.sum(w2[ok] * diff[ok]) / np.sum(w2[ok])) if np.any(ok) else 0.0
    return np.asarray((diff - c) * w, dtype=np.float64)


def correlation(jac: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(covariance of the scaled parameters for unit-variance residuals, correlation)."""
    jtj = jac.T @ jac
    cov = np.linalg.pinv(jtj, rcond=1e-15)
    d = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    return (np.asarray(cov, dtype=np.float64),
            np.asarray(cov / np.outer(d, d), dtype=np.float64))


def worst_pair(names: Sequence[str], corr: NDArray[np.float64]) -> tuple[str, str, float]:
    """The most correlated pair and its correlation (('', '', 0) for one parameter)."""
    best = ('', '', 0.0)
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(corr[i, j]) > abs(best[2]):
                best = (names[i], names[j], float(corr[i, j]))
    return best


def check_identifiable(problem: Problem) -> None:
    """Refuse (CliError, one line) when the runs cannot tell the parameters apart at the
    nominal train: a parameter they do not depend on, or a pair correlated beyond
    ``REFUSE_CORRELATION``."""
    x0 = np.zeros(len(problem.names))
    jac = problem.jacobian(x0)
    norms = np.linalg.norm(jac, axis=0)
    speeds = ', '.join(f'{d.speed.rpm:.0f}' for d in problem.datas)
    for n, v in zip(problem.names, norms):
        if not v > 1e-9 * max(1.0, float(np.max(norms))):
            raise CliError(f'rig calibrate: the runs ({speeds} rpm) do not depend on {n}: '
                           f'it cannot be fitted from them; {advice(n, n)} would help, or '
                           f'leave it out of --fit')
    _, corr = correlation(jac)
    a, b, c = worst_pair(problem.names, corr)
    if a and abs(c) > REFUSE_CORRELATION:
        raise CliError(f'rig calibrate: {a} and {b} cannot be separated by the runs given '
                       f'({speeds} rpm; correlation {c:+.5f}): {advice(a, b)} would; or fit '
                       f'only one of them')


def calibrate(problem: Problem, progress: Callable[[str], None] | None = None) -> Fit:
    """Fit ``problem.names`` (after ``check_identifiable``) and their uncertainties."""
    from scipy.optimize import least_squares

    names = problem.names
    lo = np.array([-np.inf if n == 'nose_angle' else
                   (-1.0 if n in MAY_BE_ZERO else -0.999) * problem.nominal[n]
                   / problem.scale[n] for n in names])
    hi = np.full(len(names), np.inf)
    sol = least_squares(problem.residuals, np.zeros(len(names)), jac=_jac(problem),
                        bounds=(lo, hi), method='trf', x_scale=1.0, xtol=1e-10,
                        ftol=1e-12, gtol=1e-12, max_nfev=60)
    x = sol.x
    jac = problem.jacobian(x)
    r = problem.residuals(x)
    m, p = r.size, len(names)
    chi2 = float(r @ r)
    dof = max(1, m - p - len(problem.datas))     # one offset per run
    s2 = chi2 / dof
    cov, _ = correlation(jac)
    total = cov * s2 + angle_covariance(problem, x, jac)
    d = np.sqrt(np.maximum(np.diag(total), 1e-300))
    corr = np.asarray(total / np.outer(d, d), dtype=np.float64)
    scale = np.array([problem.scale[n] for n in names])
    std = np.sqrt(np.maximum(np.diag(total), 0.0)) * scale
    values = problem.values(x)
    vt, nose = problem.train(values)
    fit = Fit(names=names, nominal=dict(problem.nominal), value=values,
              std={n: float(s) for n, s in zip(names, std)}, corr=corr, chi2=chi2, dof=dof,
              s2=s2, nfev=problem.nfev, train=vt, nose=nose)
    speeds = ', '.join(f'{d.speed.rpm:.0f}' for d in problem.datas)
    for i in range(p):
        for j in range(i + 1, p):
            if abs(corr[i, j]) > WARN_CORRELATION:
                fit.warnings.append(
                    f'{names[i]} and {names[j]} are poorly identifiable from these runs '
                    f'({speeds} rpm; correlation {corr[i, j]:+.4f}): '
                    f'{advice(names[i], names[j])} would separate them')
    for n in names:
        if n != 'nose_angle' and n not in MAY_BE_ZERO and values[n] <= 0:
            fit.warnings.append(f'{n} went to its bound (0): the runs do not support a value')
    return fit


def angle_covariance(problem: Problem, x: NDArray[np.float64], jac: NDArray[np.float64],
                     ) -> NDArray[np.float64]:
    """Covariance of the scaled parameters from the error of each run's smoothed encoder
    angle (``encoder.angle_columns``: the angle model's coefficients with their
    covariance C): for each principal direction u_j of C (variance l_j), the run's angle
    is moved by columns @ u_j sqrt(l_j) (and its ripple with it), its cycles re-binned
    and its weighted residuals recomputed; the change dr gives g = (J^T J)^-1 J^T dr,
    and the covariance is the sum of g g^T. The angle comes from the encoder, not from
    this fit, so its error is propagated rather than fitted."""
    from cam_metrology.rig.cycles import average_cycles
    from cam_metrology.rig.encoder import DRIFT_DEGREE, angle_columns

    p = jac.shape[1]
    out = np.zeros((p, p))
    solve = np.linalg.pinv(jac.T @ jac, rcond=1e-15) @ jac.T
    vt, nose = problem.train(problem.values(x))
    start = 0
    for d, k, w in zip(problem.datas, problem.ok, problem.weight):
        rows = slice(start, start + int(np.sum(k)))
        start = rows.stop
        sp = d.speed
        if not sp.angle_sigma > 0:
            continue
        cols, cov = angle_columns(d.run.time, sp)
        lam, vec = np.linalg.eigh(cov)
        base = _run_residuals(problem, vt, nose, d, k, w)
        for lj, uj in zip(lam, vec.T):
            if not lj > 0:
                continue
            step = uj * np.sqrt(lj)
            harm = step[DRIFT_DEGREE + 1:]
            moved_sp = replace(sp, theta=sp.theta + cols @ step,
                               ripple_cos=sp.ripple_cos + harm[0::2],
                               ripple_sin=sp.ripple_sin + harm[1::2])
            cyc = average_cycles(moved_sp.encoder, d.run.lift, d.run.velocity,
                                 d.cycles.step, d.run.name)
            moved = replace(d, speed=moved_sp, cycles=cyc)
            dr = np.nan_to_num(_run_residuals(problem, vt, nose, moved, k, w) - base)
            g = solve[:, rows] @ dr
            out += np.outer(g, g)
    return out


def _run_residuals(problem: Problem, vt: Any, nose: float, data: RunData,
                   k: NDArray[np.bool_], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Weighted, offset-free residuals of one run (its own ripple law, not cached)."""
    law = ripple_law(problem.law, data.speed, nose, problem.direction) \
        if has_ripple(data.speed) else problem.law
    pred = predict(law, vt, data.speed.rpm, problem.key)
    p = run_bins(pred, data, nose, problem.direction)
    return offset_free(data.cycles.lift[k] - p[k], w)


def _jac(problem: Problem) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    def jac(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return problem.jacobian(x)
    return jac


def corr_dict(names: Sequence[str], corr: NDArray[np.float64]) -> dict[str, Any]:
    """JSON form of a correlation matrix."""
    return {'names': list(names), 'matrix': [[float(v) for v in row] for row in corr]}


def bins_rms(problem: Problem, vt: Any, nose: float) -> list[float]:
    """rms [m] of measured - predicted per run for a train."""
    out = []
    for d, p, k in zip(problem.datas, problem.run_bins(vt, nose), problem.ok):
        r = d.cycles.lift[k] - p[k]
        out.append(float(np.sqrt(np.mean(r[np.isfinite(r)] ** 2))))
    return out


__all__ = ['Problem', 'Fit', 'calibrate', 'check_identifiable', 'corr_dict', 'bins_rms']
