"""Spikes on a lift table: which rows whose rebound exceeds the tolerance are confirmed
as outliers by a local leave-out prediction that follows the lift (rebound.py, step 3
of docs/reconstruction.md).

On tables coarser than 0.75 deg the cubic spline's own interpolation error on a lobe's
flanks exceeds the noise, so a large rebound alone does not make a spike: the row must
also miss a local quintic prediction from its neighbours by more than the noise allows
and by more than the same prediction misses at the neighbours (the lift's own
interpolation error there). Angles in rad, lifts in m.
"""
from __future__ import annotations

import math
import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: a confirmed spike misses its local prediction by more than these multiples of the
#: median and of the largest miss of the same predictions at its +-3 neighbours (the
#: lift's own interpolation error there)
NEIGHBOUR_FACTORS = (4.0, 2.0)


def local_maxima(a: NDArray[np.float64]) -> NDArray[np.bool_]:
    """a_i > 0 and a_i is the largest within +-2 samples."""
    padded = np.concatenate([np.zeros(2), a, np.zeros(2)])
    window = np.lib.stride_tricks.sliding_window_view(padded, 5)
    return (a > 0) & (a >= window.max(axis=1))


@dataclass(frozen=True)
class Confirmed:
    """Rows confirmed this sweep: ``single`` rows (to move by their rebound), and the
    rows of ``grouped`` spikes, confirmed together, with ``fill`` [m] their local
    quintic prediction from the rows around the group."""

    single: NDArray[np.int64]
    grouped: NDArray[np.int64]
    fill: NDArray[np.float64]


def confirmed_candidates(x: NDArray[np.float64], y: NDArray[np.float64],
                         a: NDArray[np.float64], big: NDArray[np.bool_],
                         excluded: NDArray[np.bool_], tol: float,
                         floor: float, seen: dict[bytes, dict[int, float]] | None = None
                         ) -> Confirmed:
    """Rows to take this sweep near the local maxima of ``a`` among ``big``: the best
    group of 2-``GROUP_SIZE`` rows within ``GROUP_REACH`` rows of each maximum,
    confirmed jointly (``best_group``), or else the maximum itself confirmed alone
    (``_quintic_confirms``). A refused maximum is vetoed and the next tried (at most
    four rounds). ``seen``: the group answers of earlier sweeps, by row and the rows
    that decide them (filled in)."""
    memo: dict[bytes, dict[int, float]] = {} if seen is None else seen
    score = np.where(big, a, 0.0)
    chosen: list[int] = []
    grouped: dict[int, float] = {}
    for _ in range(4):
        cand = np.flatnonzero(local_maxima(score))
        if cand.size == 0:
            break
        ok = np.zeros(cand.size, dtype=bool)
        for k, i in enumerate(cand):
            taken = excluded.copy()
            taken[chosen + list(grouped)] = True
            if taken[i]:
                ok[k] = True
                continue
            lo, hi = max(int(i) - REACH_ROWS, 0), int(i) + REACH_ROWS + 1
            key = (np.int64(i).tobytes() + y[lo:hi].tobytes() + taken[lo:hi].tobytes())
            if key not in memo:
                memo[key] = best_group(x, y, taken, int(i), tol, floor)
            found = memo[key]
            grouped.update(found)
            ok[k] = bool(found)
            for j in found:
                score[max(j - 2, 0):j + 3] = 0.0
        rest = cand[~ok]
        if rest.size:
            taken = excluded.copy()
            taken[list(grouped)] = True
            alone = _quintic_confirms(x, y, rest, taken, tol, floor)
            chosen += [int(i) for i in rest[alone]]
            ok[~ok] = alone
        score[cand] = 0.0                   # confirmed: taken; rejected: vetoed
        if np.all(ok):
            break
    rows = sorted(grouped)
    return Confirmed(np.array(sorted(chosen), dtype=np.int64), np.array(rows, dtype=np.int64),
                     np.array([grouped[j] for j in rows], dtype=float))


#: largest group of nearby rows tested together, and how far [rows] from a candidate
#: (a local maximum of the rebound) its rows may lie: two to four spikes one or two
#: rows apart put the largest rebound on a clean row between them, or hide each other
#: (each spoils the other's neighbour test), so that a row seen alone is refused
GROUP_SIZE = 4
GROUP_REACH = 3
#: rows of the local least-squares quintic that predicts a row of a group (2 degrees
#: of freedom: the noise gain sqrt(1 + |w|^2) about 1.3, where the interpolating
#: quintic through six rows on one side of a group reaches 3-4)
GROUP_FIT_ROWS = 8


#: rows either side of a candidate whose values and exclusion decide ``best_group``
#: (its window, the neighbours' and the stencils' reach)
REACH_ROWS = GROUP_REACH + 3 + 2 * GROUP_FIT_ROWS + 6

#: spacing [rows] of the places tried for a step of h'' that may explain a group instead
HINGE_STEP = 0.25


def _junction_explains(x: NDArray[np.float64], y: NDArray[np.float64],
                       usable: NDArray[np.int64], group: tuple[int, ...],
                       bar: float) -> bool:
    """Does a step of h'' explain a row of ``group`` instead? A least-squares quintic
    plus a hinge (x - t)_+^2 through the ``GROUP_FIT_ROWS`` + 2 usable rows nearest to
    the group (the group left out, and in turn each of them within ``GROUP_REACH``
    beside the group that misses its own prediction by more than ``bar``: another
    spike), for t from a row before the group to a row after it in quarter
    rows: True when, for some t, it predicts a row of the group within ``bar`` [m]. A
    junction changes h'' for every row after it, so that a step fitted to the rows
    around it also predicts the rows next to it; a spike moves one row, which no step
    fitted to its neighbours predicts (a spike beside a junction would
    otherwise take the junction's rows with it into a group)."""
    centre = 0.5 * (group[0] + group[-1])
    others = sorted((int(j) for j in usable if j not in group),
                    key=lambda j: abs(j - centre))[:GROUP_FIT_ROWS + 2]
    idx = np.array(sorted(others))
    if idx.size < 9:
        return False
    mid = int(round(centre))
    step = float(np.median(np.diff(x[idx])))
    scale = max(float(np.ptp(x[idx])), 1e-300)
    xs = (x[idx] - x[mid]) / scale
    xg = (x[list(group)] - x[mid]) / scale
    fit_base = np.vander(xs, 6, increasing=True)
    at_base = np.vander(xg, 6, increasing=True)
    # a stencil row beside the group that misses its own prediction (the group left
    # out) by more than the bar may be another spike: each such row left out in turn
    beside = np.array([j for j in idx if group[0] - GROUP_REACH <= j < group[0]
                       or group[-1] < j <= group[-1] + GROUP_REACH], dtype=np.int64)
    drops: list[int | None] = [None]
    if beside.size:
        skips = np.isin(usable[None, :], group) | (usable[None, :] == beside[:, None])
        off = np.abs(_misses(x, y, usable, beside, skips)[0]) > bar
        drops += [int(np.searchsorted(idx, j)) for j in beside[off]]
    for t in np.arange(group[0] - 1.0, group[-1] + 1.0 + 1e-9, HINGE_STEP):
        where = (t - mid) * step / scale
        design = np.column_stack([fit_base, np.maximum(xs - where, 0.0) ** 2])
        at_design = np.column_stack([at_base, np.maximum(xg - where, 0.0) ** 2])
        for drop in drops:
            use = np.arange(idx.size) != (-1 if drop is None else drop)
            coef = np.linalg.lstsq(design[use], y[idx][use], rcond=None)[0]
            if float(np.min(np.abs(y[list(group)] - at_design @ coef))) <= bar:
                return True
    return False


def _misses(x: NDArray[np.float64], y: NDArray[np.float64], usable: NDArray[np.int64],
            rows: NDArray[np.int64], skips: NDArray[np.bool_]
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Misses of local least-squares quintics, many at once: row ``rows[k]`` [m] minus
    the value at its angle of the quintic through the ``GROUP_FIT_ROWS`` rows of
    ``usable`` nearest to it (the nearer, then the lower, first) other than those
    where ``skips[k]`` (K x usable.size) is True. Returns (misses [m], noise gains
    sqrt(1 + |w|^2) of the predictions w.y), each (K,)."""
    offset = usable[None, :] - rows[:, None]
    dist = (2 * np.abs(offset) + (offset > 0)).astype(float)   # nearer, then lower row
    dist[skips] = np.inf
    idx = usable[np.argpartition(dist, GROUP_FIT_ROWS - 1, axis=1)[:, :GROUP_FIT_ROWS]]
    dx = x[idx] - x[rows][:, None]
    xs = dx / np.maximum(np.ptp(x[idx], axis=1), 1e-300)[:, None]
    vander = xs[:, :, None] ** np.arange(6)                    # (K, rows, 6)
    gram = np.einsum('kri,krj->kij', vander, vander)
    e0 = np.zeros((rows.size, 6, 1))
    e0[:, 0, 0] = 1.0
    weights = np.einsum('kri,ki->kr', vander, np.linalg.solve(gram, e0)[:, :, 0])
    miss = y[rows] - np.einsum('kj,kj->k', weights, y[idx])
    return miss, np.sqrt(1.0 + np.einsum('kj,kj->k', weights, weights))


def best_group(x: NDArray[np.float64], y: NDArray[np.float64],
               excluded: NDArray[np.bool_], i: int, tol: float,
               floor: float) -> dict[int, float]:
    """The rows of the largest group G (2 to ``GROUP_SIZE`` rows within ``GROUP_REACH``
    of row ``i``, not ``excluded``, interior) each of whose rows misses its local
    least-squares quintic prediction with all of G left out (``_misses``) by more
    than ``tol`` [m] x the prediction's noise gain, than ``floor`` [m] and than the
    misses of the same predictions at the rows within +-3 of G (``NEIGHBOUR_FACTORS``:
    4 x their median, 2 x their largest; the lift's own interpolation error, or a spike
    left out of G), and none of whose rows a step of h'' fitted to its neighbours
    predicts within the noise (``_junction_explains``); of that size the largest
    smallest margin. The largest, since every row of it must pass with the others
    left out: a clean row between two spikes misses most while they are in the
    stencil, and fits once they are out. Returns each row's prediction [m]; {} when no
    group passes (a single row is then judged alone: ``_quintic_confirms``). A clean
    row passes a member's test with probability 2 Phi(-tol / sigma) (6.8e-6 at 4.5
    sigma); a row is a member of 41 of the 91 groups around one candidate, so a clean
    row is taken with probability below 2e-3 there (Bonferroni, 7 rows x 41 groups)."""
    n = x.size
    usable = np.flatnonzero(~excluded)
    rows = [j for j in range(i - GROUP_REACH, i + GROUP_REACH + 1)
            if 0 < j < n - 1 and not excluded[j]]
    if usable.size < 2 * GROUP_FIT_ROWS or not rows:
        return {}
    near = usable[np.abs(usable - i) <= GROUP_REACH + 2 * GROUP_FIT_ROWS + 6]
    # spikes are sparse: at most GROUP_SIZE rows out within +-3 rows of a group
    # (counting those already out), or a run of rows the lift's shape leaves off the
    # local fits (beside a junction) would be taken a group at a time
    gone = np.concatenate([[0], np.cumsum(excluded)])
    groups = [g for size in range(2, GROUP_SIZE + 1)
              for g in itertools.combinations(rows, size)
              if size + gone[min(g[-1] + 4, n)] - gone[max(g[0] - 3, 0)] <= GROUP_SIZE]
    if not groups:
        return {}
    member = np.array([j for g in groups for j in g])
    owner = np.repeat(np.arange(len(groups)), [len(g) for g in groups])
    in_group = np.zeros((len(groups), near.size), dtype=bool)
    in_group[owner, np.searchsorted(near, member)] = True
    miss, gain = _misses(x, y, near, member, in_group[owner])
    bar = np.abs(miss) / np.maximum(tol * gain, floor)
    clear = np.ones(len(groups), dtype=bool)
    np.logical_and.at(clear, owner, bar > 1.0)
    for size in range(GROUP_SIZE, 1, -1):
        ks = [k for k, g in enumerate(groups) if len(g) == size and clear[k]]
        margins = _margins(x, y, near, excluded, [groups[k] for k in ks],
                           [miss[owner == k] for k in ks],
                           [np.maximum(tol * gain[owner == k], floor) for k in ks])
        for m, k in sorted(zip(margins, ks), reverse=True):
            own = owner == k
            if m <= 1.0:
                break
            if not _junction_explains(x, y, usable, groups[k],
                                      max(tol * float(np.max(gain[own])), floor)):
                return {j: float(y[j] - v) for j, v in zip(groups[k], miss[own])}
    return {}


def _margins(x: NDArray[np.float64], y: NDArray[np.float64], near: NDArray[np.int64],
             excluded: NDArray[np.bool_], groups: list[tuple[int, ...]],
             misses: list[NDArray[np.float64]], bars: list[NDArray[np.float64]]
             ) -> list[float]:
    """For each group (its rows' ``misses`` [m] and noise ``bars`` [m]): the smallest
    ratio of a row's miss to the larger of its bar and the neighbour scale (4 x the
    median, 2 x the largest miss of the predictions at the rows within +-3 of the
    group, the group left out; ``NEIGHBOUR_FACTORS``)."""
    if not groups:
        return []
    n = x.size
    med, top = NEIGHBOUR_FACTORS
    width = 2 * 3 + 2 * GROUP_REACH + 1
    first = np.array([g[0] for g in groups])
    last = np.array([g[-1] for g in groups])
    members = np.array([g + (-1,) * (GROUP_SIZE - len(g)) for g in groups])   # (K, S)
    cand = first[:, None] - 3 + np.arange(width)[None, :]
    valid = (cand <= last[:, None] + 3) & (cand > 0) & (cand < n - 1)
    valid &= ~excluded[np.clip(cand, 0, n - 1)]
    valid &= ~np.any(cand[:, :, None] == members[:, None, :], axis=2)
    owner, slot = np.nonzero(valid)
    rows = cand[owner, slot]
    skips = np.zeros((rows.size, near.size), dtype=bool)
    at = np.searchsorted(near, np.maximum(members, 0))[owner]                   # (P, S)
    pair = np.repeat(np.arange(rows.size)[:, None], GROUP_SIZE, axis=1)
    real = members[owner] >= 0
    skips[pair[real], at[real]] = True
    skips[np.arange(rows.size), np.searchsorted(near, rows)] = True
    errs = np.zeros(valid.shape)
    if rows.size:
        errs[owner, slot] = np.abs(_misses(x, y, near, rows, skips)[0])
    count = valid.sum(axis=1)
    ordered = np.sort(np.where(valid, errs, np.inf), axis=1)
    k = np.arange(len(groups))
    median = 0.5 * (ordered[k, np.maximum(count - 1, 0) // 2]
                    + ordered[k, np.minimum(count // 2, width - 1)])
    middle = np.where(count > 0, median, 0.0)
    largest = np.where(count > 0, np.max(np.where(valid, errs, 0.0), axis=1), 0.0)
    scale = np.maximum(med * middle, top * largest)
    return [float(np.min(np.abs(m) / np.maximum(b, c)))
            for m, b, c in zip(misses, bars, scale)]


def _quintic_loo(x: NDArray[np.float64], y: NDArray[np.float64], usable: NDArray[np.int64],
                 i: int, skip: tuple[int, ...]) -> tuple[float, float] | None:
    """(|y_i - p(x_i)|, sqrt(1 + sum w^2)) for a degree-5 polynomial p through six of the
    seven usable samples nearest to i other than ``skip``: the subset that predicts y_i
    best, so that one more spike among the neighbours does not spoil the test. None if
    there are not seven such samples."""
    pos = int(np.searchsorted(usable, i))
    lo = max(0, min(pos - 7, usable.size - 15))
    near = [int(j) for j in usable[lo:lo + 15] if j not in skip]
    idx = np.array(sorted(near, key=lambda j: abs(j - i))[:7])
    if idx.size < 7:
        return None
    xs = (x[idx] - x[i]) / max(float(np.ptp(x[idx])), 1e-300)
    subsets = np.array([[k for k in range(7) if k != drop] for drop in range(7)])
    vander = np.vander(xs, 6, increasing=True)[subsets]          # (7, 6, 6)
    try:
        weights = np.linalg.solve(np.transpose(vander, (0, 2, 1)),
                                  np.broadcast_to(np.eye(6)[0], (7, 6))[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return None
    resid = np.abs(y[i] - np.einsum('sk,sk->s', weights, y[idx][subsets]))
    best = int(np.argmin(resid))
    return float(resid[best]), math.sqrt(1.0 + float(weights[best] @ weights[best]))


def _quintic_confirms(x: NDArray[np.float64], y: NDArray[np.float64],
                      cand: NDArray[np.int64], excluded: NDArray[np.bool_], tol: float,
                      floor: float) -> NDArray[np.bool_]:
    """For each candidate i alone: does y_i differ from the local quintic leave-one-out
    prediction (``_quintic_loo``) by more than ``tol`` x its noise factor, than
    ``floor``, and than the same prediction error at its neighbours (i +- 1..3, each
    without i; ``NEIGHBOUR_FACTORS``)? The last test tells a spike from lift that the
    sampling does not resolve."""
    ok = np.ones(cand.size, dtype=bool)
    usable = np.flatnonzero(~excluded)
    others = tuple(int(c) for c in cand)          # other candidates stay out of stencils
    med, top = NEIGHBOUR_FACTORS
    for k, i in enumerate(cand):
        own = _quintic_loo(x, y, usable, int(i), others)
        if own is None:
            continue
        near = [j for j in (i - 3, i - 2, i - 1, i + 1, i + 2, i + 3)
                if 0 <= j < x.size and not excluded[j] and j not in others]
        local = [_quintic_loo(x, y, usable, j, (j,) + others) for j in near]
        errs = [v[0] for v in local if v is not None] or [0.0]
        scale = max(med * float(np.median(errs)), top * max(errs))
        ok[k] = own[0] > max(tol * own[1], floor, scale)
    return ok
