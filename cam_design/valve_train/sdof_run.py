"""One single-DOF simulation over the steps of a cam input (``sdof``): the state
machine that propagates each step exactly, locates the regime switches and records
the events (opening, closing, separations, seat impacts and bounces)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.valve_train.cam_input import CamInput
from cam_design.valve_train.propagate import (ARANGE, FACT, SolverError,
                                              bracket, free_flight_height, horner2,
                                              newton_bracket, reopen, screen_grid, shift,
                                              vander)
from cam_design.valve_train.sdof_model import (CONTACT, SEAT, SUB, SdofModel,
                                               inside, screen_weights, switch_flags, taylor)

MAX_EVENTS = 20000
OPEN_TOL = 1e-6              # m: a lift-off is the opening once the valve rises this high


@dataclass
class Events:
    """Events of one revolution (angles in rad on the lobe's alpha axis)."""

    opening: float | None = None
    closing: float | None = None             # first seating
    seating_velocity: float | None = None    # m/s, > 0 downwards
    separations: list[list[float]] = field(default_factory=list)   # [start, end] rad
    recontact_velocities: list[float] = field(default_factory=list)  # m/s, u' - y'
    impacts: list[tuple[float, float]] = field(default_factory=list)  # (alpha, m/s) at seat
    bounce_count: int = 0
    bounce_height: float = 0.0               # m, largest lift after the first seating
    count: int = 0                           # number of regime switches
    switch_angles: list[float] = field(default_factory=list)  # rad, every regime switch


class SdofRun:
    """One simulation: state machine over the steps of a CamInput."""

    def __init__(self, model: SdofModel, cam: CamInput) -> None:
        self.model = model
        self.cam = cam
        self.lt = cam.lengths / model.omega
        self._groups()
        self.ev = Events()
        self.seated_once = False
        self.opened = False
        self.peak = 0.0            # largest node lift since the last lift-off [m]
        self.lift_off: float | None = None   # last lift-off not followed by a seating
        self.start_open = False    # the revolution starts inside an open phase
        self.next_cycle: list[list[float]] | None = None   # [start, end, u' - y']
        self.sep_open: list[float] | None = None
        self.stop_after_bounce = False
        self.hint: tuple[int, int, NDArray, NDArray] | None = None

    # -- regimes -----------------------------------------------------------------
    def initial(self) -> tuple[tuple[float, float], int]:
        """Static state on the base circle at the first node and its regime."""
        p = self.model.p
        u0 = float(self.cam.coeffs[0, 0])
        g0 = 0.0 if self.cam.gas is None else float(self.cam.gas[0, 0])
        if p.hard_seat:
            return (0.0, 0.0), SEAT
        for r in (SEAT, SEAT | CONTACT, 0, CONTACT):
            k_, _ = self.model.coefs(r)
            f = -p.spring_preload - g0 + (p.stiffness * u0 if r & CONTACT else 0.0)
            y = f / k_ if k_ > 0 else 0.0
            ic, is_ = inside(self.model, r, y, 0.0, u0, 0.0)
            if ic >= 0 and is_ >= 0 and (r & CONTACT or u0 - y <= 0) and (
                    r & SEAT or y >= 0):
                return (y, 0.0), r
        raise SolverError('no consistent static state on the base circle')

    # -- bulk propagation ----------------------------------------------------------
    def _groups(self) -> None:
        """Steps of equal length share one propagator: group index per step."""
        uniq, inv = np.unique(self.lt, return_inverse=True)
        self.g_len = uniq.tolist()
        self.g_inv = inv
        self.g_invl = inv.tolist()
        self.g_run = np.concatenate([[0], np.cumsum(np.diff(inv) != 0)])  # changes so far
        self.g_props: dict[int, list[tuple[int, NDArray, NDArray, list[float]]]] = {}

    def _props(self, r: int) -> list[tuple[int, NDArray, NDArray, list[float]]]:
        """Per step-length group: (sub-nodes m, Phi, Gamma, end Phi as 4 floats)."""
        hit = self.g_props.get(r)
        if hit is None:
            rho = self.model.rho(r)
            hit = []
            for L in self.g_len:
                m = min(max(2, int(math.ceil(rho * L / SUB))), 4096)
                phis, gams = self.model.propagator(r, L, m)
                hit.append((m, phis, gams, phis[-1].ravel().tolist()))
            self.g_props[r] = hit
        return hit

    def bulk(self, k0: int, z: tuple[float, float], r: int,
             n: int) -> tuple[int, NDArray, NDArray]:
        """Propagate steps k0..k0+n-1 in regime r; stop before the first step with a
        switch. Returns (number of clean steps, y and v at nodes k0+1..k0+clean).

        The linear recurrence runs in windows of growing size (16, 32, ...), each
        checked for switches at its sub-nodes before the next is propagated, so a
        switch early in a long stretch costs little waste."""
        model, cam = self.model, self.cam
        k1 = min(k0 + n, cam.lengths.size)
        q = k1 - k0
        la = cam.lengths[k0:k1]
        if model.p.hard_seat and r & SEAT:
            vand, dvand = vander(4)
            uu = cam.coeffs[k0:k1] @ vand
            ud = (cam.coeffs[k0:k1] @ dvand) * (model.omega / la)[:, None]
            _, ins = inside(model, r, 0.0, 0.0, uu, ud)
            bad = np.nonzero(np.any(ins < 0, axis=1))[0]
            clean = int(bad[0]) if bad.size else q
            return clean, np.zeros(clean), np.zeros(clean)
        fco = model.forcing(r, cam.coeffs[k0:k1], la,
                            None if cam.gas is None else cam.gas[k0:k1])
        props = self._props(r)
        inv = self.g_inv[k0:k1]
        invl = self.g_invl
        if self.g_run[k0] == self.g_run[k1 - 1]:
            wl = (fco @ props[invl[k0]][2][-1].T).tolist()
        else:
            w = np.empty((q, 2))
            for g in np.unique(inv).tolist():
                idx = np.nonzero(inv == g)[0]
                w[idx] = fco[idx] @ props[g][2][-1].T
            wl = w.tolist()
        y, v = z
        yl = [y]
        vl = [v]
        pos, win = 0, 32
        clean = q
        while pos < q:
            hi = min(q, pos + win)
            one_group = self.g_run[k0 + pos] == self.g_run[k0 + hi - 1]
            a, b, c, d = props[invl[k0 + pos]][3]
            for i in range(pos, hi):
                if not one_group:
                    a, b, c, d = props[invl[k0 + i]][3]
                wy, wv = wl[i]
                y, v = a * y + b * v + wy, c * y + d * v + wv
                yl.append(y)
                vl.append(v)
            if not (math.isfinite(y) and math.isfinite(v)):
                raise SolverError('non-finite state in bulk propagation')
            ys = np.asarray(yl[pos:hi])
            vs = np.asarray(vl[pos:hi])
            parts: list[tuple[Any, NDArray | None]]
            if one_group:
                parts = [(invl[k0 + pos], None)]
            else:
                gw = inv[pos:hi]
                parts = [(g, np.nonzero(gw == g)[0]) for g in np.unique(gw).tolist()]
            for g, sub in parts:
                m, phis, gams, _ = props[g]
                if sub is None:
                    idx = np.arange(pos, hi)
                    z0 = np.stack([ys, vs], axis=1)
                else:
                    idx = pos + sub
                    z0 = np.stack([ys[sub], vs[sub]], axis=1)       # (q, 2)
                flags = switch_flags(model, r, self.g_len[g], m, z0, cam.coeffs[k0 + idx],
                                     None if cam.gas is None else cam.gas[k0 + idx])
                bad = np.nonzero(np.any(flags, axis=1))[0]
                if bad.size and int(idx[bad[0]]) < clean:
                    clean = int(idx[bad[0]])
                    # hand the sub-node states and flags of that step to event_step
                    zs = phis @ z0[bad[0]] + gams @ fco[clean]
                    self.hint = (k0 + clean, r, zs, flags[bad[0]].copy())
            if clean < q:
                break
            pos = hi
            win *= 4
        return clean, np.asarray(yl[1:clean + 1]), np.asarray(vl[1:clean + 1])

    # -- one step with events --------------------------------------------------------
    def event_step(self, k: int, z: tuple[float, float],
                   r: int) -> tuple[tuple[float, float], int]:
        """Integrate step k from node k to node k+1, handling every switch inside.

        The step is covered by segments [s0, s0 + w] (fractions of the step), each cut
        into ``pieces`` sub-intervals on which the local Taylor series locates a switch:
        from a node of the step's sub-grid in regime r (m_step sub-intervals, the step
        start or a node reached after a switch) the step's cached propagator gives the
        sub-node states and the switch flags of the rest of the step; after a switch, a
        short rest (m <= 4) is chained with Taylor pieces, a longer one is taken with one
        Taylor piece up to the next sub-grid node, then from there as above."""
        model, cam = self.model, self.cam
        p = model.p
        s0 = 0.0
        node: int | None = 0          # s0 = node / m_step of regime r's sub-grid
        la_step = float(cam.lengths[k])
        lt_step = float(self.lt[k])
        while True:
            if 1.0 - s0 <= 1e-15:
                return z, r
            if p.hard_seat and r & SEAT:
                w = 1.0 - s0
                exit_at = self._held_exit(shift(cam.coeffs[k], s0, w), la_step * w)
                if exit_at is None:
                    return (0.0, 0.0), r
                s0 += w * exit_at
                r = self._after_held(s0, k)
                z, node = (0.0, 0.0), None
                continue
            m_step = self._props(r)[self.g_invl[k]][0]
            need = int(math.ceil(model.rho(r) * lt_step * (1.0 - s0) / SUB))
            m = min(max(2, need), 4096)
            zs, used, dense, upto = None, 1, 1, None
            if node is None and m <= 4:   # short rest: chain the Taylor series over
                w = 1.0 - s0              # max(1, need) pieces, screened as finely as m
                pieces = max(1, need)
                dense = m // pieces
            elif node is None:            # one Taylor piece up to the next sub-grid node
                upto = min(m_step, int(s0 * m_step) + 1)
                w, pieces = upto / m_step - s0, 1
            else:                         # from a sub-grid node: the step's propagator
                w, pieces, used = 1.0, m_step, m_step - node
            uco = shift(cam.coeffs[k], s0, w)
            gco = None if cam.gas is None else shift(cam.gas[k], s0, w)
            fco = model.forcing(r, uco, la_step * w, gco)
            if node is None:
                todo: Any = range(pieces)
            elif node == 0 and self.hint is not None and self.hint[:2] == (k, r) and \
                    self.hint[2].shape[0] == m_step:
                zs, todo = self.hint[2], np.nonzero(self.hint[3])[0].tolist()
            else:
                phis, gams = model.propagator(r, lt_step, m_step)
                zs = phis[:used] @ np.asarray(z) + gams[:used] @ fco         # (used, 2)
                flags = switch_flags(model, r, lt_step, m_step, np.asarray(z)[None, :],
                                     uco[None, :], None if gco is None else gco[None, :])[0]
                todo = np.nonzero(flags[:used])[0].tolist()
            ds = lt_step * w / pieces
            found = None
            z_start = z
            for j in todo:
                if zs is not None:
                    z = z_start if j == 0 else (float(zs[j - 1, 0]), float(zs[j - 1, 1]))
                f_loc = shift(fco / FACT, j / pieces, 1.0 / pieces)
                u_loc = shift(uco, j / pieces, 1.0 / pieces)
                cy = taylor(model, r, z, f_loc, ds)
                hit = self._first_switch(r, cy, u_loc, ds, dense)
                if hit is not None:
                    found = (j, hit[1], hit[2], cy, u_loc)
                    break
                z = (float(np.sum(cy)), float(cy[1:] @ ARANGE[1:cy.size]) / ds)
            if found is None:
                if zs is not None:
                    z = (float(zs[used - 1, 0]), float(zs[used - 1, 1]))
                if not (math.isfinite(z[0]) and math.isfinite(z[1])):
                    raise SolverError('non-finite state')
                if upto is None or upto == m_step:
                    return z, r
                s0, node = upto / m_step, upto
                continue
            j, t_out, which, cy, u_loc = found
            ye, ve = horner2(cy, t_out)
            uu, ud = horner2(u_loc, t_out)
            ve /= ds
            ud /= ds
            s0 = s0 + w * (j + t_out) / pieces
            node = None
            alpha = float(cam.nodes[k] + la_step * s0)
            z, r = self.switch(r, which, alpha, (ye, ve), uu, ud)
            self.ev.switch_angles.append(alpha)
            self.ev.count += 1
            if self.ev.count > MAX_EVENTS:
                raise SolverError(f'more than {MAX_EVENTS} regime switches (chatter)')

    def _held_exit(self, uco: NDArray, la: float) -> float | None:
        """First sigma in (0, 1] where a held (hard-seat) valve starts to open."""
        model = self.model
        pol = np.polynomial.polynomial
        dco = pol.polyder(uco)

        def fun(s: float) -> float:
            u = pol.polyval(s, uco)
            ud = pol.polyval(s, dco) * model.omega / la
            return float(inside(model, SEAT, 0.0, 0.0, u, ud)[1])

        grid = np.linspace(0.0, 1.0, 17)
        vals = [fun(s) for s in grid]
        for i in range(1, grid.size):
            if vals[i] < 0:
                if vals[i - 1] < 0:
                    return float(grid[i - 1])
                _, b = bracket(fun, grid[i - 1], grid[i], vals[i - 1], vals[i])
                return b
        return None

    def _after_held(self, s: float, k: int) -> int:
        """Regime right after a held valve lifts off (records the opening)."""
        alpha = float(self.cam.nodes[k] + self.cam.lengths[k] * s)
        self.ev.switch_angles.append(alpha)
        self._reopen(alpha)
        return CONTACT

    def _reopen(self, alpha: float, v_up: float = math.inf) -> None:
        """Lift-off at ``alpha`` with velocity ``v_up`` [m/s] (``propagate.reopen``; the
        bounce height bound with the model's mass and spring preload)."""
        p = self.model.p
        reopen(self, alpha, free_flight_height(p.mass, v_up, p.spring_preload))

    def _first_switch(self, r: int, cy: NDArray, u_loc: NDArray, ds: float,
                      dense: int = 1) -> tuple[float, float, int] | None:
        """(t_in, t_out, which) of the first switch on [0, 1]; which: CONTACT|SEAT.

        cy: Taylor coefficients of y [m] in t = s / ds (``taylor``); u_loc: monomials
        of u [m] in t; ds: length of the piece [s]. The switching functions are
        screened on 32 dense + 1 grid points first (one product for values and
        t-derivatives of u - y and y); the component polynomials are built only when
        one dips there."""
        p = self.model.p
        n = max(cy.size, u_loc.size)
        two = np.zeros((2, n))                 # monomials of u - y and of y
        two[0, :u_loc.size] = u_loc
        two[0, :cy.size] -= cy
        two[1, :cy.size] = cy
        grid, vgd = screen_grid(dense)
        weights = screen_weights(p, ds)       # the switching components, defined once
        # rows: u - y, d(u - y)/dt, y, dy/dt (t-derivatives) on the grid -> components
        scr = weights @ (two @ vgd[:n]).reshape(4, grid.size)
        low = np.minimum(scr[0], scr[1])
        bad = low < 0 if r & CONTACT else low > 0   # leaves (enters) contact
        if p.hard_seat:
            bad |= scr[2] < 0
        else:
            low = np.minimum(scr[2], scr[3])
            bad |= low < 0 if r & SEAT else low > 0
        bad[0] = False
        if not bad.any():
            return None
        sc = 1.0 if r & CONTACT else -1.0
        dt = np.zeros((2, n))                  # monomials of their t-derivatives
        dt[:, :-1] = two[:, 1:] * ARANGE[1:n]
        # the component polynomials: the same weights on the monomials
        rows = weights @ np.stack([two[0], dt[0], two[1], dt[1]])
        rl = rows[:, ::-1].tolist()
        comps = [(sc, rl[:2])]
        if p.hard_seat:
            comps.append((1.0, rl[2:]))
        else:
            comps.append((1.0 if r & SEAT else -1.0, rl[2:]))

        def scalar(t: float, pos: int) -> float:
            sign, polys = comps[pos]
            best = math.inf
            for c in polys:
                acc = 0.0
                for x in c:
                    acc = acc * t + x
                if acc < best:
                    best = acc
            return sign * best

        i = int(np.argmax(bad))
        a, b = float(grid[i - 1]), float(grid[i])
        best = None
        for which, pos in ((CONTACT, 0), (SEAT, 1)):
            fa, fb = scalar(a, pos), scalar(b, pos)
            if fb < 0 <= fa:
                ta, tb = newton_bracket(comps[pos], a, b)
            elif fb < 0 and fa < 0:
                ta, tb = a, a
            else:
                continue
            if best is None or tb < best[1]:
                best = (ta, tb, which)
        return best

    def switch(self, r: int, which: int, alpha: float, z: tuple[float, float],
               u: float, ud: float) -> tuple[tuple[float, float], int]:
        """Apply a switch of ``which`` at ``alpha``; record events; new (state, regime)."""
        p = self.model.p
        y, v = z
        ev = self.ev
        if which == CONTACT:
            if r & CONTACT:       # contact lost
                if self.opened and not self.seated_once and u > 0:
                    self.sep_open = [alpha, alpha]
                elif self.next_cycle is not None and u > 0:
                    self.next_cycle.append([alpha, alpha, math.nan])
                return z, r & ~CONTACT
            if self.sep_open is not None:    # contact regained after a separation
                self.sep_open[1] = alpha
                ev.separations.append(self.sep_open)
                ev.recontact_velocities.append(ud - v)
                self.sep_open = None
            elif self.next_cycle and math.isnan(self.next_cycle[-1][2]):
                self.next_cycle[-1][1:] = [alpha, ud - v]
            return z, r | CONTACT
        # seat
        if p.hard_seat:
            # impact (r has no SEAT here: held exits are handled separately)
            self._seat(alpha, -v)
            ev.impacts.append((alpha, -v))
            v_new = -float(p.restitution or 0.0) * v   # hard seat: restitution is set
            if v_new <= 1e-9:
                held_inside = inside(self.model, SEAT, 0.0, 0.0, u, ud)[1]
                if held_inside >= 0:
                    return (0.0, 0.0), SEAT
                return (0.0, 0.0), r
            self._reopen(alpha, v_new)
            return (0.0, v_new), r
        if r & SEAT:            # leaves the seat
            self._reopen(alpha, v)
            return z, r & ~SEAT
        self._seat(alpha, -v)
        ev.impacts.append((alpha, -v))
        return z, r | SEAT

    def commit_next_cycle(self, alpha: float) -> None:
        """A periodic revolution that starts inside an open phase (the valve lands
        after the window start) holds the next cycle's open phase after its closing:
        its separations are this orbit's too (they were recorded in ``next_cycle``
        since the last lift-off) when the valve rose OPEN_TOL in it."""
        cyc, self.next_cycle = self.next_cycle, None
        if not cyc or self.peak < OPEN_TOL:
            return
        for a0, a1, vrel in cyc:
            self.ev.separations.append([a0, alpha if math.isnan(vrel) else a1])
            if not math.isnan(vrel):
                self.ev.recontact_velocities.append(vrel)

    def _seat(self, alpha: float, vdown: float) -> None:
        self.lift_off = None
        if self.next_cycle is not None:
            self.commit_next_cycle(alpha)
        if self.opened and not self.seated_once and self.peak < OPEN_TOL:
            # the valve never rose OPEN_TOL since it left the seat: seat chatter (or the
            # end of a bounce that was still in the air at the window start), not an
            # opening and closing
            self.opened = False
            self.ev.opening = None
            self.sep_open = None
            return
        if self.opened and not self.seated_once:
            self.seated_once = True
            self.ev.closing = alpha
            self.ev.seating_velocity = vdown
            if self.sep_open is not None:
                self.sep_open[1] = alpha
                self.ev.separations.append(self.sep_open)
                self.sep_open = None

    # -- driver ------------------------------------------------------------------
    def revolution(self, z: tuple[float, float],
                   r: int) -> tuple[NDArray, NDArray, NDArray, tuple[float, float], int]:
        """One revolution from node 0; returns node arrays y, v, regime and end state."""
        n = self.cam.lengths.size
        ys = np.empty(n + 1)
        vs = np.empty(n + 1)
        rs = np.empty(n + 1, dtype=np.int64)
        ys[0], vs[0], rs[0] = z[0], z[1], r
        k = 0
        chunk = 64      # steps asked of bulk: small after a switch (switches cluster)
        while k < n:
            if self.stop_after_bounce and self.seated_once and len(self.ev.impacts) >= 2:
                ys[k + 1:], vs[k + 1:], rs[k + 1:] = np.nan, np.nan, -1
                break
            want = min(chunk, n - k)
            clean, yb, vb = self.bulk(k, z, r, want)
            if clean:
                ys[k + 1:k + 1 + clean] = yb
                vs[k + 1:k + 1 + clean] = vb
                rs[k + 1:k + 1 + clean] = r
                z = (float(yb[-1]), float(vb[-1]))
                k += clean
                self.peak = max(self.peak, float(yb.max()))
            if k >= n:
                break
            if clean == want:
                chunk = min(4 * chunk, 4096)
                continue
            chunk = 64
            z, r = self.event_step(k, z, r)
            k += 1
            ys[k], vs[k], rs[k] = z[0], z[1], r
            self.peak = max(self.peak, z[0])
        return ys, vs, rs, z, r
