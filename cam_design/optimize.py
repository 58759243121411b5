"""Optimisation of a cam design: the best lift law of a family under design constraints.

A SPEC (a mapping, usually a YAML file) names

* ``family``: a lift-law family of ``cam_design.lift_laws.from_spec``;
* ``fixed``: the family's parameters that stay fixed, plus two generic ones:
  ``max_lift`` [m] and ``half_duration_deg`` (alpha from the start of the lobe to its
  nose, ramp included) or the family's own ``half_angle`` [rad];
* ``free``: ``{parameter path: [low, high]}`` (a path like ``positive_width`` or
  ``segments[1].width``; ``[low, high, integer]`` for whole numbers such as exponents);
  omitted: the family's defaults (``DEFAULT_FREE``);
* ``objective``: a metric to maximise or minimise (``fullness`` by default), or
  ``{weighted: {metric: weight, ...}}`` (a weighted sum of metrics, each divided by its
  value at the start point; positive weight = more is better);
* ``constraints``: ``{name: limit}`` (``CONSTRAINTS`` lists them with their units);
* ``valve_train`` (the scene's keys) and ``cam_speed_rpm`` where a force, stress, spring
  margin or jump-speed quantity is asked for; ``base_radius`` [m] and ``follower``
  ({kind: flat|roller, radius}) for curvature and stress.

Continuous problems go to SLSQP from several starts; problems with whole-number
parameters to differential evolution with integrality (scipy). Every candidate is a
complete lift law, evaluated on ``samples`` points over its support with the law's
analytic derivatives. Units: SI (m, rad); metric names say their unit.
"""
from __future__ import annotations

import copy
import math
import re
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_length
from cam_design.lift_laws.params import MAX_LIFT_M, MAX_RADIUS_M

#: objective metrics: name -> (+1 maximise / -1 minimise, unit, description)
OBJECTIVES: dict[str, tuple[int, str, str]] = {
    'fullness': (+1, '1', 'fullness coefficient of the lift (area / (max lift x duration))'),
    'peak_acceleration': (-1, 'm/rad^2', 'largest |h\'\'| over the lobe'),
    'peak_jerk': (-1, 'm/rad^3', 'largest |h\'\'\'| over the lobe'),
    'jump_speed_rpm': (+1, 'rpm', 'lowest cam speed with a separation (SDOF model)'),
}

#: constraints: name -> (metric, 'max' | 'min', unit)
CONSTRAINTS: dict[str, tuple[str, str, str]] = {
    'max_positive_acceleration': ('positive_acceleration', 'max', 'm/rad^2'),
    'max_negative_acceleration': ('negative_acceleration', 'max', 'm/rad^2 (magnitude)'),
    'max_peak_acceleration': ('peak_acceleration', 'max', 'm/rad^2 (either sign)'),
    'max_jerk': ('peak_jerk', 'max', 'm/rad^3'),
    'min_radius_of_curvature': ('min_radius_of_curvature', 'min', 'm (needs base_radius)'),
    'max_hertz_stress': ('max_hertz_stress', 'max', 'Pa (needs valve_train, cam_speed_rpm, '
                         'base_radius, width)'),
    'min_spring_margin': ('spring_margin', 'min', '1 (needs valve_train, cam_speed_rpm)'),
    'min_jump_speed_rpm': ('jump_speed_rpm', 'min', 'rpm (needs valve_train)'),
    'min_fullness': ('fullness', 'min', '1'),
    'min_nose_oil_film': ('nose_oil_film', 'min', 'm (flat follower; needs base_radius, '
                          'lubrication)'),
    'min_valve_piston_clearance': ('valve_piston_clearance', 'min',
                                   'm (needs piston; the dynamic valve lift when valve_train '
                                   'and cam_speed_rpm are given, else the rigid one)'),
}

#: free parameters used when a SPEC gives none: family -> {path: (low, high) as
#: fractions of half_angle for angles, or absolute [low, high, integer]}
DEFAULT_FREE: dict[str, dict[str, tuple]] = {
    'constant_acceleration': {'positive_width': ('angle', 0.05, 0.95)},
    'composite': {},          # filled from the segments: every width but the last
    'polynomial': {'exponents[1]': (4, 20, True), 'exponents[2]': (6, 40, True),
                   'exponents[3]': (8, 60, True)},
    'harmonic': {'order': (4, 40, True)},
    'polydyne': {'exponents[1]': (4, 20, True), 'exponents[2]': (6, 30, True),
                 'exponents[3]': (8, 40, True), 'exponents[4]': (10, 50, True)},
    'dual_peak': {'connection.point_lift': ('lift', 0.001, 0.5)},
}

FAMILIES = tuple(DEFAULT_FREE)
SPEC_KEYS = ('family', 'fixed', 'free', 'objective', 'constraints', 'valve_train',
             'cam_speed_rpm', 'base_radius', 'follower', 'width', 'samples', 'starts', 'seed',
             'generations', 'lubrication', 'piston')
#: metrics computed by simulation: piecewise constant in the parameters (bisection to a
#: tolerance), so they go to the derivative-free search
SIMULATED = frozenset({'jump_speed_rpm'})

#: a constraint is reported active when its slack is below this fraction of its limit
ACTIVE_TOL = 1e-6


@dataclass(frozen=True)
class FreeParam:
    """One free parameter: path in the family spec, bounds, whole number or not."""

    path: str
    low: float
    high: float
    integer: bool = False


@dataclass
class Spec:
    """A parsed optimisation SPEC (see the module docstring)."""

    family: str
    base: dict[str, Any]
    free: list[FreeParam]
    objective: dict[str, float]            # metric -> weight (sign: more is better)
    constraints: dict[str, float]
    valve_train: dict[str, Any] | None = None
    cam_speed_rpm: float | None = None
    base_radius: float | None = None
    follower: tuple[str, float] = ('flat', 0.0)
    width: float | None = None
    lubrication: dict[str, Any] | None = None   # {k_film}: oil-film constant of Shang (2.12)
    piston: dict[str, Any] | None = None        # checks.PISTON_KEYS
    samples: int = 4001
    starts: int = 6
    seed: int = 0
    generations: int = 30


@dataclass
class Evaluation:
    """Metrics of one candidate (None when the candidate is not a valid lift law)."""

    x: NDArray[np.float64]
    spec: dict[str, Any]
    metrics: dict[str, float] | None
    error: str | None = None


@dataclass
class Result:
    """The optimum and how it was found."""

    status: str                           # 'optimal' | 'infeasible'
    lift_law: dict[str, Any]
    parameters: dict[str, float]
    objective: dict[str, Any]
    constraints: dict[str, dict[str, Any]]
    start: dict[str, Any]
    evaluations: int
    seconds: float
    method: str
    table: dict[str, list[float]] = field(default_factory=dict)
    message: str = ''
    metrics: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready result."""
        return {'status': self.status, 'message': self.message, 'method': self.method,
                'evaluations': self.evaluations, 'seconds': self.seconds,
                'parameters': self.parameters, 'objective': self.objective,
                'constraints': self.constraints, 'start': self.start,
                'metrics': self.metrics, 'lift_law': self.lift_law, 'table': self.table}


# --------------------------------------------------------------------------- paths
_PATH = re.compile(r'^[A-Za-z_]\w*(\[\d+\])*(\.[A-Za-z_]\w*(\[\d+\])*)*$')


def _tokens(path: str) -> list[str | int]:
    out: list[str | int] = []
    for part in path.split('.'):
        name, *idx = re.split(r'\[|\]', part)
        out.append(name)
        out += [int(i) for i in idx if i != '']
    return out


def _get(doc: Any, path: str) -> Any:
    node = doc
    for t in _tokens(path):
        node = node[t]
    return node


def _set(doc: Any, path: str, value: Any) -> None:
    toks = _tokens(path)
    node = doc
    for t in toks[:-1]:
        node = node[t]
    node[toks[-1]] = value


# --------------------------------------------------------------------------- parsing
def _number(value: Any, key: str, expected: str = 'a finite number') -> float:
    if isinstance(value, bool):
        raise InputError(key, value, expected)
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InputError(key, value, expected) from None
    if not math.isfinite(out):
        raise InputError(key, value, expected)
    return out


def _ramp_angle(ramp: Any) -> float:
    """Angular width [rad] of a ramp mapping of the lift-law registry (0 for none)."""
    if not ramp or ramp.get('kind') == 'none':
        return 0.0
    if 'angle' in ramp:
        return float(ramp['angle'])
    if ramp.get('velocity'):
        return float(ramp.get('height', 0.0)) / float(ramp['velocity'])
    return 0.0


def _base_spec(family: str, fixed: Mapping[str, Any]) -> dict[str, Any]:
    """The family spec from ``fixed``: generic keys mapped to the family's own names."""
    base = {'family': family, **copy.deepcopy(dict(fixed))}
    if 'max_lift' in base:   # 8 meant as mm: refused before any candidate is tried
        require_length('fixed.max_lift', _number(base['max_lift'], 'fixed.max_lift'),
                       MAX_LIFT_M, what='a lift')
    if 'half_duration_deg' in base:
        hd = _number(base.pop('half_duration_deg'), 'fixed.half_duration_deg')
        if not 0.0 < hd <= 180.0:
            raise InputError('fixed.half_duration_deg', hd,
                             'an angle in (0, 180] deg (start of the lobe to its nose; the '
                             'whole lobe is twice that and must fit in one revolution)')
        half = math.radians(hd) - _ramp_angle(base.get('ramp'))
        if half <= 0:
            raise InputError('fixed.half_duration_deg', hd,
                             f'more than the ramp angle ({math.degrees(hd - half):.4g} deg)')
        base['half_angle'] = half
    if family in ('constant_acceleration', 'composite', 'polynomial',
                  'dual_peak') and 'ramp' not in base:
        base['ramp'] = None
    if family == 'polydyne' and 'max_lift' in base:
        base['valve_lift'] = base.pop('max_lift')
    if family == 'dual_peak' and 'max_lift' in base:
        base['rise'] = base.pop('max_lift')
    if family == 'composite' and 'segments' not in base:
        # accelerate, decelerate, dwell at the nose: the bang-bang layout
        half = float(base.get('half_angle', 1.0))
        base['segments'] = [{'shape': 'constant', 'width': half * w} for w in (0.3, 0.5, 0.2)]
        base.setdefault('ratios', [[1, 2, 0.0]])
        base.setdefault('continuity', 1)
    if family == 'composite':
        base.pop('half_angle', None)        # the widths carry it
        base['_half_angle'] = sum(float(s['width']) for s in base['segments'])
    if family == 'polynomial':
        base.setdefault('exponents', [2, 6, 10, 14])
    if family == 'polydyne':
        base.setdefault('exponents', [2, 6, 10, 14, 18])
    return base


def _default_free(family: str, base: Mapping[str, Any]) -> list[FreeParam]:
    half = float(base.get('half_angle', base.get('_half_angle', 1.0)))
    lift = float(base.get('max_lift', base.get('rise', 0.01)))
    out = []
    if family == 'composite':
        n = len(base['segments'])
        return [FreeParam(f'segments[{i}].width', 0.02 * half, 0.96 * half)
                for i in range(n - 1)]
    for path, rule in DEFAULT_FREE[family].items():
        if rule[0] == 'angle':
            out.append(FreeParam(path, rule[1] * half, rule[2] * half))
        elif rule[0] == 'lift':
            out.append(FreeParam(path, rule[1] * lift, rule[2] * lift))
        else:
            out.append(FreeParam(path, float(rule[0]), float(rule[1]), bool(rule[2])))
    return out


def parse_spec(doc: Any, key: str = 'spec') -> Spec:
    """Validate a SPEC mapping; every error names the key as written in the file."""
    if not isinstance(doc, Mapping):
        raise InputError(key, type(doc).__name__,
                         'a mapping with the keys ' + ', '.join(SPEC_KEYS))
    unknown = sorted(set(doc) - set(SPEC_KEYS))
    if unknown:
        raise InputError(unknown[0], doc[unknown[0]], 'one of ' + ', '.join(SPEC_KEYS))
    family = doc.get('family')
    if family not in FAMILIES:
        raise InputError('family', family, 'one of ' + ', '.join(FAMILIES))
    fixed = doc.get('fixed') or {}
    if not isinstance(fixed, Mapping):
        raise InputError('fixed', fixed, 'a mapping of fixed family parameters')
    base = _base_spec(family, fixed)
    free_doc = doc.get('free')
    if free_doc is None:
        free = _default_free(family, base)
    else:
        if not isinstance(free_doc, Mapping) or not free_doc:
            raise InputError('free', free_doc, 'a mapping {parameter path: [low, high]}')
        free = []
        for path, bounds in free_doc.items():
            k = f'free.{path}'
            if not isinstance(path, str) or not _PATH.match(path):
                raise InputError(k, path, 'a parameter path such as positive_width or '
                                 'segments[1].width')
            if not isinstance(bounds, (list, tuple)) or len(bounds) not in (2, 3):
                raise InputError(k, bounds, '[low, high] or [low, high, integer]')
            lo, hi = _number(bounds[0], k), _number(bounds[1], k)
            if not lo < hi:
                raise InputError(k, bounds, 'low < high (bounds that exclude every design)')
            integer = bool(bounds[2]) if len(bounds) == 3 else False
            free.append(FreeParam(path, lo, hi, integer))
    for p in free:
        try:
            _get(base, p.path)
        except KeyError:      # not given under fixed: start in the middle of its bounds
            mid = 0.5 * (p.low + p.high)
            try:
                _set(base, p.path, int(round(mid)) if p.integer else mid)
            except (KeyError, IndexError, TypeError):
                raise InputError(f'free.{p.path}', p.path, f'a parameter of the {family} '
                                 'spec (give its start value under fixed)') from None
        except (IndexError, TypeError):
            raise InputError(f'free.{p.path}', p.path, f'a parameter of the {family} spec '
                             '(give its start value under fixed)') from None
    if not free:
        raise InputError('free', free_doc, 'at least one free parameter')
    objective = _parse_objective(doc.get('objective', 'fullness'))
    constraints = {}
    for name, limit in (doc.get('constraints') or {}).items():
        if name not in CONSTRAINTS:
            raise InputError(f'constraints.{name}', limit, 'one of ' + ', '.join(CONSTRAINTS))
        constraints[name] = _number(limit, f'constraints.{name}')
        if constraints[name] < 0:
            raise InputError(f'constraints.{name}', limit, 'a limit >= 0')
    vt = doc.get('valve_train')
    rpm = doc.get('cam_speed_rpm')
    needs_force = {'max_hertz_stress', 'min_spring_margin'} & set(constraints)
    needs_train = needs_force | ({'min_jump_speed_rpm'} & set(constraints)) | (
        {'jump_speed_rpm'} & set(objective))
    if needs_train and vt is None:
        raise InputError('valve_train', None, f'a valve_train mapping (needed by '
                         f'{", ".join(sorted(needs_train))})')
    if needs_force and rpm is None:
        raise InputError('cam_speed_rpm', None, f'a cam speed (needed by '
                         f'{", ".join(sorted(needs_force))})')
    r0 = doc.get('base_radius')
    if ({'min_radius_of_curvature', 'max_hertz_stress'} & set(constraints)) and r0 is None:
        raise InputError('base_radius', None, 'the base-circle radius [m] (needed for the '
                         'radius of curvature)')
    width = doc.get('width')
    if 'max_hertz_stress' in constraints and width is None:
        raise InputError('width', None, 'the cam width [m] (needed by max_hertz_stress)')
    follower = ('flat', 0.0)
    if doc.get('follower') is not None:
        f = doc['follower']
        if not isinstance(f, Mapping) or f.get('kind') not in ('flat', 'roller'):
            raise InputError('follower', f, '{kind: flat} or {kind: roller, radius: m}')
        follower = (f['kind'], require_length('follower.radius', _number(
            f.get('radius', 0.0), 'follower.radius'), MAX_RADIUS_M, allow_zero=True,
            what='a radius'))
    lub, piston = doc.get('lubrication'), doc.get('piston')
    if 'min_nose_oil_film' in constraints:
        if follower[0] != 'flat':
            raise InputError('constraints.min_nose_oil_film', constraints['min_nose_oil_film'],
                             'a flat follower (the oil-film check is for flat tappets)')
        if r0 is None:
            raise InputError('base_radius', None, 'the base-circle radius [m] (needed by '
                             'min_nose_oil_film)')
        if not isinstance(lub, Mapping) or 'k_film' not in lub:
            raise InputError('lubrication', lub, '{k_film: K} (needed by min_nose_oil_film)')
        _number(lub['k_film'], 'lubrication.k_film')
    if 'min_valve_piston_clearance' in constraints and not isinstance(piston, Mapping):
        raise InputError('piston', piston, 'a mapping of crank_radius, rod_length, '
                         'clearance, opening_crank_angle (needed by '
                         'min_valve_piston_clearance)')
    samples = int(_number(doc.get('samples', 4001), 'samples'))
    if not 201 <= samples <= 100001:
        raise InputError('samples', samples, 'an integer in [201, 100001]')
    return Spec(family=family, base=base, free=free, objective=objective,
                constraints=constraints, valve_train=dict(vt) if vt else None,
                cam_speed_rpm=None if rpm is None else _number(rpm, 'cam_speed_rpm'),
                base_radius=None if r0 is None else require_length(
                    'base_radius', _number(r0, 'base_radius'), MAX_RADIUS_M, what='a radius'),
                follower=follower, width=None if width is None else require_length(
                    'width', _number(width, 'width'), MAX_RADIUS_M),
                lubrication=dict(lub) if isinstance(lub, Mapping) else None,
                piston=dict(piston) if isinstance(piston, Mapping) else None,
                samples=samples, starts=int(_number(doc.get('starts', 6), 'starts')),
                generations=int(_number(doc.get('generations', 30), 'generations')),
                seed=int(_number(doc.get('seed', 0), 'seed')))


def _parse_objective(obj: Any) -> dict[str, float]:
    if isinstance(obj, str):
        if obj not in OBJECTIVES:
            raise InputError('objective', obj, 'one of ' + ', '.join(OBJECTIVES) +
                             ' or {weighted: {metric: weight}}')
        return {obj: float(OBJECTIVES[obj][0])}
    if isinstance(obj, Mapping) and set(obj) == {'weighted'} and isinstance(
            obj['weighted'], Mapping) and obj['weighted']:
        out = {}
        for name, w in obj['weighted'].items():
            if name not in OBJECTIVES:
                raise InputError(f'objective.weighted.{name}', w,
                                 'one of ' + ', '.join(OBJECTIVES))
            out[name] = _number(w, f'objective.weighted.{name}')
        return out
    raise InputError('objective', obj, 'a metric name or {weighted: {metric: weight}}')


# --------------------------------------------------------------------------- metrics
def candidate_spec(spec: Spec, x: NDArray[np.float64]) -> dict[str, Any]:
    """The family spec of the candidate ``x`` (free values put into the fixed ones)."""
    doc = copy.deepcopy(spec.base)
    for p, v in zip(spec.free, x):
        _set(doc, p.path, int(round(v)) if p.integer else float(v))
    half = doc.pop('_half_angle', None)
    if spec.family == 'composite' and half is not None:   # the last width closes the sum
        widths = [float(s['width']) for s in doc['segments'][:-1]]
        doc['segments'][-1]['width'] = half - sum(widths)
        if doc['segments'][-1]['width'] <= 0:
            raise InputError('segments', widths, f'widths that sum to less than {half:.6g} rad')
    return doc


def _sdof_params(vt: Mapping[str, Any]) -> Any:
    from cam_design.valve_train.params import SdofParams

    seat = vt.get('seat') or {}
    return SdofParams(mass=vt['mass'], stiffness=vt['stiffness'],
                      damping=vt.get('damping', 0.0), spring_rate=vt['spring_rate'],
                      spring_preload=vt['spring_preload'], rocker_ratio=vt['rocker_ratio'],
                      lash=vt.get('lash', 0.0), valve_damping=vt.get('valve_damping', 0.0),
                      seat_stiffness=seat.get('stiffness', 1.0e9),
                      seat_damping=seat.get('damping', 2000.0),
                      restitution=seat.get('restitution'))


def kinematic_jump_rpm(h: NDArray, h2: NDArray, params: Any) -> float:
    """Cam speed [rpm] at which the rigid train's contact force first reaches zero:
    F0 + c' y = M k h'' omega^2 with y = k h - x0 (valve side), minimised over the lobe
    where h'' < 0. Infinite when h'' never goes negative."""
    k = params.rocker_ratio
    y = np.maximum(k * h - params.lash, 0.0)
    pull = -params.mass * k * h2                       # inertia that lifts the valve off
    mask = (pull > 0) & (y > 0)
    if not np.any(mask):
        return math.inf
    omega2 = (params.spring_preload + params.spring_rate * y[mask]) / pull[mask]
    return math.sqrt(float(omega2.min())) * 60.0 / (2.0 * math.pi)


def dynamic_jump_rpm(law: Any, params: Any, guess_rpm: float, tol_rpm: float = 1.0) -> float:
    """Lowest cam speed [rpm] with a separation in the SDOF model (``valve_train.sweep``):
    16 speeds from 0.2 to 1.6 x ``guess_rpm`` (the rigid-train estimate), then
    bisection to ``tol_rpm``. When no speed of the scan separates, the top of the scan is
    returned: a lower bound, which is what a minimum-jump-speed constraint needs. When
    the lowest speed already separates, that speed is returned (an upper bound)."""
    from cam_design.valve_train.params import RPM_MAX
    from cam_design.valve_train.sweep import sweep

    top = min(1.6 * guess_rpm, RPM_MAX)
    speeds = np.linspace(min(0.2 * guess_rpm, 0.5 * top), top, 16)
    res = sweep(law, params, speeds.tolist(), step_deg=1.0, tol_rpm=tol_rpm, check=False)
    if res.jump.speed is not None:
        return float(res.jump.speed)
    return float(speeds[0] if res.jump.bracket[0] is None else top)


def metrics_of(spec: Spec, law: Any) -> dict[str, float]:
    """Every metric the SPEC needs, for one lift law (SI; see CONSTRAINTS)."""
    from cam_design.checks import fullness

    lo, hi = law.support
    a = np.linspace(lo, hi, spec.samples)
    h, h1, h2, h3 = law.derivatives(a)
    out = {'fullness': float(fullness(a, h)),
           'positive_acceleration': float(max(h2.max(), 0.0)),
           'negative_acceleration': float(max(-h2.min(), 0.0)),
           'peak_acceleration': float(np.abs(h2).max()),
           'peak_jerk': _peak_jerk(a, h2, h3),
           'max_lift': float(h.max())}
    need = set(spec.constraints) | set(spec.objective)
    rho = None
    if spec.base_radius is not None:
        if spec.follower[0] == 'flat':
            rho = spec.base_radius + h + h2
        else:
            from cam_design.cam_profile import roller_profile
            rho = roller_profile(law, spec.base_radius, spec.follower[1], a).rho
        out['min_radius_of_curvature'] = float(rho.min())
        if 'min_nose_oil_film' in need:   # at the nose: over a flank the film of (2.12)
            from cam_design.checks import oil_film   # vanishes where gamma crosses 1/2

            i = int(np.argmax(h))
            lubrication = spec.lubrication
            assert lubrication is not None    # parse_spec requires it for this constraint
            out['nose_oil_film'] = float(oil_film(a[i:i + 1], h[i:i + 1], rho[i:i + 1],
                                                  spec.base_radius,
                                                  float(lubrication['k_film'])).h_min[0])
    if 'min_valve_piston_clearance' in need:
        out['valve_piston_clearance'] = _clearance(spec, law, a, h)
    if spec.valve_train is not None:
        params = _sdof_params(spec.valve_train)
        if {'min_jump_speed_rpm', 'jump_speed_rpm'} & need:
            guess = kinematic_jump_rpm(h, h2, params)
            if not math.isfinite(guess):     # no deceleration: scan up to the speed limit
                guess = 1.0e5 / 1.6
            out['jump_speed_rpm'] = dynamic_jump_rpm(law, params, guess)
        if spec.cam_speed_rpm is not None:
            omega = spec.cam_speed_rpm * 2 * math.pi / 60
            k = params.rocker_ratio
            y = np.maximum(k * h - params.lash, 0.0)
            spring = k * (params.spring_preload + params.spring_rate * y)   # at the tappet
            inertia = params.mass * k * k * omega ** 2 * h2                  # tappet side
            pull = -inertia
            out['spring_margin'] = (float((spring[pull > 0] / pull[pull > 0]).min())
                                    if np.any(pull > 0) else math.inf)
            if spec.width is not None and rho is not None:
                from cam_design.checks import hertz_stress_steel
                force = np.maximum(spring + inertia, 0.0)
                sigma = hertz_stress_steel(force, spec.width, np.where(rho > 0, rho, np.inf),
                                           spec.follower[1] if spec.follower[0] == 'roller'
                                           else math.inf)
                out['max_hertz_stress'] = float(np.max(sigma))
    return out


def _peak_jerk(a: NDArray, h2: NDArray, h3: NDArray) -> float:
    """Largest |h'''| [m/rad^3]; infinite when h'' jumps somewhere (a constant-
    acceleration segment, a ramp junction): the jerk is then a Dirac pulse, and the
    piecewise derivative alone would understate it. A jump is a change of h'' between
    neighbouring samples more than twice what |h'''| allows, plus 1e-9 of max |h''|."""
    step = np.abs(np.diff(h2))
    allowed = 2.0 * np.maximum(np.abs(h3[:-1]), np.abs(h3[1:])) * np.diff(a) \
        + 1e-9 * float(np.abs(h2).max())
    return math.inf if np.any(step > allowed) else float(np.abs(h3).max())


def _clearance(spec: Spec, law: Any, a: NDArray, h: NDArray) -> float:
    """Smallest valve-piston clearance [m]: the valve lift of the exact SDOF run at
    ``cam_speed_rpm`` when the SPEC has a valve train and a speed, else k h - x0."""
    from cam_design.checks import min_valve_piston_clearance

    from scipy.optimize import brentq

    vt = spec.valve_train
    k = float(vt.get('rocker_ratio', 1.0)) if vt else 1.0
    lash = float(vt.get('lash', 0.0)) if vt else 0.0
    # the valve timing is the rigid train's: the cam angle where k h first exceeds x0
    i = int(np.nonzero(k * h > lash)[0][0])
    a_open = a[0] if i == 0 else brentq(lambda x: k * float(law(x, 0)) - lash, a[i - 1],
                                        a[i], xtol=1e-12)
    if vt is not None and spec.cam_speed_rpm is not None:
        from cam_design.valve_train.report import run_sdof

        run = run_sdof(law, _sdof_params(vt), spec.cam_speed_rpm, step_deg=0.25)
        alpha, y = run.alpha, run.lift
    else:
        alpha, y = a, np.maximum(k * h - lash, 0.0)
    return min_valve_piston_clearance(alpha, y, spec.piston or {}, 'piston', a_open)[0]


def _evaluate(spec: Spec, x: NDArray[np.float64], cache: dict) -> Evaluation:
    from cam_design.lift_laws import from_spec

    key = tuple(np.round(x, 12))
    if key in cache:
        return cache[key]
    try:
        doc = candidate_spec(spec, x)
        law = from_spec(doc, 'candidate')
        ev = Evaluation(np.array(x, float), doc, metrics_of(spec, law))
    except (InputError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        ev = Evaluation(np.array(x, float), {}, None, str(exc))
    cache[key] = ev
    return ev


def _slacks(spec: Spec, m: Mapping[str, float]) -> dict[str, float]:
    """Constraint slack, normalised by the limit (>= 0 satisfied)."""
    out = {}
    for name, limit in spec.constraints.items():
        metric, kind, _ = CONSTRAINTS[name]
        value = m[metric]
        scale = max(abs(limit), 1e-300)
        out[name] = (limit - value) / scale if kind == 'max' else (value - limit) / scale
    return out


def _objective_value(spec: Spec, m: Mapping[str, float], ref: Mapping[str, float]) -> float:
    """The quantity maximised: sum of weight x metric / |metric at the start|."""
    if len(spec.objective) == 1:
        (name, w), = spec.objective.items()
        return w * m[name]
    return sum(w * m[n] / max(abs(ref[n]), 1e-300) for n, w in spec.objective.items())


# --------------------------------------------------------------------------- solve
def optimize(spec: Spec, *, progress: Callable[[str], None] | None = None) -> Result:
    """The best candidate of the SPEC (see the module docstring)."""
    from scipy.optimize import NonlinearConstraint, differential_evolution, minimize

    t0 = time.perf_counter()
    cache: dict = {}
    lo = np.array([p.low for p in spec.free])
    hi = np.array([p.high for p in spec.free])
    x_start = np.array([_start_value(spec, p) for p in spec.free])
    start = _evaluate(spec, x_start, cache)
    ref = start.metrics if start.metrics is not None else {}
    integer = np.array([p.integer for p in spec.free])
    names = list(spec.constraints)
    bad = -1e3                               # slack/objective of an invalid candidate

    def objective(x: NDArray) -> float:
        ev = _evaluate(spec, x, cache)
        if ev.metrics is None:
            return 1e6
        val = _objective_value(spec, ev.metrics, ref or ev.metrics)
        return -val if math.isfinite(val) else (-1e6 if val > 0 else 1e6)

    def slacks(x: NDArray) -> NDArray:
        ev = _evaluate(spec, x, cache)
        if ev.metrics is None:
            return np.full(max(len(names), 1), bad)
        s = _slacks(spec, ev.metrics)
        vals = [s[n] if math.isfinite(s[n]) else (1e3 if s[n] > 0 else bad) for n in names]
        return np.array(vals or [0.0])

    simulated = bool(SIMULATED & (set(spec.objective) | {CONSTRAINTS[n][0] for n in names}))
    if integer.any() or simulated:
        method = ('differential_evolution' + (' (integrality)' if integer.any() else '')
                  + (' (simulated jump speed: derivative-free)' if simulated else ''))
        cons = [NonlinearConstraint(slacks, 0.0, np.inf)] if names else []
        res = differential_evolution(objective, list(zip(lo, hi)), constraints=cons,
                                     integrality=integer, seed=spec.seed, polish=False,
                                     maxiter=max(spec.generations, 1), popsize=8, tol=1e-8)
        candidates = [res.x]
    else:
        method = f'SLSQP, {spec.starts} starts'
        rng = np.random.default_rng(spec.seed)
        starts = [x_start] + [lo + (hi - lo) * rng.random(lo.size)
                              for _ in range(max(spec.starts, 1) - 1)]
        cons = [{'type': 'ineq', 'fun': slacks}] if names else []
        candidates = []
        for i, x0 in enumerate(starts):
            r = minimize(objective, x0, method='SLSQP', bounds=list(zip(lo, hi)),
                         constraints=cons, options={'ftol': 1e-14, 'maxiter': 300})
            candidates.append(r.x)
            if progress:
                progress(f'start {i + 1}/{len(starts)}: objective {-r.fun:.6g}')
    best = _pick(spec, [_evaluate(spec, np.clip(c, lo, hi), cache) for c in candidates]
                 + list(cache.values()), ref)
    return _result(spec, best, start, ref, len(cache), time.perf_counter() - t0, method)


def _start_value(spec: Spec, p: FreeParam) -> float:
    try:
        v = float(_get(spec.base, p.path))
        if p.low <= v <= p.high:
            return v
    except (KeyError, IndexError, TypeError, ValueError):
        pass
    mid = 0.5 * (p.low + p.high)
    return float(round(mid)) if p.integer else mid


def _violation(spec: Spec, ev: Evaluation) -> float:
    if ev.metrics is None:
        return math.inf
    return max([0.0] + [-s for s in _slacks(spec, ev.metrics).values()])


def _pick(spec: Spec, evs: list[Evaluation], ref: Mapping[str, float]) -> Evaluation:
    """The best feasible candidate (1e-9 relative slack), else the least violating."""
    valid = [(e, e.metrics) for e in evs if e.metrics is not None]
    if not valid:
        raise InputError('free', [p.path for p in spec.free],
                         'bounds that contain at least one valid design (every candidate '
                         f'was rejected; e.g. {evs[0].error if evs else "none tried"})')
    feasible = [(e, m) for e, m in valid if _violation(spec, e) <= 1e-9]
    if feasible:
        return max(feasible, key=lambda em: _objective_value(spec, em[1], ref or em[1]))[0]
    return min(valid, key=lambda em: _violation(spec, em[0]))[0]


def _public(doc: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in doc.items() if not k.startswith('_')}


def _result(spec: Spec, best: Evaluation, start: Evaluation, ref: Mapping[str, float],
            evaluations: int, seconds: float, method: str) -> Result:
    from cam_design.lift_laws import from_spec

    viol = _violation(spec, best)
    metrics = best.metrics
    assert metrics is not None            # _pick returns a candidate with metrics
    cons = {}
    for name, slack in _slacks(spec, metrics).items():
        metric, kind, unit = CONSTRAINTS[name]
        cons[name] = {'limit': spec.constraints[name], 'value': metrics[metric],
                      'unit': unit, 'slack': slack * abs(spec.constraints[name]),
                      'active': abs(slack) <= ACTIVE_TOL, 'satisfied': slack >= -1e-9}
    obj_best = _objective_value(spec, metrics, ref or metrics)
    objective = {'terms': spec.objective, 'value': obj_best,
                 'metrics': {n: metrics[n] for n in spec.objective}}
    start_info: dict[str, Any] = {'parameters': {p.path: float(v) for p, v in
                                                 zip(spec.free, start.x)}}
    if start.metrics is not None:
        obj_start = _objective_value(spec, start.metrics, ref)
        start_info.update({'objective': obj_start,
                           'feasible': _violation(spec, start) <= 1e-9,
                           'improvement': obj_best - obj_start})
    else:
        start_info['error'] = start.error
    law = from_spec(best.spec, 'optimum')
    lo, hi = law.support
    alpha = np.linspace(lo, hi, int(round(math.degrees(hi - lo) / 0.5)) + 1)
    table = {'alpha_rad': alpha.tolist(), 'lift_m': law(alpha, 0).tolist()}
    status, message = 'optimal', ''
    if viol > 1e-9:
        worst = min(_slacks(spec, metrics).items(), key=lambda kv: kv[1])
        status = 'infeasible'
        message = (f'no design within the bounds meets every constraint; the most violated '
                   f'is {worst[0]} (value {cons[worst[0]]["value"]:.6g}, limit '
                   f'{spec.constraints[worst[0]]:.6g} {CONSTRAINTS[worst[0]][2]})')
    return Result(status=status, lift_law=_public(best.spec),
                  parameters={p.path: (int(round(v)) if p.integer else float(v))
                              for p, v in zip(spec.free, best.x)},
                  objective=objective, constraints=cons, start=start_info,
                  evaluations=evaluations, seconds=seconds, method=method, table=table,
                  message=message, metrics=dict(metrics))


def pareto(spec: Spec, first: str, second: str, points: int = 7) -> list[dict[str, Any]]:
    """Trade-off between two objective metrics by the epsilon-constraint method: the
    extremes of each alone, then ``first`` optimised with ``second`` held at ``points``
    levels between them. Returns one dict per point (metrics and parameters)."""
    for name in (first, second):
        if name not in OBJECTIVES:
            raise InputError('--pareto', name, 'metric names among ' + ', '.join(OBJECTIVES))
    constraint_of = {'fullness': 'min_fullness', 'jump_speed_rpm': 'min_jump_speed_rpm',
                     'peak_acceleration': 'max_peak_acceleration', 'peak_jerk': 'max_jerk'}
    name2 = constraint_of[second]
    sign2 = OBJECTIVES[second][0]
    a = copy.deepcopy(spec)
    a.objective = {first: float(OBJECTIVES[first][0])}
    b = copy.deepcopy(spec)
    b.objective = {second: float(sign2)}
    ra, rb = optimize(a), optimize(b)
    out = []
    for level in np.linspace(ra.metrics[second], rb.metrics[second], points):
        c = copy.deepcopy(a)
        c.constraints = {**spec.constraints, name2: float(level)}
        r = optimize(c)
        if r.status == 'optimal':
            out.append({'parameters': r.parameters, first: r.metrics[first],
                        second: r.metrics[second]})
    return out
