"""Exact piecewise-linear solver of the 4+N1+N2 model (docs/dynamics.md).

Between switches of the unilateral elements - cam-tappet contact (CAM), rocker-valve
contact with the lash (RV), valve seat (SEAT: penalty contact, or the hard seat's
"held" state) - the model is linear with constant coefficients,
    z' = A_r z + b_r + e_T g(t) / m_T,   z = (x, x'),
with g = k_c u + b_c u' the cam forcing on the tappet in contact (u = k h, a degree-7
polynomial on each step, ``cam_input``). Every step is propagated exactly with the
exponential of A_r augmented by the polynomial basis and the constant input (one
``expm`` of a (2n + 9)-square matrix per regime and step length, cached; velocities
scaled to balance it). The method is that of ``sdof`` (its building blocks are
reused from ``propagate``: ``expm``, the cubic-Hermite dip test ``dips`` and the
Newton bracket on the switching polynomials): switching functions are checked at
sub-nodes spaced at most pi/4 / |lambda_max| of the regime, and a switch is located on
the Taylor series of the exact local solution (order 22) to ~1e-14 of the sub-step.

Hard seat (``restitution`` e): y_V >= 0; at an impact v_V -> -e v_V (only the valve:
the coil masses keep their velocities); below 1e-9 m/s the valve is held on the seat
(its DOF frozen at 0) while the net force of the rocker, the coils and the preload on
it does not open it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.valve_train.cam_input import CamInput
from cam_design.valve_train.mdof_model import (CAM, RV, SEAT, SUB, MdofModel, R, T, V,
                                               switch_flags)
from cam_design.valve_train.propagate import (BOUNCE_TOL, FACT, GRID9, NB, VG9, SolverError,
                                              eval_min, free_flight_height, newton_bracket,
                                              reopen, shift)

_TAYLOR = 22
_MAX_EVENTS = 20000
_STICK = 1e-9          # m/s: hard-seat rebound below this holds the valve
OPEN_TOL = 1e-6        # m: a lift-off counts as the opening once the valve rises this high


@dataclass
class MdofEvents:
    """Events of one revolution (angles rad on the lobe's alpha axis)."""

    opening: float | None = None
    closing: float | None = None
    seating_velocity: float | None = None
    separations: list[list[float]] = field(default_factory=list)       # cam-tappet
    valve_toss: list[list[float]] = field(default_factory=list)        # rocker-valve
    impacts: list[tuple[float, float]] = field(default_factory=list)
    bounce_count: int = 0
    count: int = 0


class _Run:
    """One revolution over the steps of a CamInput (state machine as ``sdof_run.SdofRun``)."""

    def __init__(self, model: MdofModel, cam: CamInput, bounce_mass: float,
                 preload: float) -> None:
        self.model = model
        self.cam = cam
        self.lt = cam.lengths / model.omega
        self.ev = MdofEvents()
        self.opened = False
        self.seated_once = False
        self.sep_open: list[float] | None = None
        self.toss_open: list[float] | None = None
        self.bounce_mass = bounce_mass
        self.preload = preload
        self.peak = 0.0            # largest valve lift since the last lift-off [m]
        self.lift_off: float | None = None  # angle of the last lift-off not yet seated
        self.start_open = False            # the revolution starts inside an open phase
        self.next_cycle: list[list[float]] | None = None   # [CAM | RV, start, end]
        self.jac: NDArray | None = None   # d z / d z(start) when shooting

    # -- bulk ------------------------------------------------------------------------
    def bulk(self, k0: int, z: NDArray, r: int, want: int) -> tuple[int, NDArray]:
        """Steps k0..k0+want-1 in regime r up to the first one that may hold a switch;
        returns (clean steps, states at the following nodes (clean, 2n))."""
        model, cam = self.model, self.cam
        ks = np.arange(k0, min(k0 + want, cam.lengths.size))
        lt = self.lt[ks]
        la = cam.lengths[ks]
        ucoef = cam.coeffs[ks]
        gmono = model.cam_forcing(r, ucoef, la)
        fco = gmono * FACT
        rho = model.mats(r)[4]
        uniq, inv = np.unique(lt, return_inverse=True)
        props = []
        for L in uniq.tolist():
            m = min(max(2, int(math.ceil(rho * L / SUB))), 4096)
            props.append((m, *model.propagator(r, L, m)))
        nz = 2 * model.n
        w = np.empty((ks.size, nz))
        for gi, (m, phis, gq, g1) in enumerate(props):
            idx = np.nonzero(inv == gi)[0]
            w[idx] = fco[idx] @ gq[-1].T + g1[-1]
        zz = np.empty((ks.size + 1, nz))
        zz[0] = z
        invl = inv.tolist()
        ends = [p_[1][-1] for p_ in props]
        cur = z
        for i in range(ks.size):
            cur = ends[invl[i]] @ cur + w[i]
            zz[i + 1] = cur
        if not np.all(np.isfinite(cur)):
            raise SolverError('non-finite state in bulk propagation')
        clean = ks.size
        for gi, (m, phis, gq, g1) in enumerate(props):
            idx = np.nonzero(inv == gi)[0]
            if idx.size == 0:
                continue
            z0 = zz[idx]
            zs = (np.einsum('mab,qb->qma', phis, z0) + np.einsum('mab,qb->qma', gq, fco[idx])
                  + g1[None])
            zall = np.concatenate([z0[:, None, :], zs], axis=1)
            flags = switch_flags(model, r, ucoef[idx], gmono[idx], la[idx], lt[idx], zall)
            bad = np.nonzero(np.any(flags, axis=1))[0]
            if bad.size and int(idx[bad[0]]) < clean:
                clean = int(idx[bad[0]])
        if self.jac is not None:
            jac = self.jac
            for i in range(clean):
                jac = ends[invl[i]] @ jac
            self.jac = jac
        return clean, zz[1:clean + 1]

    # -- one step with switches ----------------------------------------------------------
    def event_step(self, k: int, z: NDArray, r: int) -> tuple[NDArray, int]:
        """Step k from its start node to its end node, every switch inside handled."""
        model, cam = self.model, self.cam
        s0 = 0.0
        la_step = float(cam.lengths[k])
        lt_step = float(self.lt[k])
        while True:
            w = 1.0 - s0
            if w <= 1e-15:
                return z, r
            uco = shift(cam.coeffs[k], s0, w)
            lt, la = lt_step * w, la_step * w
            rho = model.mats(r)[4]
            m = min(max(2, int(math.ceil(rho * lt / SUB))), 4096)
            gmono = model.cam_forcing(r, uco, la)
            phis, gq, g1 = model.propagator(r, lt, m)
            zs = phis @ z + gq @ (gmono * FACT) + g1
            zall = np.concatenate([z[None, :], zs], axis=0)
            flags = switch_flags(model, r, uco[None, :], gmono[None, :], np.array([la]),
                                 np.array([lt]), zall[None])[0]
            found = None
            for j in np.nonzero(flags)[0].tolist():
                g_loc = shift(gmono, j / m, 1.0 / m)
                u_loc = shift(uco, j / m, 1.0 / m)
                cz = self._taylor(r, zall[j], g_loc, lt / m)
                hit = self._first_switch(r, cz, u_loc, lt / m)
                if hit is not None:
                    found = (j, hit[0], hit[1], cz, u_loc)
                    break
            if found is None:
                self.peak = max(self.peak, float(np.max(zs[:, V])))
                if self.jac is not None:
                    self.jac = phis[-1] @ self.jac
                z = zs[-1]
                if not np.all(np.isfinite(z)):
                    raise SolverError('non-finite state')
                return z, r
            j, t_out, which, cz, u_loc = found
            ze = _horner_vec(cz, t_out)
            self.peak = max(self.peak, float(np.max(zall[:j + 1, V])), float(ze[V]))
            ds = lt / m
            uu = float(np.polynomial.polynomial.polyval(t_out, u_loc))
            ud = float(np.polynomial.polynomial.polyval(
                t_out, np.polynomial.polynomial.polyder(u_loc))) / ds
            s_new = s0 + w * (j + t_out) / m
            alpha = float(cam.nodes[k] + la_step * s_new)
            r_old = r
            z, r = self.switch(r, which, alpha, ze, uu, ud)
            if self.jac is not None:
                udd = float(np.polynomial.polynomial.polyval(
                    t_out, np.polynomial.polynomial.polyder(u_loc, 2))) / (ds * ds)
                loc = _horner_mat(self._taylor_phi(r_old, ds), t_out)
                if j:
                    loc = loc @ phis[j - 1]
                sal = self._saltation(r_old, r, which, ze, z, uu, ud, udd)
                self.jac = sal @ (loc @ self.jac)
            s0 = s_new
            self.ev.count += 1
            if self.ev.count > _MAX_EVENTS:
                raise SolverError(f'more than {_MAX_EVENTS} regime switches (chatter)')

    def _taylor(self, r: int, z: NDArray, g_loc: NDArray, ds: float) -> NDArray:
        """(ORDER+1, 2n) coefficients c_i of z(t) = sum c_i t^i, t = s/ds in [0, 1]."""
        model = self.model
        n = model.n
        am = model.mats(r)[3]
        b = model.const_rate(r)
        cz = np.zeros((_TAYLOR + 1, 2 * n))
        cz[0] = z
        c = z
        for i in range(_TAYLOR):
            rhs = am @ c
            if i == 0:
                rhs = rhs + b
            if i < g_loc.size and r & CAM:
                rhs[n + T] += g_loc[i] * model.minv[T]
            c = rhs * (ds / (i + 1))
            cz[i + 1] = c
        return cz

    def _taylor_phi(self, r: int, ds: float) -> NDArray:
        """(ORDER+1, 2n, 2n) Taylor coefficients of Phi(t ds) = exp(A t ds)."""
        am = self.model.mats(r)[3] * ds
        out = np.empty((_TAYLOR + 1,) + am.shape)
        out[0] = np.eye(am.shape[0])
        for i in range(_TAYLOR):
            out[i + 1] = am @ out[i] / (i + 1)
        return out

    def _field(self, r: int, z: NDArray, u: float, ud: float) -> NDArray:
        """z' of regime r at state z with the cam at (u, ud)."""
        model = self.model
        am = model.mats(r)[3]
        out = am @ z + model.const_rate(r)
        if r & CAM:
            out[model.n + T] += (model.asm.k_c * u + model.asm.b_c * ud) * model.minv[T]
        return out

    def _grad(self, r: int, which: int, z: NDArray, u: float, ud: float,
              udd: float) -> tuple[NDArray, float]:
        """(grad_z g, dg/dt) of the active switching component of ``which``."""
        model = self.model
        a = model.asm
        n = model.n
        e = np.eye(2 * n)
        if which == CAM:
            d = u - z[T]
            gc = a.k_c * d + a.b_c * (ud - z[n + T])
            if d <= gc:
                return -e[T], ud
            return -a.k_c * e[T] - a.b_c * e[n + T], a.k_c * ud + a.b_c * udd
        if which == RV:
            d2 = z[R] - z[V] - model.lash
            g2 = a.k_rv * d2 + a.b_rv * (z[n + R] - z[n + V])
            if d2 <= g2:
                return e[R] - e[V], 0.0
            return a.k_rv * (e[R] - e[V]) + a.b_rv * (e[n + R] - e[n + V]), 0.0
        if model.hard:
            if r & SEAT:
                kk, cc, _, _, _ = model.mats(r)
                return np.concatenate([kk[V], cc[V]]), 0.0
            return e[V], 0.0
        gs = -model.ks * z[V] - model.bs * z[n + V]
        if -z[V] <= gs:
            return -e[V], 0.0
        return -model.ks * e[V] - model.bs * e[n + V], 0.0

    def _saltation(self, r_old: int, r_new: int, which: int, zm: NDArray, zp: NDArray,
                   u: float, ud: float, udd: float) -> NDArray:
        """Jacobian of the state across a switch (reset map and switching time)."""
        model = self.model
        n = model.n
        reset = np.eye(2 * n)
        if model.hard and which == SEAT and not r_old & SEAT:      # impact
            reset[n + V, n + V] = -model.e if zp[n + V] != 0.0 else 0.0
        grad, gt = self._grad(r_old, which, zm, u, ud, udd)
        fm = self._field(r_old, zm, u, ud)
        fp = self._field(r_new, zp, u, ud)
        den = float(grad @ fm) + gt
        if abs(den) < 1e-300:
            return reset
        return reset + np.outer(fp - reset @ fm, grad) / den

    def _first_switch(self, r: int, cz: NDArray, u_loc: NDArray,
                      ds: float) -> tuple[float, int] | None:
        """(t_out, which) of the first switch in t in (0, 1]; which: CAM | RV | SEAT."""
        model = self.model
        n = model.n
        nt = cz.shape[0]
        uu = np.zeros(nt)
        uu[:u_loc.size] = u_loc
        d1 = _dcoef(cz) / ds           # time derivative coefficients
        u1 = _dcoef(uu[:, None])[:, 0] / ds
        u2 = _dcoef(u1[:, None])[:, 0] / ds
        one = np.zeros(nt)
        one[0] = 1.0
        groups = model.groups(r, cz[:, :n], cz[:, n:], d1[:, n:], uu, u1, u2, one=one)
        comps = []
        for sign, vals, _ in groups:
            comps.append((sign, [np.asarray(v)[::-1].tolist() for v in vals]))
        vg = VG9[:nt]
        bad_any = np.zeros(GRID9.size, dtype=bool)
        for sign, polys in comps:
            low = np.full(GRID9.size, np.inf)
            for c in polys:
                low = np.minimum(low, np.asarray(c[::-1]) @ vg)
            bad_any |= sign * low < 0
        bad_any[0] = False
        if not np.any(bad_any):
            return None
        i = int(np.argmax(bad_any))
        a, b = float(GRID9[i - 1]), float(GRID9[i])
        best = None
        for which, comp in zip((CAM, RV, SEAT), comps):
            fa, fb = eval_min(comp, a)[0], eval_min(comp, b)[0]
            if fb < 0 <= fa:
                _, tb = newton_bracket(comp, a, b)
            elif fb < 0 and fa < 0:
                tb = a
            else:
                continue
            if best is None or tb < best[0]:
                best = (tb, which)
        return best

    # -- switches and events ---------------------------------------------------------
    def switch(self, r: int, which: int, alpha: float, z: NDArray, u: float,
               ud: float) -> tuple[NDArray, int]:
        """Apply a switch of ``which`` at ``alpha``; record events."""
        model = self.model
        n = model.n
        ev = self.ev
        if which == CAM:
            if r & CAM:
                if self.opened and not self.seated_once and u > 0:
                    self.sep_open = [alpha, alpha]
                elif self.next_cycle is not None and u > 0:
                    self.next_cycle.append([CAM, alpha, math.nan])
                return z, r & ~CAM
            if self.sep_open is not None:
                self.sep_open[1] = alpha
                ev.separations.append(self.sep_open)
                self.sep_open = None
            else:
                self._close_next(CAM, alpha)
            return z, r | CAM
        if which == RV:
            if r & RV:
                if self.opened and not self.seated_once and z[V] > 0:
                    self.toss_open = [alpha, alpha]
                elif self.next_cycle is not None and z[V] > 0:
                    self.next_cycle.append([RV, alpha, math.nan])
                return z, r & ~RV
            if self.toss_open is not None:
                self.toss_open[1] = alpha
                ev.valve_toss.append(self.toss_open)
                self.toss_open = None
            else:
                self._close_next(RV, alpha)
            return z, r | RV
        v = float(z[n + V])
        if model.hard:
            if r & SEAT:                       # held valve released
                self._reopen(alpha, 0.0, force=True)
                return z, r & ~SEAT
            self._seat(alpha, -v)
            ev.impacts.append((alpha, -v))
            z = z.copy()
            z[V] = 0.0
            v_new = -model.e * v
            if v_new <= _STICK:
                zh = z.copy()
                zh[n + V] = 0.0
                acc = model.accel(r | SEAT, zh[:n], zh[n:], 0.0)
                fv, _ = model.valve_force(r | SEAT, zh[:n], zh[n:], acc)
                if fv <= 0:
                    return zh, r | SEAT
                z[n + V] = 0.0
                return z, r
            z[n + V] = v_new
            self._reopen(alpha, v_new)
            return z, r
        if r & SEAT:
            self._reopen(alpha, v)
            return z, r & ~SEAT
        self._seat(alpha, -v)
        ev.impacts.append((alpha, -v))
        return z, r | SEAT

    def _reopen(self, alpha: float, v_up: float, force: bool = False) -> None:
        """Lift-off (``propagate.reopen``): the bounce height bound with the valve-side
        bounce mass and preload; ``force``: a held valve released from a hard seat
        counts as a bounce."""
        reopen(self, alpha, free_flight_height(self.bounce_mass, v_up, self.preload),
               forced=force and self.model.hard)

    def _close_next(self, which: int, alpha: float) -> None:
        for item in reversed(self.next_cycle or []):
            if item[0] == which and math.isnan(item[2]):
                item[2] = alpha
                return

    def commit_next_cycle(self, alpha: float) -> None:
        """As ``sdof_run.SdofRun.commit_next_cycle``: a periodic revolution that starts inside
        an open phase holds the next cycle's open phase after its closing; its
        separations and tosses are this orbit's when the valve rose OPEN_TOL in it."""
        cyc, self.next_cycle = self.next_cycle, None
        if not cyc or self.peak < OPEN_TOL:
            return
        for which, a0, a1 in cyc:
            lst = self.ev.separations if which == CAM else self.ev.valve_toss
            lst.append([a0, alpha if math.isnan(a1) else a1])

    def _seat(self, alpha: float, vdown: float) -> None:
        self.lift_off = None
        if self.next_cycle is not None:
            self.commit_next_cycle(alpha)
        if self.opened and not self.seated_once and self.peak < OPEN_TOL:
            self.opened = False     # seat chatter before the opening, not a closing:
            self.ev.opening = None  # nor was its lift-off the opening (as sdof)
            return
        if self.opened and not self.seated_once:
            self.seated_once = True
            self.ev.closing = alpha
            self.ev.seating_velocity = vdown
            for attr, lst in (('sep_open', self.ev.separations),
                              ('toss_open', self.ev.valve_toss)):
                cur = getattr(self, attr)
                if cur is not None:
                    cur[1] = alpha
                    lst.append(cur)
                    setattr(self, attr, None)

    # -- driver ------------------------------------------------------------------------
    def revolution(self, z: NDArray, r: int) -> tuple[NDArray, NDArray, NDArray, int]:
        """One revolution from node 0: states (N+1, 2n), regimes (N+1,), end state."""
        nst = self.cam.lengths.size
        zs = np.empty((nst + 1, z.size))
        rs = np.empty(nst + 1, dtype=np.int64)
        zs[0], rs[0] = z, r
        k = 0
        chunk = 16
        while k < nst:
            want = min(chunk, nst - k)
            clean, states = self.bulk(k, z, r, want)
            if clean:
                zs[k + 1:k + 1 + clean] = states
                self.peak = max(self.peak, float(np.max(states[:, V])))
                rs[k + 1:k + 1 + clean] = r
                z = states[-1]
                k += clean
            if clean == want:
                chunk = min(chunk * 2, 256)
                continue
            z, r = self.event_step(k, z, r)
            k += 1
            zs[k], rs[k] = z, r
            chunk = 16
        return zs, rs, z, r


def _dcoef(c: NDArray) -> NDArray:
    """Coefficients of d/dt of sum c_i t^i along axis 0 (same length, last row 0)."""
    out = np.zeros_like(c)
    out[:-1] = c[1:] * np.arange(1, c.shape[0])[:, None]
    return out


def _horner_mat(c: NDArray, t: float) -> NDArray:
    """sum_i c_i t^i for matrix coefficients c (first axis)."""
    acc = np.zeros(c.shape[1:])
    for mat in c[::-1]:
        acc = acc * t + mat
    return acc


def _horner_vec(c: NDArray, t: float) -> NDArray:
    """sum_i c_i t^i for vector coefficients c (rows)."""
    acc = np.zeros(c.shape[1])
    for row in c[::-1]:
        acc = acc * t + row
    return acc


def static_state(model: MdofModel, u0: float) -> tuple[NDArray, int]:
    """Static equilibrium on the base circle (cam displacement u0) and its regime."""
    n = model.n
    order = (CAM | SEAT, CAM | RV | SEAT, CAM, CAM | RV, SEAT, RV | SEAT, 0, RV)
    for r in order:
        kk, _, f, _, _ = model.mats(r)
        kk = kk.copy()
        f = f.copy()
        if r & CAM:
            f[T] += model.asm.k_c * u0
        if model.held(r):
            kk[V, :] = 0.0
            kk[V, V] = 1.0
            f[V] = 0.0
        elif model.hard and r & SEAT:
            continue
        try:
            x = np.linalg.solve(kk, f)
        except np.linalg.LinAlgError:
            continue
        zero = np.zeros(n)
        ok = True
        for sign, vals, _ in model.groups(r, x, zero, zero, u0, 0.0, 0.0):
            if sign * min(float(v) for v in vals) < 0:
                ok = False
        if ok:
            return np.concatenate([x, zero]), r
    raise SolverError('no consistent static state on the base circle')


def _consistent(model: MdofModel, r: int, z: NDArray, u0: float) -> bool:
    """z is a state of regime r at the start node (cam at rest on the base circle)."""
    n = model.n
    x, xd = z[:n], z[n:]
    acc = model.accel(r, x, xd, model.asm.k_c * u0 if r & CAM else 0.0)
    for sign, vals, _ in model.groups(r, x, xd, acc, u0, 0.0, 0.0):
        if sign * min(float(v) for v in vals) < -1e-12 * max(1.0, max(
                abs(float(v)) for v in vals)):
            return False
    if model.held(r) and (z[V] != 0.0 or z[n + V] != 0.0):
        return False
    return True


@dataclass
class ExactRevolutions:
    """Nodes (alpha rad), states (N+1, 2n), regimes of the last revolution; events."""

    alpha: NDArray[np.float64]
    z: NDArray[np.float64]
    regime: NDArray[np.int64]
    u: NDArray[np.float64]
    ud: NDArray[np.float64]
    events: MdofEvents
    revolutions: int
    periodic_residual: float
    settled: bool


def run_exact(asm: Any, cam: CamInput, omega: float, *, max_revolutions: int = 1,
              periodic_tol: float = 1e-9, shooting: bool = True) -> ExactRevolutions:
    """Revolutions from the static state until the state at the start node repeats
    within ``periodic_tol`` [m] (positions; velocities divided by the lowest natural
    angular frequency) or ``max_revolutions`` revolutions have been simulated.

    ``shooting``: after each revolution a Newton step on the one-revolution map
    z -> P(z) (piecewise affine; its Jacobian is the product of the step propagators
    and the saltation matrices of the switches) when the revolution ended in the regime
    it started in and the Newton point is a consistent state; otherwise plain
    repetition (z <- P(z))."""
    model = MdofModel(asm, omega)
    u0 = float(cam.coeffs[0, 0])
    z0, r0 = static_state(model, u0)
    n = model.n
    w1 = 2 * math.pi * float(max(asm.natural_frequencies()[0], 1e-3))
    mp = asm.mp
    residual = math.inf
    revs = 0
    run: _Run | None = None
    zs = rs = None
    eye = np.eye(2 * n)

    def metric(d: NDArray) -> float:
        return float(max(np.max(np.abs(d[:n])), np.max(np.abs(d[n:])) / w1))

    for revs in range(1, max_revolutions + 1):
        prev = run
        run = _Run(model, cam, mp.masses[V], mp.base.spring_preload)
        if revs > 1 and not r0 & SEAT and z0[V] > BOUNCE_TOL:
            # a periodic start off the seat: the valve is in the air, already open (a
            # lobe over the whole revolution, a valve still bouncing or flying from the
            # last lobe); landing without rising OPEN_TOL ends a bounce (``_seat``).
            # The opening angle is known when the last revolution ended after a lift-off
            run.opened = True
            run.start_open = True
            run.peak = float(z0[V])
            if prev is not None and prev.lift_off is not None:
                run.ev.opening = prev.lift_off - 2 * math.pi
        if shooting and revs < max_revolutions:
            run.jac = eye.copy()
        zs, rs, z, r = run.revolution(z0, r0)
        if run.next_cycle is not None:   # the next open phase runs past the window end
            run.commit_next_cycle(float(cam.nodes[-1]))
        residual = metric(z - z0)
        if residual <= periodic_tol and r == r0:
            break
        if run.jac is not None and r == r0:
            try:
                z_new = z0 - np.linalg.solve(run.jac - eye, z - z0)
            except np.linalg.LinAlgError:
                z_new = None
            if z_new is not None and model.held(r0):
                z_new[V] = z_new[n + V] = 0.0
            if z_new is not None and np.all(np.isfinite(z_new)) and _consistent(
                    model, r0, z_new, u0):
                z0 = z_new
                continue
        z0, r0 = z, r
    if run is None or zs is None or rs is None:
        raise ValueError(f'max_revolutions = {max_revolutions}: at least 1 is needed')
    u = np.concatenate([cam.coeffs[:, 0], [np.sum(cam.coeffs[-1])]])
    du = np.concatenate([cam.coeffs[:, 1] / cam.lengths,
                         [np.sum(cam.coeffs[-1, 1:] * np.arange(1, NB)) / cam.lengths[-1]]])
    return ExactRevolutions(alpha=cam.nodes.copy(), z=zs, regime=rs, u=u, ud=du * omega,
                            events=run.ev, revolutions=revs, periodic_residual=residual,
                            settled=bool(residual <= periodic_tol))
