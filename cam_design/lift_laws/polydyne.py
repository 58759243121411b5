"""Polydyne cam (Dudley), docs/lift_laws.md: invert the SDOF valve train for a valve motion.

Prescribe the valve motion y_d(alpha) (a polynomial); at the design speed omega_d the
cam lift is (damping ignored, eps_c = M omega_d^2 / c)

    k h = x0 + F0/c + (1 + c'/c) y_d + eps_c y_d''.

Since y_d is a power sum in an affine variable u, so is h: the inversion is exact
(coefficient by coefficient). Before a profile is produced the contact margin
delta = k h - x0 - y_d = F0/c + (c'/c) y_d + eps_c y_d'' is checked on a dense grid
of the open interval: c delta <= 0 anywhere means the train would have to pull, the
design is infeasible and InputError is raised (naming the design speed).

Practical junction with a constant-velocity ramp (v_r, zero acceleration): the ramp
height is (x0 + F0/c)/k and y_d starts with y_d = 0, y_d' = k v_r/(1 + c'/c),
y_d'' = y_d''' = y_d'''' = 0; with five exponents and y_d(nose) = y_max this is the 5x5
moment system of §1.4 (solved exactly). h is then C2 at the ramp end and C3 at the nose.
Without a ramp (ramp_velocity 0) the law starts at the opening with the step
(x0 + F0/c)/k: the lash take-up is not modelled (continuity order -1).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Sequence

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.polynomial import MAX_EXPONENT, nose_order
from cam_design.lift_laws.segments import (Flank, PiecewiseLaw, PowerSegment, Segment,
                                           assemble_lobe, solve_moments)

TRAIN_KEYS = ('rocker_ratio', 'lash', 'mass', 'stiffness', 'spring_rate', 'spring_preload',
              'design_cam_speed_rpm')


@dataclasses.dataclass(frozen=True)
class Train:
    """SDOF valve-train parameters at the valve side (docs/contract.md names), SI."""

    rocker_ratio: float     # k
    lash: float             # x0 [m]
    mass: float             # M [kg]
    stiffness: float        # c [N/m]
    spring_rate: float      # c' [N/m]
    spring_preload: float   # F0 [N]
    design_speed: float     # omega_d [rad/s] (cam)

    @property
    def eps(self) -> float:
        """eps_c = M omega_d^2 / c (alpha in rad)."""
        return self.mass * self.design_speed ** 2 / self.stiffness

    @property
    def opening_height(self) -> float:
        """h at the valve opening: (x0 + F0/c)/k [m]."""
        return (self.lash + self.spring_preload / self.stiffness) / self.rocker_ratio

    @classmethod
    def from_spec(cls, spec: Mapping, key: str) -> 'Train':
        """Read the valve-train parameters (design speed in cam rpm)."""
        rpm = P.positive(spec, key, 'design_cam_speed_rpm')
        if rpm > 1e5:
            raise InputError(f'{key}.design_cam_speed_rpm', rpm, 'a cam speed <= 1e5 rpm')
        return cls(P.positive(spec, key, 'rocker_ratio'),
                   P.positive(spec, key, 'lash', allow_zero=True),
                   P.positive(spec, key, 'mass'), P.positive(spec, key, 'stiffness'),
                   P.positive(spec, key, 'spring_rate', allow_zero=True),
                   P.positive(spec, key, 'spring_preload', allow_zero=True),
                   rpm * 2 * math.pi / 60)


def invert(seg: PowerSegment, train: Train) -> PowerSegment:
    """The cam-lift segment h for the valve-motion segment y_d (same variable u)."""
    k, c = train.rocker_ratio, train.stiffness
    gain = 1 + train.spring_rate / c
    curv = train.eps / seg.scale ** 2
    coeffs: dict[int, float] = {0: train.lash + train.spring_preload / c}
    for i, d in seg.coefficients:
        coeffs[i] = coeffs.get(i, 0.0) + gain * d
        if i >= 2:
            coeffs[i - 2] = coeffs.get(i - 2, 0.0) + curv * i * (i - 1) * d
    return dataclasses.replace(seg, coefficients=tuple(
        sorted((i, v / k) for i, v in coeffs.items())))


def contact_margin(seg: PowerSegment, train: Train, alpha: np.ndarray) -> np.ndarray:
    """delta = F0/c + (c'/c) y_d + eps_c y_d'' [m] on ``alpha`` (must stay > 0)."""
    c = train.stiffness
    return (train.spring_preload / c + train.spring_rate / c * seg(alpha)
            + train.eps * seg(alpha, 2))


def check_feasible(valve: Sequence[PowerSegment], train: Train, *,
                   key: str, samples: int = 4001) -> float:
    """Smallest c delta [N] over the valve-motion segments; InputError if <= 0."""
    worst, at = math.inf, 0.0
    for seg in valve:
        a = np.linspace(seg.lo, seg.hi, samples)
        m = contact_margin(seg, train, a) * train.stiffness
        i = int(np.argmin(m))
        if m[i] < worst:
            worst, at = float(m[i]), float(a[i])
    if worst <= 0:
        rpm = train.design_speed * 60 / (2 * math.pi)
        raise InputError(f'{key}.design_cam_speed_rpm', rpm,
                         'a design speed at which the train stays in contact (c*delta = '
                         f'{worst:.4g} N <= 0 at alpha = {math.degrees(at):.4g} deg: '
                         'infeasible polydyne)')
    return worst


def polydyne_law(valve: Sequence[PowerSegment], train: Train, *, key: str = 'lift_law',
                 ramp: Sequence[Segment] = (), ramp_required: Sequence[int] = (),
                 nose_required: int | None = None) -> PiecewiseLaw:
    """Lobe from valve-motion segments in flank coordinate (t = 0 at the base circle).

    ``valve`` covers the open part of the rise flank up to the nose (flank end);
    ``ramp`` (flank segments before it) takes the follower from the base circle to
    the opening height. Feasibility is checked first."""
    check_feasible(valve, train, key=key)
    cam = [invert(s, train) for s in valve]
    if ramp:
        required = list(ramp_required) + [2] + [3] * (len(cam) - 1)
    else:
        required = [-1] + [3] * (len(cam) - 1)
    exps = [i for s in cam for i, _ in s.coefficients]
    nose = nose_order(exps) if nose_required is None else nose_required
    required.append(nose)
    flank = Flank(tuple(ramp) + tuple(cam), tuple(required), nose_order=nose)
    law = assemble_lobe(flank, None, key=key, name='polydyne')
    for seg in valve:          # docs/lift_laws.md: y_d monotone on the flank (it rises)
        t = np.linspace(seg.lo, seg.hi, 4001)
        v = seg(t, 1)
        if np.any(v < -1e-9 * max(float(np.max(np.abs(v))), 1e-300)):
            raise InputError(f'{key}.half_angle', None,
                             'a valve motion y_d that rises monotonically to the nose '
                             f'(y_d\' < 0 at t = {math.degrees(float(t[np.argmin(v)])):.4g} '
                             'deg; change half_angle, exponents or ramp_velocity)')
    if not law.flank_is_monotone():
        raise InputError(f'{key}.design_cam_speed_rpm', train.design_speed * 30 / math.pi,
                         'a design speed whose cam lift h is monotone on each flank (the '
                         'eps_c y_d\'\' correction reverses h\')')
    law.train = train          # type: ignore[attr-defined]
    law.valve_motion = tuple(s.mapped(+1, flank.length) for s in valve)  # type: ignore
    return law


def practical_valve_motion(train: Train, valve_lift: float, half_angle: float,
                           ramp_velocity: float, exponents: Sequence[int], start: float,
                           *, key: str) -> PowerSegment:
    """y_d on [start, start + half_angle] (flank coordinate) with the practical ramp
    junction: y_d = 0, y_d' = k v_r/(1 + c'/c), y_d'' = y_d''' = y_d'''' = 0 at the start."""
    exps = [int(e) for e in exponents]
    if len(exps) != 5 or any(e < 2 or e > MAX_EXPONENT for e in exps) or len(set(exps)) != 5:
        raise InputError(f'{key}.exponents', list(exponents),
                         f'five distinct exponents in 2..{MAX_EXPONENT}')
    w = train.rocker_ratio * ramp_velocity / (1 + train.spring_rate / train.stiffness)
    d = solve_moments(exps, [-valve_lift, -w * half_angle, 0.0, 0.0, 0.0],
                      key=f'{key}.exponents')
    coeffs = ((0, valve_lift),) + tuple(zip(exps, d))
    return PowerSegment(start, start + half_angle, start + half_angle, -half_angle,
                        coefficients=coeffs)


def polydyne_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: polydyne`` (see docs/lift_laws.md)."""
    P.reject_unknown(spec, key, TRAIN_KEYS + ('valve_lift', 'half_angle', 'exponents',
                                              'ramp_velocity', 'valve_motion'))
    train = Train.from_spec(spec, key)
    v_r = P.positive(spec, key, 'ramp_velocity', 0.0, allow_zero=True)
    ramp: list[Segment] = []
    ramp_required: list[int] = []
    start = 0.0
    if v_r > 0:
        angle = train.opening_height / v_r
        ramp = [PowerSegment(0.0, angle, 0.0, angle,
                             coefficients=((1, train.opening_height),))]
        ramp_required = [0]
        start = angle
    if spec.get('valve_motion') is not None:
        vk = f'{key}.valve_motion'
        vm = P.mapping(spec['valve_motion'], vk)
        P.reject_unknown(vm, vk, ('angle', 'coefficients'))
        if v_r > 0:
            raise InputError(f'{key}.ramp_velocity', v_r,
                             '0 with an explicit valve_motion (its start is used as is)')
        angle = P.angle(vm, vk, 'angle')
        raw = P.get(vm, vk, 'coefficients')
        coeffs = []
        for i, pair in enumerate(raw if isinstance(raw, list) else [None]):
            if not (isinstance(pair, (list, tuple)) and len(pair) == 2):
                raise InputError(f'{vk}.coefficients[{i}]', pair, '[exponent, value in m]')
            coeffs.append((int(pair[0]), float(pair[1])))
        seg = PowerSegment(0.0, angle, 0.0, angle, coefficients=tuple(coeffs))
        return polydyne_law([seg], train, key=key, nose_required=1)
    seg = practical_valve_motion(train, P.lift(spec, key, 'valve_lift'),
                                 P.angle(spec, key, 'half_angle'), v_r,
                                 P.integers(spec, key, 'exponents', [2, 6, 10, 14, 18]),
                                 start, key=key)
    return polydyne_law([seg], train, key=key, ramp=ramp, ramp_required=ramp_required)
