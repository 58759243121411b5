"""Friction torques of the camshaft (docs/camshaft.md): cam-follower contact (flat tappet:
constant coefficient or a mixed-lubrication law on the oil-film parameter; roller:
rolling resistance and a slip check) and the journal bearings.

All functions take the contact force F [N] (cam side), the lift h [m] and its cam-angle
derivatives h' [m/rad], h'' [m/rad^2] at the lobe's own cam angle, the base-circle
radius R0 [m], and return torques [N m] that resist the shaft's rotation.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam_design.camshaft.spec import FlatFriction, RollerFriction

#: film parameter Lambda = h_min / sigma at or below which the contact is boundary
#: lubricated, and at or above which it is full-film (Hamrock's regimes)
LAMBDA_BOUNDARY, LAMBDA_FULL = 1.0, 3.0
#: exponent of the speed in the EHL minimum film thickness (Hamrock-Dowson: u^0.68)
FILM_SPEED_EXPONENT = 0.68


def film_parameter(h: NDArray[np.float64], d2h: NDArray[np.float64], base_radius: float,
                   spec: FlatFriction, rpm: float) -> NDArray[np.float64]:
    """Lambda = h_min / roughness of a flat tappet, with the oil-film check's
    h_min = K (R0 + h) sqrt|2 g^2 - g|, g = rho / (R0 + h), rho = R0 + h + h'', and
    K = k_film (rpm / k_film_rpm)^0.68."""
    p = base_radius + h
    g = (p + d2h) / p
    k = spec.k_film * (rpm / spec.k_film_rpm) ** FILM_SPEED_EXPONENT
    h_min = k * p * np.sqrt(np.abs(2.0 * g * g - g))
    return h_min / spec.roughness


def mixed_coefficient(lam: NDArray[np.float64], boundary: float,
                      fluid: float) -> NDArray[np.float64]:
    """Friction coefficient over the film parameter: ``boundary`` for Lambda <= 1,
    ``fluid`` for Lambda >= 3, linear in between (mixed regime)."""
    share = np.clip((LAMBDA_FULL - lam) / (LAMBDA_FULL - LAMBDA_BOUNDARY), 0.0, 1.0)
    return fluid + (boundary - fluid) * share


def flat_friction_torque(force: NDArray[np.float64], h: NDArray[np.float64],
                         d2h: NDArray[np.float64], base_radius: float, spec: FlatFriction,
                         rpm: float) -> NDArray[np.float64]:
    """mu F (R0 + h): the friction force mu F lies in the tappet face, whose distance
    from the cam axis is R0 + h; the cam surface always slides forward on the face."""
    if spec.coefficient is not None:
        mu: NDArray[np.float64] | float = spec.coefficient
    else:
        mu = mixed_coefficient(film_parameter(h, d2h, base_radius, spec, rpm),
                               spec.boundary, spec.fluid)
    return mu * force * (base_radius + h)


def roller_lever(h: NDArray[np.float64], dh: NDArray[np.float64], base_radius: float,
                 roller_radius: float) -> NDArray[np.float64]:
    """Distance [m] from the cam axis to the common tangent at the contact of an in-line
    roller: s cos(psi) - r, s = R0 + r + h the pitch radius, tan(psi) = h' / s."""
    s = base_radius + roller_radius + h
    return s / np.sqrt(1.0 + (dh / s) ** 2) - roller_radius


def roller_friction_torque(force: NDArray[np.float64], h: NDArray[np.float64],
                           dh: NDArray[np.float64], base_radius: float,
                           roller_radius: float, spec: RollerFriction) -> NDArray[np.float64]:
    """Rolling resistance (f_r F) and the pin friction referred to the rim
    (mu_pin F r_pin / r) acting along the tangent, times ``roller_lever``."""
    tangential = force * (spec.rolling_resistance
                          + spec.pin_coefficient * spec.pin_radius / roller_radius)
    return tangential * roller_lever(h, dh, base_radius, roller_radius)


def roller_slip(force: NDArray[np.float64], h: NDArray[np.float64], dh: NDArray[np.float64],
                alpha: NDArray[np.float64], base_radius: float, roller_radius: float,
                spec: RollerFriction, omega: float) -> dict[str, float | None]:
    """Roller-slip check: the traction needed to keep the roller rolling,
    (J_r |d Omega_r / dt| + mu_pin F r_pin) / r, against what the contact transmits,
    traction F. The roller's speed is Omega_r = omega l / r, l = ``roller_lever`` (the
    cam surface speed at the contact, omega l, shared by the rim). Returns the largest
    ratio needed/available where the follower is loaded (F > 0), its angle [deg] and
    the angular extent [deg] where it exceeds 1 (the roller slips)."""
    lever = roller_lever(h, dh, base_radius, roller_radius)
    spin = omega * lever / roller_radius                            # rad/s
    d_alpha = np.gradient(alpha)
    accel = np.gradient(spin) / d_alpha * omega                      # rad/s^2
    need = (spec.inertia * np.abs(accel)
            + spec.pin_coefficient * force * spec.pin_radius) / roller_radius
    avail = spec.traction * force
    loaded = force > 0
    if not np.any(loaded) or spec.traction <= 0:
        return {'roller_slip_ratio_max': None, 'roller_slip_ratio_max_deg': None,
                'roller_slip_deg': 0.0}
    ratio = np.where(loaded, need / np.where(loaded, avail, 1.0), 0.0)
    i = int(np.argmax(ratio))
    return {'roller_slip_ratio_max': float(ratio[i]),
            'roller_slip_ratio_max_deg': math.degrees(float(alpha[i])),
            'roller_slip_deg': math.degrees(float(np.sum(d_alpha[ratio > 1.0])))}


def bearing_friction_torque(radial_load: NDArray[np.float64], coefficient: float,
                            journal_radius: float) -> NDArray[np.float64]:
    """Journal bearing friction torque mu_b |W| r_j [N m] of a radial load W [N]."""
    return coefficient * np.abs(radial_load) * journal_radius
