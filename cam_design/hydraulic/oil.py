"""Oil properties: effective bulk modulus with entrained air, wave speed, orifice law."""
from __future__ import annotations

import math

from cam_design.errors import InputError, require_positive

#: atmospheric pressure [Pa], the reference of the air fraction
P_ATM = 101_325.0


def effective_bulk_modulus(bulk_modulus: float, air_fraction: float, pressure: float,
                           polytropic: float = 1.0) -> float:
    """K_eff [Pa] of oil with free air (volume fraction ``air_fraction`` at atmospheric
    pressure), at absolute ``pressure`` [Pa]: the mixture's compliance is the oil's plus
    the air's, 1/K_eff = (1 - x)/K + x/(n p) with the air volume fraction x at p
    (isothermal n = 1 by default; Boyle: the air shrinks as P_ATM/p)."""
    k = require_positive('bulk_modulus', bulk_modulus)
    x0 = float(air_fraction)
    if not 0.0 <= x0 < 1.0:
        raise InputError('air_fraction', air_fraction, 'a volume fraction in [0, 1)')
    p = max(float(pressure), 1.0)
    if x0 == 0.0:
        return k
    air = x0 * (P_ATM / p) ** (1.0 / polytropic)
    x = air / (air + (1.0 - x0))
    return 1.0 / ((1.0 - x) / k + x / (polytropic * p))


def wave_speed(bulk_modulus: float, density: float) -> float:
    """Pressure-wave speed a = sqrt(K/rho) [m/s] (rigid pipe wall)."""
    return math.sqrt(require_positive('bulk_modulus', bulk_modulus)
                     / require_positive('oil_density', density))


def orifice_flow(dp: float, area: float, density: float, cd: float = 0.7,
                 dp_lin: float = 1.0e4) -> float:
    """Flow [m^3/s] through an orifice of ``area`` [m^2] for the pressure drop ``dp``
    [Pa] (signed): Q = cd A sqrt(2 |dp| / rho) sign(dp) for |dp| >= ``dp_lin``; below
    it the odd cubic Q = Q_lin (5 x - x^3) / 4, x = dp / dp_lin, Q_lin the square-root
    law at dp_lin, which is tangent-matched: value and slope dQ/ddp = Q_lin / (2 dp_lin)
    are continuous at |dp| = dp_lin (C1), and the flow is smooth through dp = 0 with the
    finite conductance 5 Q_lin / (4 dp_lin)."""
    if area <= 0.0:
        return 0.0
    if abs(dp) >= dp_lin:
        return math.copysign(cd * area * math.sqrt(2.0 * abs(dp) / density), dp)
    x = dp / dp_lin
    return cd * area * math.sqrt(2.0 * dp_lin / density) * x * (5.0 - x * x) / 4.0
