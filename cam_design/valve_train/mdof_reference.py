"""Reference solution of the 4+N1+N2 model with scipy ``solve_ivp`` and events.

The same equations and switching rules as ``mdof_exact`` written out force by force
(no regime matrices), the exact lift law (not its Hermite interpolant) with the law's
junctions as breakpoints, and every switch a terminal event at which the integration
restarts in the new regime. Slow; the truth of the tests and the benchmark.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.mdof import MdofAssembly, MdofParams
from cam_design.valve_train.params import omega_of_rpm

T, P, R, V = 0, 1, 2, 3
CAM, RV, SEAT = 1, 2, 4
_MAX_RESTARTS = 20000


@dataclass
class MdofReference:
    """States (len(alpha), 2n) at ``alpha`` [rad]; switches (alpha, which, regime)."""

    alpha: NDArray[np.float64]
    z: NDArray[np.float64]
    switches: list[tuple[float, int, int]] = field(default_factory=list)
    impacts: list[tuple[float, float]] = field(default_factory=list)

    @property
    def y(self) -> NDArray[np.float64]:
        return self.z[:, V]


class _Eq:
    def __init__(self, law: LiftLaw, mp: MdofParams, omega: float, a0: float) -> None:
        self.law, self.mp, self.omega, self.a0 = law, mp, omega, a0
        self.asm = MdofAssembly(mp)
        self.n = self.asm.n
        b = mp.base
        self.hard = b.hard_seat
        self._t = math.nan
        self._u = (0.0, 0.0)
        # piecewise polynomial laws (breaks, pieces): Horner on Python floats, the
        # same polynomials without numpy's per-call overhead
        self._fast = None
        if hasattr(law, 'breaks') and hasattr(law, 'pieces'):
            self._fast = (np.asarray(law.breaks, dtype=float).tolist(),
                          [(pc[0].convert().coef[::-1].tolist(),
                            pc[1].convert().coef[::-1].tolist()) for pc in law.pieces])

    def cam(self, t: float) -> tuple[float, float]:
        """(u, du/dt) at time t (the last one cached: rhs and events share it)."""
        if t == self._t:
            return self._u
        a = self.a0 + self.omega * t
        k = self.mp.base.rocker_ratio
        if self._fast is not None:
            br, pcs = self._fast
            h = h1 = 0.0
            if br[0] <= a <= br[-1]:
                i = min(max(bisect.bisect_right(br, a) - 1, 0), len(pcs) - 1)
                for c in pcs[i][0]:
                    h = h * a + c
                for c in pcs[i][1]:
                    h1 = h1 * a + c
        else:
            h, h1 = (float(v) for v in self.law.derivatives(np.array([a]))[:2, 0])
        self._t, self._u = t, (k * h, k * self.omega * h1)
        return self._u

    def forces(self, t: float, x: NDArray, xd: NDArray, r: int) -> NDArray:
        """Net force on every DOF in regime r (the unilateral ones as linear springs)."""
        a, b = self.asm, self.mp.base
        f = a.preload - a.k_lin @ x - a.c_lin @ xd
        if r & CAM:
            u, ud = self.cam(t)
            f[T] += a.k_c * (u - x[T]) + a.b_c * (ud - xd[T])
        if r & RV:
            frv = a.k_rv * (x[R] - x[V] - b.lash) + a.b_rv * (xd[R] - xd[V])
            f[R] -= frv
            f[V] += frv
        if r & SEAT and not self.hard:
            f[V] += -b.seat_stiffness * x[V] - b.seat_damping * xd[V]
        return f

    def rhs(self, t: float, z: NDArray, r: int) -> NDArray:
        n = self.n
        acc = self.forces(t, z[:n], z[n:], r) / self.asm.m
        out = np.concatenate([z[n:], acc])
        if self.hard and r & SEAT:
            out[V] = 0.0
            out[n + V] = 0.0
        return out

    def inside(self, t: float, z: NDArray, r: int) -> list[float]:
        """sign * min(...) of the three switching groups (cam, rocker-valve, seat)."""
        a, b = self.asm, self.mp.base
        n = self.n
        x, xd = z[:n], z[n:]
        u, ud = self.cam(t)
        d = u - x[T]
        gc = min(d, a.k_c * d + a.b_c * (ud - xd[T]))
        d2 = x[R] - x[V] - b.lash
        g2 = min(d2, a.k_rv * d2 + a.b_rv * (xd[R] - xd[V]))
        out = [gc if r & CAM else -gc, g2 if r & RV else -g2]
        if self.hard:
            if r & SEAT:
                out.append(-float(self.forces(t, x, xd, r & ~SEAT)[V]))
            else:
                out.append(float(x[V]))
        else:
            gs = min(-x[V], -b.seat_stiffness * x[V] - b.seat_damping * xd[V])
            out.append(gs if r & SEAT else -gs)
        return out


def _static(eq: _Eq) -> tuple[NDArray, int]:
    n = eq.n
    for r in (CAM | SEAT, CAM | RV | SEAT):
        # K x = f by linearity of the forces in x (velocities zero)
        f0 = eq.forces(0.0, np.zeros(n), np.zeros(n), r)
        kk = np.column_stack([f0 - eq.forces(0.0, np.eye(n)[i], np.zeros(n), r)
                              for i in range(n)])
        if eq.hard:
            kk[V, :] = 0.0
            kk[V, V] = 1.0
            f0[V] = 0.0
        x = np.linalg.solve(kk, f0)
        z = np.concatenate([x, np.zeros(n)])
        if min(eq.inside(0.0, z, r)) >= 0:
            return z, r
    raise RuntimeError('no static state')


def reference_mdof(law: LiftLaw, mp: MdofParams, rpm: float, alpha: NDArray[np.float64], *,
                   method: str = 'Radau', rtol: float = 1e-11, atol: float = 1e-16,
                   start: tuple[NDArray, int] | None = None) -> MdofReference:
    """States at the increasing angles ``alpha`` [rad] (one revolution at most) from the
    static state at alpha[0], or from ``start`` = (state, regime bits CAM=1 RV=2
    SEAT=4) there."""
    omega = omega_of_rpm(rpm)
    a0 = float(alpha[0])
    eq = _Eq(law, mp, omega, a0)
    n = eq.n
    t_out = (np.asarray(alpha, dtype=float) - a0) / omega
    t_end = float(t_out[-1])
    junctions = sorted({float(j) for j in (*law.junctions, *law.support)
                        if a0 < j < a0 + omega * t_end})
    breaks = [(j - a0) / omega for j in junctions] + [t_end]
    z, r = _static(eq) if start is None else (np.array(start[0], dtype=float), start[1])
    out = np.full((t_out.size, 2 * n), np.nan)
    out[0] = z
    t = 0.0
    res = MdofReference(alpha=np.asarray(alpha, dtype=float), z=out)
    e = float(mp.base.restitution or 0.0) if eq.hard else 0.0   # hard seat: set
    bi = 0
    for _ in range(_MAX_RESTARTS):
        while bi < len(breaks) and breaks[bi] <= t + 1e-15:
            bi += 1
        if bi >= len(breaks):
            break
        t1 = breaks[bi]
        events = []
        for g in range(3):
            def ev(tt: float, zz: NDArray, g: int = g, r: int = r) -> float:
                return eq.inside(tt, zz, r)[g]
            setattr(ev, 'terminal', True)     # solve_ivp's event attributes
            setattr(ev, 'direction', -1)
            events.append(ev)
        sel = (t_out > t) & (t_out <= t1)
        extra = {}
        if method in ('Radau', 'BDF', 'LSODA'):
            zero = eq.rhs(t, np.zeros(2 * n), r)
            jac = np.column_stack([eq.rhs(t, e_i, r) - zero for e_i in np.eye(2 * n)])
            extra['jac'] = jac                      # affine right-hand side
        sol = solve_ivp(lambda tt, zz: eq.rhs(tt, zz, r), (t, t1), z, method=method,
                        rtol=rtol, atol=atol, events=events, dense_output=True, **extra)
        if not sol.success:
            raise RuntimeError(sol.message)
        t_stop = float(sol.t[-1])
        keep = sel & (t_out <= t_stop)
        if np.any(keep):
            out[keep] = sol.sol(t_out[keep]).T
        hit = [g for g in range(3) if sol.t_events[g].size]
        z = sol.y[:, -1].copy()
        t = t_stop
        if not hit or t_stop >= t1:
            continue
        g = min(hit, key=lambda i: sol.t_events[i][0])
        t = float(sol.t_events[g][0])
        z = sol.y_events[g][0].copy()
        # step just past the switch: the new regime must start strictly inside
        which = (CAM, RV, SEAT)[g]
        if eq.hard and which == SEAT and not r & SEAT:
            res.impacts.append((a0 + omega * t, -z[n + V]))
            z[V] = 0.0
            v_new = -e * z[n + V]
            if v_new <= 1e-9:
                zh = z.copy()
                zh[n + V] = 0.0
                if eq.forces(t, zh[:n], zh[n:], r)[V] <= 0:
                    z, r = zh, r | SEAT
                else:
                    z = zh
            else:
                z[n + V] = v_new
        else:
            r ^= which
        res.switches.append((a0 + omega * t, which, r))
        if eq.hard and which == SEAT:
            # the velocity reset can leave the rocker-valve contact outside its domain
            # (its dashpot force turns negative): it opens at once
            vals = eq.inside(t, z, r)
            if vals[1] < 0 and r & RV:
                r ^= RV
                res.switches.append((a0 + omega * t, RV, r))
    return res
