"""Followers and the lift conversion between follower kinds through the cam profile
(docs/follower.md); the profile geometry itself is ``cam_design.cam_profile``, the
order-3 Taylor arithmetic it differentiates with ``cam_design.jets``.

Conventions: alpha [rad] is the cam angle from the lobe centreline (see
``cam_design.lift_laws.base``); ``base_radius`` R0 [m] is the radius of the cam's base
circle (the profile itself, not the roller pitch circle).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_finite, require_positive
from cam_design.jets import (JET_ORDER, jet_atan2, jet_const, jet_deriv, jet_div,
                             jet_inverse_compose, jet_mul, jet_sqrt)
from cam_design.lift_laws.base import LiftLaw, SolvedLift

FOLLOWER_KINDS = ('flat', 'roller', 'knife')


@dataclass(frozen=True)
class Follower:
    """A translating follower or probe: ``kind`` flat | roller | knife; ``radius`` [m].

    A ball probe is a roller in the plane of measurement; a knife (point) follower
    is a roller of radius 0; ``radius`` is ignored for flat followers.
    """

    kind: str
    radius: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in FOLLOWER_KINDS:
            raise InputError('follower.kind', self.kind, ' | '.join(FOLLOWER_KINDS))
        require_positive('follower.radius', self.radius, allow_zero=True)
        if self.kind == 'roller' and self.radius == 0.0:
            raise InputError('follower.radius', self.radius,
                             'a roller radius > 0 (use kind: knife for a point follower)')


def _circle_ray(c: ArrayLike, radius: ArrayLike, x: NDArray[np.float64], sign: float
                ) -> NDArray[np.float64]:
    """(4, n): D and dD/dx^k (k = 1..3) of D = c cos x + sign sqrt(radius^2 - c^2 sin^2 x),
    the distance along the ray at angle x to a circle of ``radius`` whose centre is at
    distance c on the ray x = 0 (sign +1: far intersection, -1: near)."""
    c = np.asarray(c, dtype=float)
    co, si = np.cos(x), np.sin(x)
    k = c * c
    q = np.sqrt(np.asarray(radius, dtype=float) ** 2 - k * si * si)
    # q q' = -w with w = c^2 sin x cos x, w' = c^2 cos 2x, w'' = -2 c^2 sin 2x
    q1 = -k * si * co / q
    q2 = -(k * np.cos(2 * x) + q1 * q1) / q
    q3 = -(-2.0 * k * np.sin(2 * x) + 3.0 * q1 * q2) / q
    return np.stack([c * co + sign * q, -c * si + sign * q1, -c * co + sign * q2,
                     c * si + sign * q3])


def wrap_angle(alpha: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles [rad] wrapped to [-pi, pi)."""
    return (alpha + np.pi) % (2.0 * np.pi) - np.pi


# ---------------------------------------------------------------------------------------
# Lift conversion between follower kinds through the cam profile (docs/follower.md)
# ---------------------------------------------------------------------------------------

#: table density of the contact-angle map (points on the full turn).
TABLE_POINTS = 8192
#: one-sided offset [rad] used to read the limits of h' at a breakpoint.
SIDE_EPS = 1e-10
#: velocity steps [m/rad] below this are smooth; above it a flat design has a flat.
JUMP_TOL = 1e-9
#: downward velocity steps [m/rad] above this are rejected (a convex corner: undercut);
#: upward steps of a roller design below it are ignored (arc shorter than ~1e-16 m).
STEP_REJECT = 1e-6
#: largest allowed step of h itself at a breakpoint [m].
POSITION_TOL = 1e-9
NEWTON_TOL = 1e-14
NEWTON_MAX_ITER = 40
#: |dA/ds| below this is a plateau (straight flank under a flat target) [rad/rad].
PLATEAU_TOL = 1e-9
#: one-sided step [rad] used to evaluate the target on a plateau.
PLATEAU_SHIFT = 1e-9
#: scan density and (safeguarded Newton) steps locating the contact jumps of a bridge.
SWITCH_SCAN = 4096
SWITCH_ITER = 30
#: points per block in ConvertedLift.solve (keeps the jet temporaries in cache).
SOLVE_BLOCK = 2048


def contact_radius(f: Follower) -> float:
    """Radius [m] of the circle that touches the cam: 0 for a knife (point) follower."""
    return 0.0 if f.kind == 'knife' else f.radius


def _same_follower(a: Follower, b: Follower) -> bool:
    if a.kind == 'flat' and b.kind == 'flat':
        return True
    return a.kind == b.kind and contact_radius(a) == contact_radius(b)


class ConvertedLift(SolvedLift):
    """The lift seen by follower ``target`` on the cam cut for ``law`` with ``source``.

    Built by :func:`convert_lift`. The source follower defines the cam profile through
    its envelope; the profile is described by its support function H(psi) (psi: normal
    angle) and tangential coordinate T = dH/dpsi, both as exact jets in the source angle
    s. The target's contact angle A(s) (psi for a flat target, the polar angle of the
    roller centre psi + atan2(T, H + r) for a roller/knife) is inverted by bracketed
    Newton from a dense monotone table, and the lift derivatives follow by series
    reversion (no finite differences, no spline): exact to rounding.
    At an upward step of h' at b (the start of a constant-velocity ramp) the profile has
    a straight flat (flat design) or a concave arc of radius r1 around the pitch corner
    (roller design); the target's contact there is in closed form (``_piece_contact``).
    Where A(s) is not monotone (a concave flank the target bridges) the table is split
    into increasing runs and the lift is the max over the runs' contacts.
    """

    def __init__(self, law: LiftLaw, base_radius: float, source: Follower,
                 target: Follower, *, key: str = 'lift') -> None:
        self.law = law
        self.base_radius = base_radius
        self.source = source
        self.target = target
        self.key = key
        lo, hi = law.support
        self._src_support = (float(lo), float(hi))
        # (b, kind, value) of the pieces at h' steps: 'flat' (straight flat of a flat
        # design, value H_b = R0 + h(b)) or 'arc' (concave arc of radius r1 of a roller
        # design around the pitch corner C = g_b u(b), value g_b = R0 + r1 + h(b))
        self._edges: list[tuple[float, str, float]] = []
        self._splits: list[float] = []       # other h' steps (table points on both sides)
        self._breaks = self._breakpoints()
        self._build_table()
        # h' of the target steps on a plateau (straight flank under a flat target); h''
        # steps at the ends of a flat (roller/knife target on a flat of a flat design)
        if self._plateau or len(self._runs) > 1:
            self.continuity_order = 0
        elif self._edges:
            self.continuity_order = 1
        else:
            self.continuity_order = law.continuity_order
        self._cache: tuple[bytes, NDArray[np.float64]] | None = None

    # --- profile description -----------------------------------------------------------
    def _jets(self, s: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """Jets (psi, H, T) of the profile at source angles ``s`` (unwrapped, rad)."""
        n = s.size
        sw = wrap_angle(s)
        hj = np.stack([self.law(sw, k) / math.factorial(k) for k in range(JET_ORDER + 1)])
        param = jet_const(s, n)
        param[1] = 1.0
        r0 = self.base_radius
        if self.source.kind == 'flat':
            height = hj.copy()
            height[0] += r0
            return param, height, jet_deriv(hj)
        r1 = contact_radius(self.source)
        g = hj.copy()
        g[0] += r0 + r1
        gp = jet_deriv(g)
        w = jet_sqrt(jet_mul(g, g) + jet_mul(gp, gp))
        psi = param - jet_atan2(gp, g)
        height = jet_div(jet_mul(g, g), w)
        height[0] -= r1
        return psi, height, jet_div(jet_mul(g, gp), w)

    def _target_jets(self, s: NDArray[np.float64], check: bool = True
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Jets of the contact angle A and of the target lift at source angles ``s``."""
        psi, height, tang = self._jets(s)
        if check:
            self._check(s, psi, height, tang)
        r0 = self.base_radius
        if self.target.kind == 'flat':
            lift = height.copy()
            lift[0] -= r0
            return psi, lift
        r2 = contact_radius(self.target)
        hr = height.copy()
        hr[0] += r2
        angle = psi + jet_atan2(tang, hr)
        lift = jet_sqrt(jet_mul(hr, hr) + jet_mul(tang, tang))
        lift[0] -= r0 + r2
        return angle, lift

    def _check(self, s: NDArray[np.float64], psi: NDArray[np.float64],
               height: NDArray[np.float64], tang: NDArray[np.float64]) -> None:
        """Raise InputError where the design profile is undercut (envelope cusp)."""
        # P' = lam * t(psi): lam > 0 means the envelope advances (no cusp/undercut);
        # rho = lam / psi' is the profile's signed radius of curvature.
        lam = height[0] * psi[1] + tang[1]
        bad = ~(lam > 0)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise InputError(
                self.key, f'undercut (cusp) of the {self.source.kind} design profile at '
                f'alpha = {wrap_angle(s[i:i + 1])[0]:.6g} rad',
                'a lift law whose cam profile is realisable (radius of curvature > 0 for a '
                'flat design, pitch radius of curvature > roller radius for a roller)')

    def _breakpoints(self) -> list[float]:
        """Wrapped angles where h' may step: support ends and the law's junctions."""
        lo, hi = self._src_support
        if not (hi > lo and lo >= -math.pi - 1e-9 and hi <= math.pi + 1e-9):
            raise InputError(f'{self.key}.support', (lo, hi),
                             'an interval inside [-pi, pi] rad (alpha from the lobe centreline)')
        cands = [lo, hi] + [float(j) for j in self.law.junctions if lo < j < hi]
        wrapped = sorted(set(float(x) for x in wrap_angle(np.asarray(cands))))
        out: list[float] = []
        for b in wrapped:
            if out and abs(b - out[-1]) < 1e-12:
                continue
            out.append(b)
        if len(out) > 1 and abs(out[0] + 2 * math.pi - out[-1]) < 1e-12:
            out.pop()
        edges = []
        for b in out:
            side = wrap_angle(np.array([b - SIDE_EPS, b + SIDE_EPS]))
            h = self.law(side, 0)
            hp = self.law(side, 1)
            if abs(h[1] - h[0]) > POSITION_TOL + 2 * SIDE_EPS * float(np.max(np.abs(hp))):
                raise InputError(self.key, f'a step of {h[1] - h[0]:.3g} m in h at alpha = '
                                 f'{b:.6g} rad', 'a continuous lift (h = 0 at the support ends)')
            step = float(hp[1] - hp[0])
            if step < -STEP_REJECT:
                raise InputError(self.key, f'h\' steps down by {-step:.3g} m/rad at alpha = '
                                 f'{b:.6g} rad', 'a lift whose h\' only steps up (a down '
                                 'step cuts a convex corner: undercut)')
            if step > JUMP_TOL:
                edge = self._step_piece(b, step)
                if edge is not None:
                    edges.append(edge)
                else:
                    self._splits.append(b)
        if self.target.kind != 'flat':
            self._edges = edges
        return out

    def _step_piece(self, b: float, step: float) -> tuple[float, str, float] | None:
        """The profile piece at an upward step of h' at ``b`` (see ``_edges``)."""
        h_b = float(self.law(np.array([b]))[0])
        if self.source.kind == 'flat':
            return b, 'flat', self.base_radius + h_b
        r1, r2 = contact_radius(self.source), contact_radius(self.target)
        if step <= STEP_REJECT:
            return None          # too small to matter (< 1e-16 m)
        if self.target.kind == 'flat' or r2 > r1:
            return None          # the target bridges the arc: max over the two flanks
        return b, 'arc', self.base_radius + r1 + h_b

    # --- contact-angle table ------------------------------------------------------------
    def _build_table(self) -> None:
        edges = [b for b, _, _ in self._edges]
        start = edges[0] if edges else -math.pi
        end = start + 2 * math.pi
        grid = np.linspace(start, end, TABLE_POINTS + 1)
        pts: list[ArrayLike] = []
        gap_left: list[float] = []
        keep = np.ones(grid.size, dtype=bool)
        for b in self._splits:
            b = b if b >= start else b + 2 * math.pi
            keep &= np.abs(grid - b) > 2 * SIDE_EPS
            pts.append([b - SIDE_EPS, b + SIDE_EPS])
        if edges:
            inner = [b if b >= start else b + 2 * math.pi for b in edges[1:]]
            keep &= (grid > start + 2 * SIDE_EPS) & (grid < end - 2 * SIDE_EPS)
            for b in inner:
                keep &= np.abs(grid - b) > 2 * SIDE_EPS
                pts.append([b - SIDE_EPS, b + SIDE_EPS])
                gap_left.append(b - SIDE_EPS)
            # the last gap wraps: the point past the end repeats the first, one turn later
            pts.append([start + SIDE_EPS, end - SIDE_EPS, end + SIDE_EPS])
            gap_left.append(end - SIDE_EPS)
        pts.append(grid[keep])
        s = np.unique(np.concatenate([np.asarray(p, dtype=float) for p in pts]))
        angle, _ = self._target_jets(s)
        self._plateau = bool(np.any(np.abs(angle[1]) < PLATEAU_TOL))
        a = angle[0]
        raw = a.copy()
        if edges:
            a[-1] = a[0] + 2 * math.pi
        gap = np.zeros(s.size - 1, dtype=bool)
        for g in gap_left:
            gap[int(np.argmin(np.abs(s[:-1] - g)))] = True
        # runs of increasing contact angle: one for a convex profile; a concave flank the
        # target cannot follow (bridged) splits it, and the lift is the max over the runs
        # (a straight pitch segment gives a plateau of psi under a flat target: kept)
        tol = PLATEAU_TOL if self.target.kind == 'flat' else 0.0
        up = (np.diff(a) > -tol) | gap
        cuts = np.flatnonzero(~up)
        first = np.concatenate([[0], cuts + 1])
        last = np.concatenate([cuts, [s.size - 1]])
        self._runs = [(int(i), int(j)) for i, j in zip(first, last) if j > i]
        for i, j in self._runs:
            a[i:j + 1] = np.maximum.accumulate(a[i:j + 1])
        self._s = s
        self._a = a
        self._gap = gap
        self._edge_b = np.array([b for b, _, _ in self._edges])
        self._edge_arc = np.array([kind == 'arc' for _, kind, _ in self._edges], dtype=bool)
        self._edge_v = np.array([v for _, _, v in self._edges])
        # support: the contact angles of every flank point (wider than the source's when
        # the target bridges a concave flank next to the base circle)
        lo, hi = self._src_support
        ends, _ = self._target_jets(np.array([lo - SIDE_EPS, hi + SIDE_EPS]), check=False)
        wrapped = wrap_angle(s)
        flank = (wrapped >= lo) & (wrapped <= hi)
        seen = raw[flank] - (s[flank] - wrapped[flank])
        self._support = (float(min(ends[0][0], lo, np.min(seen, initial=lo))),
                         float(max(ends[0][1], hi, np.max(seen, initial=hi))))
        # target angles where the target's derivatives may step: both ends of every flat
        # and the images of the source's junctions
        marks = [self._a[:-1][gap], self._a[1:][gap]]
        inner = [j for j in self._breaks if all(abs(j - b) > 1e-12 for b in edges)]
        if inner:
            marks.append(self._target_jets(np.asarray(inner, dtype=float), check=False)[0][0])
        if len(self._runs) > 1:
            marks.append(np.asarray(self._contact_switches()))
        self._junctions = tuple(sorted(set(float(x) for x in wrap_angle(np.concatenate(marks)))))

    @property
    def support(self) -> tuple[float, float]:
        return self._support

    @property
    def junctions(self) -> tuple[float, ...]:
        return self._junctions

    # --- evaluation ----------------------------------------------------------------------
    def solve(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): target h, h', h'', h''' at ``alpha`` [rad] (flattened); 0 on the base.

        Any alpha is accepted (wrapped); work proceeds in cache-sized blocks.
        """
        a = np.asarray(alpha, dtype=float).reshape(-1)
        if not np.all(np.isfinite(a)):
            raise InputError('alpha', 'non-finite entries', 'finite angles in rad')
        out = np.zeros((JET_ORDER + 1, a.size))
        for start in range(0, a.size, SOLVE_BLOCK):
            stop = start + SOLVE_BLOCK
            out[:, start:stop] = self._solve_block(a[start:stop])
        bad = ~np.all(np.isfinite(out), axis=0)
        if np.any(bad):     # defensive: never hand back NaN silently
            raise InputError(self.key, f'no unique contact at alpha = {a[bad][0]:.6g} rad',
                             'a lift law whose cam profile gives the target one contact')
        return out

    def _candidates(self, a: NDArray[np.float64], runs: NDArray[np.int64] | None = None
                    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
        """Candidate contacts at angles ``a``: (angle index, run index, derivatives).

        Every (angle, run) pair whose run reaches the angle is a candidate (with ``runs``:
        only the pair (a[i], runs[i])); all are solved in one vectorised pass.
        """
        which, owner, where, cells = [], [], [], []
        keys = range(len(self._runs)) if runs is None else np.unique(runs)
        for k in keys:
            i0, i1 = self._runs[k]
            pick = np.arange(a.size) if runs is None else np.flatnonzero(runs == k)
            run = self._a[i0:i1 + 1]
            aa = run[0] + np.mod(a[pick] - run[0], 2 * math.pi)
            inside = aa <= run[-1]
            sel = pick[inside]
            if sel.size:
                which.append(sel)
                owner.append(np.full(sel.size, k))
                where.append(aa[inside])
                cells.append(i0 + np.clip(np.searchsorted(run, aa[inside], side='right') - 1,
                                          0, run.size - 2))
        if not which:
            return np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros((4, 0))
        got = self._run_contact(np.concatenate(where), np.concatenate(cells))
        return np.concatenate(which), np.concatenate(owner), got

    def _solve_block(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        q, _, got = self._candidates(a)
        if np.unique(q).size < a.size:
            i = int(np.setdiff1d(np.arange(a.size), q)[0])
            raise InputError(self.key, f'no contact found at alpha = {a[i]:.6g} rad',
                             'a closed, undercut-free cam profile')
        out = np.empty((JET_ORDER + 1, a.size))
        first = self._winners(q, got[0])
        out[:, q[first]] = got[:, first]
        return out

    @staticmethod
    def _winners(q: NDArray[np.int64], lift: NDArray[np.float64]) -> NDArray[np.int64]:
        """Per angle index in ``q``, the position of its largest candidate lift."""
        if np.unique(q).size == q.size:
            return np.arange(q.size)
        order = np.lexsort((-lift, q))
        return order[np.concatenate([[True], np.diff(q[order]) != 0])]

    def _contact_switches(self) -> list[float]:
        """Angles [rad] where a bridging contact jumps between runs (h' steps there):
        the winner changes on a 4096-point scan, then bisection on the two runs' lifts."""
        grid = np.linspace(-math.pi, math.pi, SWITCH_SCAN, endpoint=False)
        q, run, got = self._candidates(grid)
        value = np.full((len(self._runs), grid.size), -np.inf)
        value[run, q] = got[0]
        first = self._winners(q, got[0])
        win = np.empty(grid.size, dtype=int)
        win[q[first]] = run[first]
        nxt = np.roll(np.arange(grid.size), -1)
        ra, rb = win, win[nxt]
        both = (ra != rb) & np.isfinite(value[ra, nxt]) & np.isfinite(value[rb, np.arange(
            grid.size)])
        lo = grid[both]
        hi = lo + 2 * math.pi / SWITCH_SCAN
        ra, rb = ra[both], rb[both]
        x = 0.5 * (lo + hi)
        for _ in range(SWITCH_ITER):   # safeguarded Newton on the lift difference
            da, db = self._run_lift(x, ra), self._run_lift(x, rb)
            diff = da[0] - db[0]
            ahead = diff > 0            # the first run still wins at x
            lo = np.where(ahead, x, lo)
            hi = np.where(ahead, hi, x)
            with np.errstate(divide='ignore', invalid='ignore'):
                step = x - diff / (da[1] - db[1])
            ok = np.isfinite(step) & (step > lo) & (step < hi)
            x_new = np.where(ok, step, 0.5 * (lo + hi))
            moved = np.max(np.abs(x_new - x), initial=0.0)
            x = x_new
            if moved < 1e-13 or np.all(np.abs(diff) < 1e-15):
                break
        return [float(v) for v in wrap_angle(x)]

    def _run_lift(self, a: NDArray[np.float64], runs: NDArray[np.int64]
                  ) -> NDArray[np.float64]:
        """(2, n): lift and h' of run ``runs[i]``'s contact at a[i] (-inf if out of reach)."""
        q, _, got = self._candidates(a, runs)
        out = np.full((2, a.size), -np.inf)
        out[:, q] = got[:2]
        return out

    def _run_contact(self, aa: NDArray[np.float64], idx: NDArray[np.int64]
                     ) -> NDArray[np.float64]:
        """Target derivatives at unwrapped angles ``aa`` in table intervals ``idx``."""
        out = np.zeros((JET_ORDER + 1, aa.size))
        on_gap = self._gap[idx]
        if np.any(on_gap):
            out[:, on_gap] = self._piece_contact(aa[on_gap], idx[on_gap])
        smooth = ~on_gap
        if np.any(smooth):
            derivs, rate = self._newton(aa[smooth], idx[smooth])
            # on a plateau of psi (a straight flank under a flat target) h' steps: take
            # the limit from above, shifted back by a Taylor step
            flat_on = np.abs(rate) < PLATEAU_TOL
            if np.any(flat_on):
                shifted = aa[smooth][flat_on] + PLATEAU_SHIFT
                sub = np.minimum(idx[smooth][flat_on] + (shifted > self._a[
                    idx[smooth][flat_on] + 1]), self._a.size - 2)
                right, _ = self._newton(shifted, sub)
                for k in range(JET_ORDER):
                    right[k] -= PLATEAU_SHIFT * right[k + 1]
                derivs[:, flat_on] = right
            out[:, smooth] = derivs
        return out

    def _piece_contact(self, aa: NDArray[np.float64], idx: NDArray[np.int64]
                       ) -> NDArray[np.float64]:
        """Target on the piece at an h' step b (alpha between A(b-) and A(b+)).

        Flat of a flat design: D = c / cos(alpha - b), c = R0 + h(b) + r2. Concave arc of a
        roller design (radius r1 around C = g_b u(b)): the target centre is on the circle
        of radius r1 - r2 around C, D = g_b cos x - sqrt((r1 - r2)^2 - g_b^2 sin^2 x),
        x = alpha - b.
        """
        b = 0.5 * (self._s[idx] + self._s[idx + 1])
        which = np.argmin(np.abs(wrap_angle(b[:, None] - self._edge_b[None, :])), axis=1)
        value = self._edge_v[which]
        arc = self._edge_arc[which]
        r2 = contact_radius(self.target)
        x = aa - b
        out = np.empty((JET_ORDER + 1, aa.size))
        flat = ~arc
        if np.any(flat):
            c, xf = value[flat] + r2, x[flat]
            sec, tan = 1.0 / np.cos(xf), np.tan(xf)
            out[:, flat] = np.stack([c * sec, c * sec * tan, c * (sec * tan * tan + sec ** 3),
                                     c * sec * tan * (tan * tan + 5.0 * sec * sec)])
        if np.any(arc):
            out[:, arc] = _circle_ray(value[arc], contact_radius(self.source) - r2, x[arc], -1.0)
        out[0] -= self.base_radius + r2
        return out

    def _newton(self, aa: NDArray[np.float64], idx: NDArray[np.int64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Derivatives (4, n) at the target angles and dA/ds at the contact."""
        s_lo = self._s[idx].copy()
        s_hi = self._s[idx + 1].copy()
        a_lo = self._a[idx]
        a_hi = self._a[idx + 1]
        span = a_hi - a_lo
        frac = np.where(span > 0, (aa - a_lo) / np.where(span > 0, span, 1.0), 0.5)
        s = s_lo + np.clip(frac, 0.0, 1.0) * (s_hi - s_lo)
        for _ in range(NEWTON_MAX_ITER):
            angle, lift = self._target_jets(s)
            f = angle[0] - aa
            if np.max(np.abs(f)) < NEWTON_TOL:
                break
            s_hi = np.where(f > 0, s, s_hi)
            s_lo = np.where(f <= 0, s, s_lo)
            with np.errstate(divide='ignore', invalid='ignore'):
                step = s - f / angle[1]
            inside = (step >= s_lo) & (step <= s_hi)
            s = np.where(np.abs(f) < NEWTON_TOL, s,
                         np.where(inside, step, 0.5 * (s_lo + s_hi)))
        with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
            derivs = jet_inverse_compose(angle, lift)
            for k in range(JET_ORDER):     # first-order correction for the residual angle
                derivs[k] -= f * derivs[k + 1]
        return derivs, angle[1]


def convert_lift(law: LiftLaw, base_radius: float, source: Follower, target: Follower,
                 *, key: str = 'lift') -> LiftLaw:
    """Lift [m] that the in-line translating follower ``target`` sees on the cam cut for
    the design lift ``law`` with follower ``source``.

    Same alpha convention as ``law`` (rad from the lobe centreline, h = 0 on the base
    circle); ``base_radius`` [m] is the base-circle radius of the cam profile itself.
    Returns ``law`` itself when the followers are the same (flat radii are ignored);
    otherwise a :class:`ConvertedLift` with exact h, h', h'', h'''.
    A concave flank that the target cannot follow (flat face, larger roller) is bridged:
    the lift is the max over the contacts (docs/follower.md), with a step of h' where the
    contact jumps. Raises InputError (naming ``key``) for an undercut design profile
    (envelope cusp), a step in h, or a downward step of h' (a convex corner).
    """
    if not isinstance(law, LiftLaw):
        raise InputError(key, type(law).__name__, 'a cam_design LiftLaw')
    r0 = require_positive('base_radius', base_radius)
    for name, f in (('source', source), ('target', target)):
        if not isinstance(f, Follower):
            raise InputError(f'{name}', f, 'a cam_design.follower.Follower')
    if _same_follower(source, target):
        return law
    return ConvertedLift(law, r0, source, target, key=key)


class EccentricDiscLift(LiftLaw):
    """Exact lift of an eccentric disc (docs/follower.md; docs/methods.md case 13) for a follower.

    Disc radius ``disc_radius`` R_c [m], eccentricity e [m] (nose at alpha = 0, base
    radius R0 = R_c - e). Flat: h = e (1 + cos a). Roller radius r (knife r = 0):
    h = e cos a + sqrt((R_c + r)^2 - e^2 sin^2 a) - (R0 + r). The reference for
    conversion tests and benchmarks; support is the full turn.
    """

    continuity_order = 3

    def __init__(self, disc_radius: float, eccentricity: float, follower: Follower) -> None:
        self.disc_radius = require_positive('disc_radius', disc_radius)
        self.eccentricity = require_positive('eccentricity', eccentricity)
        if self.eccentricity >= self.disc_radius:
            raise InputError('eccentricity', eccentricity, 'a value below the disc radius')
        self.follower = follower

    @property
    def support(self) -> tuple[float, float]:
        return -math.pi, math.pi

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        e = self.eccentricity
        if self.follower.kind == 'flat':
            c, s = np.cos(alpha), np.sin(alpha)
            return (e * (1.0 + c), -e * s, -e * c, e * s)[nu]
        r = contact_radius(self.follower)
        out = _circle_ray(e, self.disc_radius + r, alpha, 1.0)[nu]
        return out - (self.disc_radius - e + r) if nu == 0 else out


def wheel_centre_lift(law: LiftLaw, base_radius: float, design: Follower,
                      wheel_radius: float) -> LiftLaw:
    """Grinding-wheel centre path as a roller lift (docs/follower.md step 1).

    The wheel of radius R_w [m] acts as a roller follower on the work cam: its centre is
    at D = R0 + R_w + h_w(alpha), with h_w = convert_lift(law, R0, design, roller R_w).
    """
    rw = require_positive('wheel_radius', wheel_radius)
    return convert_lift(law, base_radius, design, Follower('roller', rw))


def ground_lift(law: LiftLaw, base_radius: float, design: Follower, wheel_radius: float,
                wheel_error: float, target: Follower | None = None) -> LiftLaw:
    """Lift of the cam actually ground with a wheel of radius R_w + dR (docs/follower.md).

    The master is computed for ``wheel_radius`` R_w, the real wheel is R_w + dR
    (``wheel_error`` dR [m], either sign) and the operator re-zeroes the base circle, so
    the wheel centre runs on D + dR: the ground cam is the roller-design cam of
    ``wheel_centre_lift`` for a roller of radius R_w + dR with the same base radius.
    Returns the lift that ``target`` (default: the design follower) sees on it; the
    error is ``ground_lift(...)(alpha) - law(alpha)``. InputError if the ground
    profile is undercut (dR too negative for the path's curvature).
    """
    rw = require_positive('wheel_radius', wheel_radius)
    dr = require_finite('wheel_error', wheel_error)
    if rw + dr <= 0:
        raise InputError('wheel_error', dr, f'a value above -wheel_radius ({-rw} m)')
    path = wheel_centre_lift(law, base_radius, design, rw)
    return convert_lift(path, base_radius, Follower('roller', rw + dr),
                        design if target is None else target, key='ground lift')
