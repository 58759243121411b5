"""Parameters of the single-DOF valve-train model (docs/contract.md ``sdof``), validated.

All quantities are referred to the valve side, SI units: masses kg, stiffnesses N/m,
dampings N s/m, forces N, lengths m. ``restitution`` None selects the penalty seat of
the contract; a number in [0, 1] selects the hard seat with that coefficient.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from cam_design.errors import InputError, require_finite, require_positive


@dataclass(frozen=True)
class SdofParams:
    """The ``sdof`` model: M y'' = F_t + R_seat - F0 - c' y - b_v y' (docs/dynamics.md)."""

    mass: float                 # M [kg], equivalent mass at the valve
    stiffness: float            # c [N/m], train stiffness at the valve
    damping: float              # b_t [N s/m], train damping
    spring_rate: float          # c' [N/m]
    spring_preload: float       # F0 [N] at the closed valve
    rocker_ratio: float         # k (valve side / tappet side)
    lash: float                 # x0 [m] at the valve
    valve_damping: float = 0.0  # b_v [N s/m]
    seat_stiffness: float = 1.0e9   # k_s [N/m] (penalty seat)
    seat_damping: float = 2000.0    # b_s [N s/m] (penalty seat)
    restitution: float | None = None  # hard seat coefficient e_s, None: penalty seat
    key: str = 'valve_train'    # prefix of parameter names in error messages

    def __post_init__(self) -> None:
        k = self.key
        pos = {'mass': self.mass, 'stiffness': self.stiffness,
               'rocker_ratio': self.rocker_ratio}
        for name, value in pos.items():
            require_positive(f'{k}.{name}', value)
        nonneg = {'damping': self.damping, 'spring_rate': self.spring_rate,
                  'spring_preload': self.spring_preload, 'lash': self.lash,
                  'valve_damping': self.valve_damping}
        for name, value in nonneg.items():
            require_positive(f'{k}.{name}', value, allow_zero=True)
        if self.restitution is None:
            require_positive(f'{k}.seat.stiffness', self.seat_stiffness)
            require_positive(f'{k}.seat.damping', self.seat_damping, allow_zero=True)
        else:
            e = require_finite(f'{k}.seat.restitution', self.restitution)
            if not 0.0 <= e <= 1.0:
                raise InputError(f'{k}.seat.restitution', self.restitution,
                                 'a coefficient of restitution in [0, 1]')
        if self.spring_rate == 0.0 and self.spring_preload == 0.0:
            raise InputError(f'{k}.spring_rate', self.spring_rate,
                             'a spring rate > 0 when spring_preload is 0 (nothing '
                             'would close the valve)')
        # products that must stay finite in float64 (rates of the stiffest regime)
        for name, value in (('stiffness', self.stiffness),
                            ('seat.stiffness', self.seat_stiffness)):
            if not math.isfinite(value / self.mass) or value / self.mass > 1e30:
                raise InputError(f'{k}.{name}', value,
                                 f'a stiffness with {name}/mass <= 1e30 1/s^2')

    @property
    def hard_seat(self) -> bool:
        """True for the hard seat with restitution, False for the penalty seat."""
        return self.restitution is not None

    @property
    def seated_lift(self) -> float:
        """Static valve lift [m] on the seat with the cam off: -F0/(k_s + c'); 0 (hard)."""
        if self.hard_seat:
            return 0.0
        return -self.spring_preload / (self.seat_stiffness + self.spring_rate)

    def with_(self, **changes: Any) -> 'SdofParams':
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @classmethod
    def from_valve_train(cls, vt: Any, key: str = 'valve_train') -> 'SdofParams':
        """Build from a ``cam_metrology.scene.model.ValveTrain``-like object (duck-typed)."""
        seat = getattr(vt, 'seat', None)
        return cls(mass=vt.mass, stiffness=vt.stiffness, damping=vt.damping,
                   spring_rate=vt.spring_rate, spring_preload=vt.spring_preload,
                   rocker_ratio=vt.rocker_ratio, lash=vt.lash,
                   valve_damping=getattr(vt, 'valve_damping', 0.0),
                   seat_stiffness=getattr(seat, 'stiffness', 1.0e9),
                   seat_damping=getattr(seat, 'damping', 2000.0),
                   restitution=getattr(seat, 'restitution', None), key=key)


#: accepted camshaft speeds [rpm] (as ``cam_design.checks``): above 1e5 rpm a valve
#: train has long stopped following any cam (no opening, no seating).
RPM_MAX = 1.0e5
#: accepted output steps [deg]: below 0.01 deg a revolution is > 36 000 steps (seconds
#: and hundreds of MB; the solver is exact between nodes, the step only sets the grid).
STEP_DEG_MIN, STEP_DEG_MAX = 0.01, 5.0


def require_rpm(key: str, rpm: Any) -> float:
    """``rpm`` as float if it is a camshaft speed in (0, RPM_MAX] rpm, else InputError."""
    value = require_positive(key, rpm)
    if value > RPM_MAX:
        raise InputError(key, rpm, f'a camshaft speed in (0, {RPM_MAX:g}] rpm')
    return value


def require_step_deg(key: str, step_deg: Any) -> float:
    """``step_deg`` as float if it is in [STEP_DEG_MIN, STEP_DEG_MAX] deg, else InputError.

    Checked before anything is allocated (a 1e-7 deg step would need 27 GiB).
    """
    expected = f'a step in [{STEP_DEG_MIN:g}, {STEP_DEG_MAX:g}] deg'
    try:
        value = float(step_deg)
    except (TypeError, ValueError):
        raise InputError(key, step_deg, expected) from None
    if isinstance(step_deg, bool) or not STEP_DEG_MIN <= value <= STEP_DEG_MAX:  # NaN too
        raise InputError(key, step_deg, expected)
    return value


def omega_of_rpm(rpm: float, key: str = 'cam_speed_rpm') -> float:
    """Cam angular speed [rad/s] from camshaft rpm (in (0, RPM_MAX], finite)."""
    value = require_rpm(key, rpm)
    return value * 2.0 * math.pi / 60.0
