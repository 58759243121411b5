"""Cylinder-gas force on a valve head, from a cylinder-pressure table versus crank angle.

F_gas = (p_cyl - p_port) pi d^2 / 4 pushes an exhaust valve shut: the train must
overcome it to open the valve. Crank angle phi and cam angle alpha are tied by
phi = phi0 + 2 (alpha - alpha0) (four-stroke), with phi0 the crank angle at which the lobe
angle alpha0 is under the follower.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_positive


def gas_force(crank_deg: ArrayLike, pressure: ArrayLike, head_diameter: float,
              back_pressure: float = 0.0) -> Callable[[float], float]:
    """The cylinder-gas force on a valve head [N] as a function of crank angle [deg]:
    (p_cyl - p_port) pi d^2 / 4, from a pressure table (gauge Pa) interpolated linearly and
    periodically over 720 deg. Returns a callable of crank angle [deg]."""
    phi = np.asarray(crank_deg, dtype=float)
    p = np.asarray(pressure, dtype=float)
    if phi.shape != p.shape or phi.ndim != 1 or phi.size < 2 or np.any(np.diff(phi) <= 0):
        raise InputError('gas.crank_deg', phi.shape, 'increasing crank angles, one pressure '
                         'each')
    area = math.pi * require_positive('gas.head_diameter', head_diameter) ** 2 / 4

    def force(crank: float) -> float:
        return float(area * (np.interp(crank % 720.0, phi, p, period=720.0) - back_pressure))

    return force


def on_cam_angle(force: Callable[[float], float], phi0_deg: float,
                 alpha0: float = 0.0) -> Callable[[float], float]:
    """The same force as a function of the lobe's cam angle alpha [rad]."""
    def at_alpha(alpha: float) -> float:
        return force(phi0_deg + 2.0 * math.degrees(alpha - alpha0))

    return at_alpha


def gas_events(gas: Callable[[float], float], alpha: NDArray[np.float64],
               opening_deg: float | None) -> dict[str, Any]:
    """Gas-force fields of a run: largest force [N] on the angles ``alpha`` [rad] and
    where [deg], the force at the opening (``opening_deg``, None if the valve never
    opened)."""
    g = np.array([float(gas(float(x))) for x in alpha])
    i = int(np.argmax(g))
    return {'gas_force_max_n': float(g[i]), 'gas_force_max_deg': math.degrees(float(alpha[i])),
            'gas_force_at_opening_n': None if opening_deg is None
            else float(gas(math.radians(opening_deg)))}
