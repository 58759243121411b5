"""Dowel pin measured as a cam (Liu, docs/metrology.md).

A cylinder of radius ``pin_radius`` (R_x) has its centre on a circle of radius
``circle_radius`` (R_z) about the shaft axis; a ball probe of radius ``probe_radius``
(R_c) moves radially and touches the pin from outside. With alpha [rad] the shaft
angle of the pin centre from the probe's line of motion and rho = R_x + R_c, the
probe-centre distance from the axis is

    L(alpha) = R_z cos(alpha) + sqrt(rho^2 - R_z^2 sin^2(alpha)),

and the seed's lift is h = L - R_c (distance of the probe tip from the axis). Contact
exists for |alpha| <= alpha_max = arcsin(rho / R_z), where |h'| becomes infinite.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_positive


@dataclass(frozen=True)
class DowelPinGeometry:
    """Pin and probe radii [m]; validates that the probe can touch the pin."""

    pin_radius: float
    circle_radius: float
    probe_radius: float

    def __post_init__(self) -> None:
        require_positive('dowel_pin.pin_radius', self.pin_radius)
        require_positive('dowel_pin.circle_radius', self.circle_radius)
        require_positive('dowel_pin.probe_radius', self.probe_radius, allow_zero=True)
        if self.pin_radius + self.probe_radius >= self.circle_radius:
            raise InputError(
                'dowel_pin.circle_radius', self.circle_radius,
                f'more than pin_radius + probe_radius = '
                f'{self.pin_radius + self.probe_radius:g} m (else the pin covers the axis)')

    @property
    def contact_half_angle(self) -> float:
        """alpha_max [rad]: beyond it the probe no longer touches the pin."""
        return float(np.arcsin((self.pin_radius + self.probe_radius) / self.circle_radius))

    @property
    def lift_min(self) -> float:
        """h at alpha_max [m]: R_z cos(alpha_max) - R_c."""
        return float(self.circle_radius * np.cos(self.contact_half_angle) - self.probe_radius)

    @property
    def lift_max(self) -> float:
        """h at alpha = 0 [m]: R_z + R_x (the probe tip on top of the pin)."""
        return float(self.circle_radius + self.pin_radius)

    def lift(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        """nu-th derivative (0..3) of h at ``alpha`` [rad]; NaN where there is no contact.

        Units: m, m/rad, m/rad^2, m/rad^3. The derivatives are analytic (methods.md
        §5.4, with the cos(alpha) factor the seed's printed h' lacks).
        """
        out = centre_distance(alpha, nu, self.circle_radius, self.pin_radius + self.probe_radius)
        return out - self.probe_radius if nu == 0 else out


def centre_distance(alpha: ArrayLike, nu: int, circle_radius: float,
                    rho: float) -> NDArray[np.float64]:
    """nu-th derivative (0..3) of L(alpha) = R_z cos(alpha) + sqrt(rho^2 - R_z^2 sin^2(alpha))
    [m, m/rad^nu]: the distance from the shaft axis of a ball centre that moves radially
    and touches, at distance ``rho`` [m], a point (a pin axis, or a sharp edge with
    rho = the ball radius) on the circle ``circle_radius`` [m] at angle ``alpha`` [rad]
    from the ball's line; NaN where there is no contact (also behind the axis)."""
    a = np.asarray(alpha, dtype=float)
    rz = circle_radius
    sin_a, cos_a = np.sin(a), np.cos(a)
    radicand = rho * rho - (rz * sin_a) ** 2
    # cos(alpha) > 0: the point is on the ball's side of the axis (rho < R_z, so the
    # radicand alone would also admit the mirror region behind the axis).
    contact = (radicand > 0.0) & (cos_a > 0.0)
    s = np.sqrt(np.where(contact, radicand, np.nan))
    s2a, c2a = np.sin(2 * a), np.cos(2 * a)
    if nu == 0:
        out = rz * cos_a + s
    elif nu == 1:
        out = -rz * sin_a * (1.0 + rz * cos_a / s)
    elif nu == 2:
        out = -rz * cos_a - rz**2 * c2a / s - 0.25 * rz**4 * s2a**2 / s**3
    elif nu == 3:
        out = (rz * sin_a + 2 * rz**2 * s2a / s - 1.5 * rz**4 * s2a * c2a / s**3
               - 0.375 * rz**6 * s2a**3 / s**5)
    else:
        raise InputError('nu', nu, 'a derivative order 0..3')
    # alpha = +-alpha_max exactly: L is finite (radicand 0), the slope is not.
    edge = (radicand == 0.0) & (cos_a > 0.0)
    if nu == 0 and np.any(edge):
        out = np.where(edge, rz * cos_a, out)
    return np.asarray(out, dtype=float)
