"""Buffer (ramp) sections, docs/lift_laws.md, in flank coordinate t (t = 0 on the base circle).

* constant velocity [STD]: h = v t on [0, alpha_r], H_r = v alpha_r (h' steps at t = 0).
* constant acceleration + constant velocity [S2 eqs 1, 7-13]: h = C_B t^2 on [0, beta1],
  E0 + E1 t on [beta1, alpha1] with E1 = v1, E0 = H1 - v1 alpha1,
  beta1 = 2 (v1 alpha1 - H1) / v1, C_B = v1^2 / (4 (v1 alpha1 - H1)). It exists only for
  H1/alpha1 < v1 <= 2 H1/alpha1 (0 < beta1 <= alpha1).
"""
from __future__ import annotations

import dataclasses
from typing import Any, Mapping

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.segments import PowerSegment, Segment

RAMP_KINDS = ('constant_velocity', 'constant_acceleration_velocity', 'none')


@dataclasses.dataclass(frozen=True)
class Ramp:
    """A ramp as flank segments plus its end state (height [m], velocity [m/rad])."""

    segments: tuple[Segment, ...]
    required: tuple[int, ...]     # base-circle junction, then interior junctions
    height: float
    velocity: float
    angle: float
    end_acceleration: float = 0.0  # h'' [m/rad^2] at the ramp end (0: constant velocity)

    @property
    def is_empty(self) -> bool:
        """True for 'no ramp' (the base section starts on the base circle)."""
        return not self.segments


@dataclasses.dataclass(frozen=True)
class PatentRamp:
    """Coefficients of the S2 ramp (all SI: m, rad): E0, E1, beta1, C_B."""

    e0: float
    e1: float
    beta1: float
    cb: float


def patent_ramp_coefficients(height: float, velocity: float, angle: float, *,
                             key: str = 'ramp') -> PatentRamp:
    """S2 eqs 10-13 with the existence check H1/alpha1 < v1 <= 2 H1/alpha1."""
    if height <= 0:
        raise InputError(f'{key}.height', height, 'a ramp height > 0')
    if angle <= 0:
        raise InputError(f'{key}.angle', angle, 'a ramp angle > 0 rad')
    lo, hi = height / angle, 2 * height / angle
    if not (velocity > lo * (1 + 1e-9) and velocity <= hi * (1 + 1e-12)):
        raise InputError(f'{key}.velocity', velocity,
                         f'height/angle < velocity <= 2 height/angle, i.e. in ({lo:.6g}, '
                         f'{hi:.6g}] m/rad (S2 ramp existence condition)')
    excess = velocity * angle - height
    beta1 = min(2 * excess / velocity, angle)
    return PatentRamp(e0=height - velocity * angle, e1=velocity, beta1=beta1,
                      cb=velocity ** 2 / (4 * excess))


def constant_velocity_ramp(height: float, velocity: float, *, key: str = 'ramp') -> Ramp:
    """h = v t up to H_r: angle H_r / v."""
    if height <= 0:
        raise InputError(f'{key}.height', height, 'a ramp height > 0 m')
    if velocity <= 0:
        raise InputError(f'{key}.velocity', velocity, 'a ramp velocity > 0 m/rad')
    angle = height / velocity
    seg = PowerSegment(0.0, angle, 0.0, angle, coefficients=((1, height),))
    return Ramp((seg,), (0,), height, velocity, angle)


def acceleration_velocity_ramp(height: float, velocity: float, angle: float, *,
                               key: str = 'ramp') -> Ramp:
    """The S2 ramp (constant acceleration then constant velocity), C1."""
    c = patent_ramp_coefficients(height, velocity, angle, key=key)
    segs: list[Segment] = [PowerSegment(0.0, c.beta1, 0.0, angle,
                                        coefficients=((2, c.cb * angle ** 2),))]
    required = [1]
    if angle - c.beta1 > 1e-12 * angle:
        segs.append(PowerSegment(c.beta1, angle, 0.0, angle,
                                 coefficients=((0, c.e0), (1, c.e1 * angle))))
        required.append(1)
        return Ramp(tuple(segs), tuple(required), height, velocity, angle)
    return Ramp(tuple(segs), tuple(required), height, velocity, angle, 2 * c.cb)


def no_ramp() -> Ramp:
    """No ramp: the base section starts on the base circle with zero velocity."""
    return Ramp((), (), 0.0, 0.0, 0.0)


def ramp_from_spec(spec: Any, key: str, *, default_kind: str | None = None) -> Ramp:
    """Build a ramp from ``{kind, height [m], velocity [m/rad], angle [rad]}``.

    ``kind`` constant_velocity needs height and velocity; constant_acceleration_velocity
    (the patent ramp) needs height, velocity and angle; none (or a null spec) is no ramp.
    """
    if spec is None or spec == 'none':
        return no_ramp()
    spec = P.mapping(spec, key)
    kind = P.choice(spec, key, 'kind', RAMP_KINDS, default_kind or P.MISSING)
    if kind == 'none':
        P.reject_unknown(spec, key, ('kind',))
        return no_ramp()
    if kind == 'constant_velocity':
        P.reject_unknown(spec, key, ('kind', 'height', 'velocity'))
        return constant_velocity_ramp(P.lift(spec, key, 'height'),
                                      P.positive(spec, key, 'velocity'), key=key)
    P.reject_unknown(spec, key, ('kind', 'height', 'velocity', 'angle'))
    return acceleration_velocity_ramp(P.lift(spec, key, 'height'),
                                      P.positive(spec, key, 'velocity'),
                                      P.angle(spec, key, 'angle'), key=key)


def ramp_spec_example() -> Mapping[str, Any]:
    """The §1.1 example in SI: H1 = 0.3 mm, v1 = 0.015 mm/deg, alpha1 = 30 deg."""
    import math

    return {'kind': 'constant_acceleration_velocity', 'height': 3e-4,
            'velocity': 0.015e-3 * 180 / math.pi, 'angle': math.radians(30)}
