"""Hydraulic lash adjuster (HLA): a plunger on a high-pressure oil chamber that leaks
down under load and refills through a check valve on the base circle.

Chamber: (V / K) dp/dt = -A x' - Q_gap(p) + Q_check(p), with the plunger position x
(extension, m), the load F carried by the oil, p = F / A while the plunger is loaded, and
the leakage through the annular plunger gap (laminar, concentric):
Q_gap = pi d c^3 p / (12 mu L) (d: plunger diameter, c: radial clearance, L: gap length,
mu: oil viscosity). Under a constant load the plunger sinks at x' = -Q_gap / A, so it
leaks down a stroke s in t = 12 mu L s A / (pi d c^3 p).

On the base circle the light plunger spring (force F_s) extends it and the check valve
refills the chamber from the gallery, taking up the lash. At overspeed the valve train
separates and the plunger extends during the lift as well: that net extension over a
cycle is **pump-up** (the valve can no longer seat), reported by ``cycle``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_positive


@dataclass(frozen=True)
class LashAdjuster:
    """HLA dimensions and oil (SI)."""

    plunger_diameter: float = 0.012     # m
    clearance: float = 4.0e-6           # m, radial gap
    gap_length: float = 0.008           # m
    viscosity: float = 0.01             # Pa s
    spring_force: float = 10.0          # N, plunger spring
    gallery_pressure: float = 2.0e5     # Pa (gauge), oil supply
    refill_rate: float = 2.0e-3         # m/s, largest extension speed the check valve feeds
    max_stroke: float = 3.0e-3          # m
    # used by the coupled model (hla_coupled.py)
    check_area: float = 1.0e-6          # m^2, check-valve orifice
    chamber_volume: float = 2.0e-7      # m^3, high-pressure chamber
    bulk_modulus: float = 1.5e9         # Pa, pure oil
    air_fraction: float = 0.0           # free air at atmospheric pressure
    oil_density: float = 850.0          # kg/m^3
    ratio: float = 1.0                  # valve-side displacement per HLA displacement

    def __post_init__(self) -> None:
        for name in ('plunger_diameter', 'clearance', 'gap_length', 'viscosity',
                     'refill_rate', 'max_stroke', 'check_area', 'chamber_volume',
                     'bulk_modulus', 'oil_density', 'ratio'):
            require_positive(f'hla.{name}', getattr(self, name))
        require_positive('hla.spring_force', self.spring_force, allow_zero=True)
        require_positive('hla.gallery_pressure', self.gallery_pressure, allow_zero=True)
        if not 0.0 <= self.air_fraction < 1.0:
            raise InputError('hla.air_fraction', self.air_fraction,
                             'a volume fraction in [0, 1)')

    @property
    def area(self) -> float:
        """Plunger area [m^2]."""
        return math.pi * self.plunger_diameter ** 2 / 4

    @property
    def gap_conductance(self) -> float:
        """Laminar conductance of the annular gap [m^3/(s Pa)]: pi d c^3 / (12 mu L)."""
        return (math.pi * self.plunger_diameter * self.clearance ** 3
                / (12.0 * self.viscosity * self.gap_length))

    def leak_down_time(self, load: float, stroke: float) -> float:
        """Time [s] to sink ``stroke`` [m] under a constant ``load`` [N] (closed form)."""
        p = require_positive('load', load) / self.area
        return require_positive('stroke', stroke) * self.area / (self.gap_conductance * p)

    def velocity(self, load: float | NDArray) -> NDArray[np.float64]:
        """Plunger speed x' [m/s] under the train ``load`` [N] (> 0 extends): loaded,
        it leaks down; unloaded below the spring force, it extends at the refill rate."""
        f = np.asarray(load, dtype=float)
        p = np.maximum(f - self.spring_force, 0.0) / self.area
        sink = -self.gap_conductance * p / self.area
        return np.where(f > self.spring_force, sink, self.refill_rate)


@dataclass
class CycleResult:
    """One cam cycle of the HLA under a given load history."""

    extension: NDArray[np.float64]      # m, plunger extension relative to the start
    net_extension: float                # m over the cycle (> 0: pumps up)
    leak_down: float                    # m lost while loaded
    pumped_up: bool


def cycle(hla: LashAdjuster, t: ArrayLike, load: ArrayLike, *,
          base_circle: ArrayLike, tol: float = 1e-6) -> CycleResult:
    """Integrate the plunger extension x [m] (0 = zero lash at the start) over one cycle
    of the load history ``load(t)`` [N], e.g. the cam-follower force of an SDOF run.

    * loaded above the plunger spring force: it leaks down (x' = -Q_gap / A);
    * on the base circle (``base_circle`` True) and unloaded: the check valve refills it
      at ``refill_rate`` until the lash is taken up again (x = 0), no further;
    * unloaded during the lift (the train has separated): it extends at ``refill_rate``
      and the check valve keeps what it gained: pump-up, reported when the net
      extension over the cycle exceeds ``tol`` [m]."""
    tt = np.asarray(t, dtype=float)
    f = np.asarray(load, dtype=float)
    bc = np.asarray(base_circle, dtype=bool)
    if tt.shape != f.shape or f.shape != bc.shape or tt.ndim != 1 or tt.size < 2 \
            or np.any(np.diff(tt) <= 0):
        raise InputError('load', f.shape, 'one load and one base-circle flag per time, '
                         'times increasing')
    v = hla.velocity(f)
    x = np.zeros(tt.size)
    down = 0.0
    for i in range(1, tt.size):
        dt = tt[i] - tt[i - 1]
        step = 0.5 * (v[i] + v[i - 1]) * dt
        if step < 0:
            down -= step
        xi = x[i - 1] + step
        if bc[i] and step > 0:
            xi = min(xi, max(x[i - 1], 0.0))       # refill only back to zero lash
        x[i] = min(max(xi, -hla.max_stroke), hla.max_stroke)
    return CycleResult(extension=x, net_extension=float(x[-1]), leak_down=down,
                       pumped_up=bool(x[-1] > tol))
