"""The epsilon criterion of docs/dynamics.md (Shang §3.3, reconstructed).

In the open phase (undamped) the SDOF model divided by c_sum = c + c' reads
eps y'' + y = q(alpha), alpha in rad, with

    eps = M omega^2 / c_sum = (omega / omega_n)^2     (dimensionless)
    q   = (c u - F0) / c_sum                          (quasi-static lift)

Shang (1988) prints eps = M omega^3 / c, which has units of 1/s and is dimensionally
inconsistent; the dimensionless parameter is M omega^2 / c (we use c + c' by default,
``use_spring=False`` gives Shang's c; which one Shang (1988) means is an open item).
A jump Delta q^(j) of the j-th derivative of q (j >= 1, including the mismatch at the
opening, where the valve starts at rest) adds a free vibration of amplitude
eps^(j/2) |Delta q^(j)|: O(sqrt(eps)) for a velocity step, O(eps) for an acceleration
step, O(eps^1.5) for a jerk step. The thresholds of Shang's selection rule (pp.
77-89) are not available: the allowed amplitude is an input here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cam_design.errors import require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.params import SdofParams, omega_of_rpm

_ONE_SIDED = 1e-9
FAMILIES = {
    1: 'constant-acceleration or composite cam (acceleration steps are tolerated)',
    2: 'jerk-continuous cam (high-order polynomial, N-harmonic)',
    3: 'polydyne correction at the design speed',
}


def epsilon(params: SdofParams, rpm: float, *, use_spring: bool = True) -> float:
    """eps = M omega^2 / (c + c') (or / c with ``use_spring=False``), dimensionless."""
    omega = omega_of_rpm(rpm)
    c = params.stiffness + (params.spring_rate if use_spring else 0.0)
    return params.mass * omega ** 2 / c


def natural_frequency_hz(params: SdofParams) -> float:
    """f_n = sqrt((c + c')/M) / 2 pi [Hz] of the open valve."""
    return math.sqrt((params.stiffness + params.spring_rate) / params.mass) / (2 * math.pi)


@dataclass
class EpsilonReport:
    """eps at one speed, the predicted vibration per continuity class and advice."""

    rpm: float
    eps: float
    eps_book_c: float                       # M omega^2 / c
    natural_period_deg: float               # 2 pi sqrt(eps) in cam degrees
    static_deviation_m: float               # eps * max |q''|
    jumps: dict[int, float] = field(default_factory=dict)       # j -> max |Delta q^(j)|
    amplitudes_m: dict[int, float] = field(default_factory=dict)  # j -> eps^(j/2) |dq|
    predicted_amplitude_m: float = 0.0
    recommendation: str = ''

    def as_dict(self) -> dict[str, object]:
        """JSON-ready (keys with units)."""
        return {
            'cam_speed_rpm': self.rpm, 'epsilon': self.eps, 'epsilon_c': self.eps_book_c,
            'natural_period_deg': self.natural_period_deg,
            'static_deviation_m': self.static_deviation_m,
            'jumps': {f'q{j}': v for j, v in self.jumps.items()},
            'amplitudes_m': {f'q{j}': v for j, v in self.amplitudes_m.items()},
            'predicted_amplitude_m': self.predicted_amplitude_m,
            'recommendation': self.recommendation,
        }


def continuity_jumps(law: LiftLaw, params: SdofParams) -> dict[int, float]:
    """max |Delta q^(j)| (j = 1, 2, 3) over the law's junctions inside the open phase
    and the start mismatch at the rigid opening (valve at rest: Delta q^(j) = q^(j))."""
    p = params
    scale = p.stiffness * p.rocker_ratio / (p.stiffness + p.spring_rate)
    h_open = (p.lash + p.spring_preload / p.stiffness) / p.rocker_ratio
    lo, hi = law.support
    grid = np.linspace(lo, hi, 20001)
    h = law(grid)
    above = np.nonzero(h > h_open)[0]
    out = {1: 0.0, 2: 0.0, 3: 0.0}
    if above.size == 0:
        return out
    a_open, a_close = float(grid[above[0]]), float(grid[above[-1]])
    for a in (a_open, a_close):
        for j in (1, 2, 3):
            out[j] = max(out[j], scale * abs(float(law(a, j))))
    for a in law.junctions:
        if not a_open < a < a_close:
            continue
        for j in (1, 2, 3):
            d = float(law(a + _ONE_SIDED, j) - law(a - _ONE_SIDED, j))
            if abs(d) > 1e-6 * max(1.0, abs(float(law(a, j)))):
                out[j] = max(out[j], scale * abs(d))
    return out


def assess(law: LiftLaw, params: SdofParams, rpm: float, *,
           allowed_amplitude: float = 1e-5, use_spring: bool = True) -> EpsilonReport:
    """eps at ``rpm``, predicted vibration eps^(j/2) |Delta q^(j)| and the family advice.

    ``allowed_amplitude`` [m]: the valve-motion error the user accepts (e.g. the
    lash/seating tolerance). Advice: the lowest continuity class j whose predicted
    vibration, estimated with this lobe's own magnitudes max |q^(j)|, is below it.
    """
    allowed = require_positive('allowed_amplitude', allowed_amplitude)
    eps = epsilon(params, rpm, use_spring=use_spring)
    eps_c = epsilon(params, rpm, use_spring=False)
    p = params
    scale = p.stiffness * p.rocker_ratio / (p.stiffness + p.spring_rate)
    lo, hi = law.support
    grid = np.linspace(lo, hi, 20001)
    qmax = {j: scale * float(np.max(np.abs(law(grid, j)))) for j in (1, 2, 3)}
    jumps = continuity_jumps(law, params)
    amps = {j: eps ** (j / 2) * jumps[j] for j in (1, 2, 3)}
    rec = FAMILIES[3]
    for j, fam in FAMILIES.items():
        # class j tolerates steps in q^(j+1): typical step ~ max |q^(j+1)|
        typical = eps ** ((j + 1) / 2) * qmax.get(j + 1, qmax[3])
        if typical <= allowed:
            rec = fam
            break
    return EpsilonReport(rpm=float(rpm), eps=eps, eps_book_c=eps_c,
                         natural_period_deg=math.degrees(2 * math.pi * math.sqrt(eps)),
                         static_deviation_m=eps * qmax[2], jumps=jumps, amplitudes_m=amps,
                         predicted_amplitude_m=max(amps.values()), recommendation=rec)
