"""Checks a valve-train engineer compares with commercial tools, per dynamics run.

* Spring margin (docs/dynamics.md): along the open part of the lobe where the rigid
  valve acceleration is negative (the spring must hold the train on the cam), the ratio
  of the spring force F0 + c' y to the inertia force M |y''|, y = k h - x0 the rigid
  valve lift, y'' = k h'' omega^2; its minimum and where. Below 1 the rigid train would
  separate (the kinematic no-separation check of ``cam_design.checks``, as a ratio).
* Coil bind from the spring geometry (scene ``valve_train.spring``): solid length
  n_t d against the installed length minus the largest valve lift (rigid and dynamic).
* Valve-piston clearance (eq. 2.13, ``cam_design.checks``) from the DYNAMIC valve lift
  of the run, crank phased on the rigid opening as in ``design check``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from numpy.typing import NDArray

from cam_design import checks
from cam_design.errors import InputError, require_finite, require_mapping, require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.params import SdofParams

SPRING_KEYS = ('wire_diameter', 'total_coils', 'active_coils', 'free_length',
               'installed_length')
PISTON_KEYS = ('crank_radius', 'rod_length', 'clearance', 'opening_crank_angle', 'exact')


@dataclass(frozen=True)
class SpringGeometry:
    """Valve spring geometry [m]; ``installed_length`` None: free - F0/c'."""

    wire_diameter: float
    total_coils: float
    free_length: float
    active_coils: float | None = None
    installed_length: float | None = None

    @property
    def solid_length(self) -> float:
        """n_t d [m] (closed and ground ends)."""
        return self.total_coils * self.wire_diameter


@dataclass(frozen=True)
class PistonGeometry:
    """Crank-slider of eq. 2.14 and the valve-piston clearance y0 of eq. 2.13 [m, rad]."""

    crank_radius: float
    rod_length: float
    clearance: float
    opening_crank_angle: float
    exact: bool = True


@dataclass(frozen=True)
class TrainChecks:
    """Optional geometry of the valve train (scene ``valve_train.spring`` / ``piston``)."""

    spring: SpringGeometry | None = None
    piston: PistonGeometry | None = None


def _required(spec: Mapping[str, Any], key: str, name: str) -> Any:
    if name not in spec:
        raise InputError(f'{key}.{name}', None, 'a value (see docs/scene.md)')
    return spec[name]


def train_checks_from(spring: Any, piston: Any, key: str = 'valve_train') -> TrainChecks:
    """Validate the scene's ``valve_train.spring`` and ``valve_train.piston`` mappings
    (None: not given). Lengths in m, angles in rad."""
    sg = pg = None
    if spring is not None:
        k = f'{key}.spring'
        s = require_mapping(spring, k, SPRING_KEYS)
        d = require_positive(f'{k}.wire_diameter', _required(s, k, 'wire_diameter'))
        nt = require_positive(f'{k}.total_coils', _required(s, k, 'total_coils'))
        free = require_positive(f'{k}.free_length', _required(s, k, 'free_length'))
        na = s.get('active_coils')
        if na is not None:
            na = require_positive(f'{k}.active_coils', na)
            if na > nt:
                raise InputError(f'{k}.active_coils', na, f'at most total_coils ({nt:g})')
        inst = s.get('installed_length')
        if inst is not None:
            inst = require_positive(f'{k}.installed_length', inst)
            if inst > free:
                raise InputError(f'{k}.installed_length', inst,
                                 f'at most free_length ({free:g} m)')
        if nt * d >= free:
            raise InputError(f'{k}.free_length', free,
                             f'more than the solid length total_coils * wire_diameter '
                             f'({nt * d:g} m)')
        sg = SpringGeometry(wire_diameter=d, total_coils=nt, free_length=free,
                            active_coils=na, installed_length=inst)
    if piston is not None:
        k = f'{key}.piston'
        s = require_mapping(piston, k, PISTON_KEYS)
        exact = s.get('exact', True)
        if not isinstance(exact, bool):
            raise InputError(f'{k}.exact', exact, 'true or false')
        cr = require_positive(f'{k}.crank_radius', _required(s, k, 'crank_radius'))
        rl = require_positive(f'{k}.rod_length', _required(s, k, 'rod_length'))
        if cr >= rl:
            raise InputError(f'{k}.rod_length', rl, f'a rod longer than the crank ({cr:g} m)')
        pg = PistonGeometry(
            crank_radius=cr, rod_length=rl,
            clearance=require_positive(f'{k}.clearance', _required(s, k, 'clearance'),
                                       allow_zero=True),
            opening_crank_angle=require_finite(f'{k}.opening_crank_angle',
                                               _required(s, k, 'opening_crank_angle')),
            exact=exact)
    return TrainChecks(spring=sg, piston=pg)


def _lobe_grid(law: LiftLaw, samples: int = 20001) -> NDArray[np.float64]:
    """Dense angles over the support plus both sides of every junction [rad]."""
    lo, hi = law.support
    a = np.linspace(lo, hi, samples)
    js = [j for j in law.junctions if lo < j < hi]
    eps = 1e-11
    extra = np.array([j + s for j in js for s in (-eps, eps)])
    return np.unique(np.concatenate([a, extra]))


def spring_margin(law: LiftLaw, params: SdofParams, omega: float) -> dict[str, Any]:
    """Minimum of (F0 + c' y) / (M |y''|) where the valve is open (y > 0) and y'' < 0
    (rigid kinematics, valve side), and its angle [deg]; None where never decelerating."""
    a = _lobe_grid(law)
    h, _, h2, _ = law.derivatives(a)
    k = params.rocker_ratio
    y = k * h - params.lash
    acc = k * h2 * omega * omega
    sel = (y > 0) & (acc < 0)
    if not np.any(sel):
        return {'spring_margin_min': None, 'spring_margin_deg': None}
    ratio = (params.spring_preload + params.spring_rate * y[sel]) / (params.mass * -acc[sel])
    i = int(np.argmin(ratio))
    return {'spring_margin_min': float(ratio[i]),
            'spring_margin_deg': math.degrees(float(a[sel][i]))}


def coil_bind(geom: SpringGeometry, params: SdofParams, lifts: Mapping[str, float]
              ) -> dict[str, Any]:
    """Spring length at the largest lift of each kind (``lifts``: name -> lift [m])
    against the solid length. Keys ``coil_bind_<name>_margin_mm`` (> 0: clear),
    ``coil_bind`` (any margin <= 0), and the coil gap per active coil when given."""
    if geom.installed_length is not None:
        inst = geom.installed_length
        source = 'valve_train.spring.installed_length'
    else:
        if params.spring_rate <= 0:
            raise InputError('valve_train.spring.installed_length', None,
                             'an installed length (spring_rate is 0, so free - F0/rate '
                             'is undefined)')
        inst = geom.free_length - params.spring_preload / params.spring_rate
        source = 'free_length - spring_preload / spring_rate'
    out: dict[str, Any] = {'spring_solid_length_mm': geom.solid_length * 1e3,
                           'spring_installed_length_mm': inst * 1e3,
                           'spring_installed_length_source': source}
    bind = False
    for name, lift in lifts.items():
        margin = inst - lift - geom.solid_length
        out[f'coil_bind_{name}_margin_mm'] = margin * 1e3
        if geom.active_coils is not None:
            out[f'coil_gap_{name}_mm'] = margin / geom.active_coils * 1e3
        bind = bind or margin <= 0
    out['coil_bind'] = bool(bind)
    return out


def dynamic_clearance(law: LiftLaw, params: SdofParams, pg: PistonGeometry,
                      alpha: NDArray[np.float64], lift: NDArray[np.float64]
                      ) -> dict[str, Any]:
    """Eq. 2.13 D_s = s + y0 - y with the run's valve lift y at ``alpha`` [rad]; the
    crank angle is phi0 at the rigid opening (as ``design check``)."""
    a = _lobe_grid(law)
    y_rigid = checks.rigid_valve_lift(law(a), params.rocker_ratio, params.lash)
    opened = np.nonzero(y_rigid > 0)[0]
    if opened.size == 0:
        return {}
    alpha_open = float(a[opened[0]])
    open_ = lift > 0          # off the seat: the closed valve (firing TDC) is not a case
    phi = checks.crank_angle(alpha[open_], pg.opening_crank_angle, alpha_open)
    s = checks.piston_displacement(phi, pg.crank_radius, pg.rod_length, exact=pg.exact)
    ds = checks.valve_piston_clearance(s, lift[open_], pg.clearance)
    phi_r = checks.crank_angle(a, pg.opening_crank_angle, alpha_open)
    s_r = checks.piston_displacement(phi_r, pg.crank_radius, pg.rod_length, exact=pg.exact)
    ds_r = checks.valve_piston_clearance(s_r, y_rigid, pg.clearance)
    j = int(np.argmin(ds_r))
    out: dict[str, Any] = {
        'min_valve_piston_clearance_mm': None, 'min_clearance_crank_deg': None,
        'valve_piston_collision': False,
        'static_min_valve_piston_clearance_mm': float(ds_r[j]) * 1e3,
        'static_min_clearance_crank_deg': math.degrees(float(phi_r[j]))}
    if ds.size:
        i = int(np.argmin(ds))
        out.update({'min_valve_piston_clearance_mm': float(ds[i]) * 1e3,
                    'min_clearance_crank_deg': math.degrees(float(phi[i])),
                    'valve_piston_collision': bool(ds[i] <= 0)})
    return out


def run_checks(law: LiftLaw, params: SdofParams, omega: float, alpha: NDArray[np.float64],
               lift: NDArray[np.float64], tc: TrainChecks | None) -> dict[str, Any]:
    """All fields of this module for one run (spring margin always)."""
    out = spring_margin(law, params, omega)
    if tc is None:
        return out
    if tc.spring is not None:
        rigid = float(np.max(checks.rigid_valve_lift(law(_lobe_grid(law)),
                                                     params.rocker_ratio, params.lash)))
        out.update(coil_bind(tc.spring, params, {'rigid': rigid,
                                                 'dynamic': float(np.nanmax(lift))}))
    if tc.piston is not None:
        out.update(dynamic_clearance(law, params, tc.piston, alpha, lift))
    return out
