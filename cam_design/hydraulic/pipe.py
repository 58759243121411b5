"""The high-pressure pipe as 1-D transient flow, by the method of characteristics.

Equations (rigid pipe, small Mach number): dp/dt + (rho a^2 / A) dQ/dx = 0 and
dQ/dt + (A/rho) dp/dx + f Q|Q| / (2 D A) = 0. Along dx/dt = +-a they become
dp +- B dQ +- R Q|Q| dt' = 0 with B = rho a / A and R = rho f dx / (2 D A^2). With
dt = dx / a (Courant number 1) the characteristics meet the grid nodes exactly, so a
frictionless wave is propagated without numerical error. The friction term is integrated
along each characteristic by the trapezoidal rule, R/2 (Q_A|Q_A| + Q_P|Q_P|), with the
flow Q_P at the arrival node extrapolated linearly from its two previous values
(2 Q^n - Q^(n-1)): second order in dx, and explicit.

Cavitation: a node whose pressure would fall below the vapour pressure is clamped to
it and opens a vapour cavity whose volume follows the flow imbalance (discrete vapour
cavity model); the cavity collapses when its volume returns to zero.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive


@dataclass
class Pipe:
    """State and constants of a pipe of ``reaches`` equal reaches (``reaches + 1`` nodes)."""

    length: float            # m
    diameter: float          # m
    wave_speed: float        # m/s
    density: float           # kg/m^3
    friction: float = 0.0    # Darcy friction factor f
    reaches: int = 1
    vapour_pressure: float = -math.inf   # Pa, on the model's scale (-inf: never cavitates)
    p: NDArray[np.float64] = field(init=False)
    q: NDArray[np.float64] = field(init=False)
    cavity: NDArray[np.float64] = field(init=False)   # vapour volume per node [m^3]
    q_old: NDArray[np.float64] = field(init=False)    # flows one step earlier
    imbalance: NDArray[np.float64] = field(init=False)   # cavity outflow - inflow [m^3/s]

    def __post_init__(self) -> None:
        require_positive('pipe_length', self.length)
        require_positive('pipe_diameter', self.diameter)
        require_positive('wave_speed', self.wave_speed)
        if int(self.reaches) < 1:
            raise InputError('reaches', self.reaches, 'an integer >= 1')
        self.reaches = int(self.reaches)
        self.p = np.zeros(self.reaches + 1)
        self.q = np.zeros(self.reaches + 1)
        self.cavity = np.zeros(self.reaches + 1)
        self.q_old = np.zeros(self.reaches + 1)
        self.imbalance = np.zeros(self.reaches + 1)

    @property
    def area(self) -> float:
        """Flow area [m^2]."""
        return math.pi * self.diameter ** 2 / 4.0

    @property
    def dx(self) -> float:
        """Reach length [m]."""
        return self.length / self.reaches

    @property
    def dt(self) -> float:
        """Time step [s] at Courant number 1."""
        return self.dx / self.wave_speed

    @property
    def impedance(self) -> float:
        """B = rho a / A [Pa s/m^3]."""
        return self.density * self.wave_speed / self.area

    @property
    def resistance(self) -> float:
        """R = rho f dx / (2 D A^2) [Pa s^2/m^6]."""
        return self.density * self.friction * self.dx / (2.0 * self.diameter * self.area ** 2)

    def stored_volume(self, bulk_modulus: float) -> float:
        """Oil volume [m^3] stored by compression (trapezoid over the nodes, p A dx / K)
        minus the vapour cavities."""
        w = np.full(self.reaches + 1, self.area * self.dx)
        w[[0, -1]] *= 0.5
        return float(np.dot(w, self.p) / bulk_modulus - np.sum(self.cavity))

    def fill(self, pressure: float, flow: float = 0.0) -> None:
        """Uniform initial state (for a flow, the friction gradient is not set up)."""
        self.p[:] = pressure
        self.q[:] = flow
        self.q_old[:] = flow
        self.cavity[:] = 0.0
        self.imbalance[:] = 0.0

    def _friction(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Q|Q| at every node: half the value one step ago plus half the value
        extrapolated to the next step (the two ends of a characteristic)."""
        qa = self.q
        qp = 2.0 * self.q - self.q_old
        return 0.5 * (qa * np.abs(qa)), 0.5 * (qp * np.abs(qp))

    def c_plus(self) -> NDArray[np.float64]:
        """C_P at nodes 1..N: p_P = C_P - B Q_P (from the node on the left)."""
        b, r = self.impedance, self.resistance
        fa, fp = self._friction()
        return self.p[:-1] + b * self.q[:-1] - r * (fa[:-1] + fp[1:])

    def c_minus(self) -> NDArray[np.float64]:
        """C_M at nodes 0..N-1: p_P = C_M + B Q_P (from the node on the right)."""
        b, r = self.impedance, self.resistance
        fa, fp = self._friction()
        return self.p[1:] - b * self.q[1:] + r * (fa[1:] + fp[:-1])

    def step(self, p_left: float, q_left: float, p_right: float, q_right: float,
             cp: NDArray[np.float64], cm: NDArray[np.float64]) -> None:
        """Advance the interior nodes by one step with the characteristics ``cp``, ``cm``
        computed before the step; the end nodes take the boundary solution given."""
        b = self.impedance
        n = self.reaches
        p_new = np.empty(n + 1)
        q_new = np.empty(n + 1)
        if n > 1:
            cpi, cmi = cp[:-1], cm[1:]
            pp = 0.5 * (cpi + cmi)
            qq = (cpi - cmi) / (2.0 * b)
            vap = self.vapour_pressure
            cav = self.cavity[1:-1]
            low = (pp < vap) | (cav > 0.0)
            if np.any(low):
                q_in = (cpi - vap) / b          # flow arriving from the left
                q_out = (vap - cmi) / b         # flow leaving to the right
                imb = q_out - q_in
                cav_new = cav + 0.5 * (imb + self.imbalance[1:-1]) * self.dt   # trapezoid
                still = low & (cav_new > 0.0)
                pp = np.where(still, vap, pp)
                qq = np.where(still, 0.5 * (q_in + q_out), qq)
                self.cavity[1:-1] = np.where(still, cav_new, 0.0)
                self.imbalance[1:-1] = np.where(still, imb, 0.0)
            p_new[1:-1] = pp
            q_new[1:-1] = qq
        p_new[0], q_new[0] = p_left, q_left
        p_new[-1], q_new[-1] = p_right, q_right
        self.q_old = self.q
        self.p, self.q = p_new, q_new
