"""An independent time-domain solver of the SDOF valve train for the rig tests.

Not the product's propagator: ``scipy.integrate.solve_ivp`` (Radau, rtol 1e-8, exact
Jacobian) on the
contract's equations in time, with the camshaft angle a function of time (steady speed
plus a ripple), and terminal events at every regime switch (cam contact lost / made,
seat contact made / lost), restarting in the new regime. The valve starts seated at
rest on the base circle; ``settle`` revolutions are discarded, then samples are taken
on the time clock. Equations (docs/contract.md ``sdof``):

    u = k h(alpha) - x0,  delta = u - y
    F_t = c delta + b_t (du/dt - dy/dt)   in contact (delta > 0 and F_t > 0), else 0
    R   = -k_s y - b_s dy/dt              on the seat (y < 0 and R > 0), else 0
    M y'' = F_t + R - F0 - c' y - b_v y'
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Train:
    """SDOF parameters (SI) of the reference."""

    mass: float = 0.12
    stiffness: float = 1.2e7
    damping: float = 60.0
    spring_rate: float = 3.0e4
    spring_preload: float = 250.0
    rocker_ratio: float = 1.5
    lash: float = 2.5e-4
    valve_damping: float = 0.0
    seat_stiffness: float = 1.0e9
    seat_damping: float = 2000.0


@dataclass
class RefRun:
    """Clean reference samples: ``t`` [s], ``theta`` [rad] unwrapped, ``y`` [m]; and the
    lobe angles [rad] where the cam contact was lost while the rigid lift was positive,
    between the valve's lift-off and its next landing (separations), in the recorded
    revolutions."""

    t: np.ndarray
    theta: np.ndarray
    y: np.ndarray
    separations: list


def _lift_tables(law):
    """h and h' of the law as scalar functions: a degree-7 spline through the law's
    values every 0.02 deg on its support (error far below a nanometre), zero outside."""
    import bisect

    from scipy.interpolate import PPoly, make_interp_spline

    lo, hi = law.support
    a = np.linspace(lo, hi, int((hi - lo) / math.radians(0.02)) + 1)
    spl = make_interp_spline(a, law(a), k=7)

    def table(f):
        pp = PPoly.from_spline(f)
        xs = pp.x.tolist()
        cs = pp.c.T.tolist()

        def value(x):
            if not lo <= x <= hi:
                return 0.0
            i = min(max(bisect.bisect_right(xs, x) - 1, 0), len(cs) - 1)
            dx = x - xs[i]
            acc = 0.0
            for c in cs[i]:
                acc = acc * dx + c
            return acc
        return value
    return table(spl), table(spl.derivative())


def simulate_time(law, tr: Train, rpm: float, *, nose: float, direction: int = 1,
                  ripple: float = 0.0, order: int = 2, ripple_phase: float = 0.3,
                  settle: int = 2, revolutions: float = 4.0, rate: float = 50_000.0,
                  theta0: float = 0.0, rtol: float = 1e-8):
    """Clean samples of a run at mean camshaft speed ``rpm`` (``RefRun``)."""
    from scipy.integrate import solve_ivp

    w0 = rpm * math.pi / 30.0
    k = max(1, order)
    h_of, dh_of = _lift_tables(law)

    def theta(t):
        return theta0 + w0 * t + ripple / k * (math.sin(k * w0 * t + ripple_phase)
                                               - math.sin(ripple_phase))

    def theta_dot(t):
        return w0 * (1.0 + ripple * math.cos(k * w0 * t + ripple_phase))

    def cam(t):
        a = direction * (theta(t) - nose)
        a = (a + math.pi) % (2 * math.pi) - math.pi
        h = h_of(a)
        dh = dh_of(a)
        return tr.rocker_ratio * h - tr.lash, tr.rocker_ratio * dh * direction * theta_dot(t)

    def forces(t, z, contact, seat):
        u, ud = cam(t)
        ft = tr.stiffness * (u - z[0]) + tr.damping * (ud - z[1]) if contact else 0.0
        r = -tr.seat_stiffness * z[0] - tr.seat_damping * z[1] if seat else 0.0
        return u, ud, ft, r

    def rhs_for(contact, seat):
        def rhs(t, z):
            _, _, ft, r = forces(t, z, contact, seat)
            acc = (ft + r - tr.spring_preload - tr.spring_rate * z[0]
                   - tr.valve_damping * z[1]) / tr.mass
            return [z[1], acc]
        return rhs

    def events_for(contact, seat):
        evs = []
        if contact:
            def lose_cam(t, z):
                return forces(t, z, True, seat)[2]
            lose_cam.terminal, lose_cam.direction = True, -1
            evs.append(lose_cam)
        else:
            def meet_cam(t, z):
                return cam(t)[0] - z[0]
            meet_cam.terminal, meet_cam.direction = True, 1
            evs.append(meet_cam)
        if seat:
            def leave_seat(t, z):
                return forces(t, z, contact, True)[3]
            leave_seat.terminal, leave_seat.direction = True, -1
            evs.append(leave_seat)
        else:
            def land(t, z):
                return z[0]
            land.terminal, land.direction = True, -1
            evs.append(land)
        return evs

    period = 2 * math.pi / w0
    t_rec = settle * period
    t_end = t_rec + revolutions * period
    times = t_rec + np.arange(int(revolutions * period * rate)) / rate
    y_out = np.full(times.size, np.nan)
    z = np.array([-tr.spring_preload / (tr.seat_stiffness + tr.spring_rate), 0.0])
    t = 0.0
    contact, seat = cam(0.0)[0] > z[0], True
    wn = math.sqrt((tr.stiffness + tr.spring_rate) / tr.mass)
    max_step = 2 * math.pi / wn / 6.0
    switches = 0
    losses: list[float] = []
    airborne = False
    while t < t_end:
        kk = (tr.stiffness * contact + tr.seat_stiffness * seat + tr.spring_rate) / tr.mass
        bb = (tr.damping * contact + tr.seat_damping * seat + tr.valve_damping) / tr.mass
        jac = np.array([[0.0, 1.0], [-kk, -bb]])
        sol = solve_ivp(rhs_for(contact, seat), (t, t_end), z, method='Radau', jac=jac,
                        rtol=rtol, atol=1e-12, max_step=max_step,
                        events=events_for(contact, seat), dense_output=True)
        t1 = float(sol.t[-1])
        sel = (times >= t) & (times <= t1)
        if np.any(sel):
            y_out[sel] = sol.sol(times[sel])[0]
        z = sol.y[:, -1].copy()
        if sol.status == 1:          # a switch: flip the regime whose event fired
            fired = [i for i, te in enumerate(sol.t_events) if te.size]
            i = fired[0]
            if i == 0 and contact and airborne and t1 >= t_rec and cam(t1)[0] > 1e-6:
                a = direction * (theta(t1) - nose)
                losses.append((a + math.pi) % (2 * math.pi) - math.pi)
            if i == 0:
                contact = not contact
            else:
                seat = not seat
                # opening: the lift-off on the rise flank; the first landing ends it
                rise = ((direction * (theta(t1) - nose) + math.pi) % (2 * math.pi)
                        - math.pi) < 0
                airborne = (not seat) and (rise or airborne)
            switches += 1
            if switches > 200_000:
                raise RuntimeError('reference: endless switching')
            t = t1 + 1e-12 * period
        else:
            t = t1
    th = np.array([theta(tt) for tt in times])
    return RefRun(t=times - t_rec, theta=th, y=y_out, separations=losses)
