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

import numpy as np
from numpy.typing import NDArray

#: on an exact table an outlier (a typing error) also misses by more than this multiple
#: of the rebound floor (5 x 2e-5 = 1e-4 of the lift range: 0.8 um on an 8 mm lobe)
EXACT_FLOOR = 5.0


def local_maxima(a: NDArray[np.float64]) -> NDArray[np.bool_]:
    """a_i > 0 and a_i is the largest within +-2 samples."""
    padded = np.concatenate([np.zeros(2), a, np.zeros(2)])
    window = np.lib.stride_tricks.sliding_window_view(padded, 5)
    return (a > 0) & (a >= window.max(axis=1))


def confirmed_candidates(x: NDArray[np.float64], y: NDArray[np.float64],
                         a: NDArray[np.float64], big: NDArray[np.bool_],
                         excluded: NDArray[np.bool_], tol: float,
                         floor: float, exact: bool = False) -> NDArray[np.int64]:
    """Indices to move this sweep: confirmed local maxima of ``a`` among ``big``."""
    score = np.where(big, a, 0.0)
    chosen: list[int] = []
    for _ in range(4):
        cand = np.flatnonzero(local_maxima(score))
        if cand.size == 0:
            break
        ok = _quintic_confirms(x, y, cand, excluded, tol, floor, exact)
        chosen += [int(i) for i in cand[ok]]
        score[cand] = 0.0                   # confirmed: taken; rejected: vetoed
        if np.all(ok):
            break
    return np.array(sorted(chosen), dtype=np.int64)


def _one_sided_miss(x: NDArray[np.float64], y: NDArray[np.float64],
                    usable: NDArray[np.int64], i: int, skip: tuple[int, ...]) -> float:
    """Smallest |y_i - p(x_i)| over the quintics through the six nearest usable samples
    on either side of i (extrapolation; for exact tables, where a junction of the lift
    law next to i spoils every two-sided stencil). inf if neither side has six."""
    best = math.inf
    pos = int(np.searchsorted(usable, i))
    sides = (usable[max(0, pos - 12):pos][::-1], usable[pos:pos + 13])
    for side in sides:
        idx = np.array([int(j) for j in side if j != i and j not in skip][:6])
        if idx.size < 6:
            continue
        xs = (x[idx] - x[i]) / max(float(np.ptp(x[idx])), 1e-300)
        try:
            w = np.linalg.solve(np.vander(xs, 6, increasing=True).T, np.eye(6)[0])
        except np.linalg.LinAlgError:
            continue
        best = min(best, abs(float(y[i] - w @ y[idx])))
    return best


def quintic_loo(x: NDArray[np.float64], y: NDArray[np.float64], usable: NDArray[np.int64],
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


#: a confirmed outlier misses its local quintic prediction by more than these multiples
#: of the median and of the largest miss at its +-3 neighbours (the lift's own
#: interpolation error there); (noisy table, exact table)
NEIGHBOUR_FACTORS = ((4.0, 2.0), (8.0, 4.0))


def _quintic_confirms(x: NDArray[np.float64], y: NDArray[np.float64],
                      cand: NDArray[np.int64], excluded: NDArray[np.bool_], tol: float,
                      floor: float, exact: bool = False) -> NDArray[np.bool_]:
    """For each candidate i: does y_i differ from the local quintic leave-one-out
    prediction by more than ``tol`` x its noise factor, than ``floor``, and than 4 x
    the same prediction error at its neighbours (i +- 1, i +- 2, each without i)? The
    last test tells a spike from lift that the sampling does not resolve."""
    ok = np.ones(cand.size, dtype=bool)
    usable = np.flatnonzero(~excluded)
    others = tuple(int(c) for c in cand)          # other candidates stay out of stencils
    for k, i in enumerate(cand):
        own = quintic_loo(x, y, usable, int(i), others)
        if own is None:
            continue
        near = [j for j in (i - 3, i - 2, i - 1, i + 1, i + 2, i + 3)
                if 0 <= j < x.size and not excluded[j] and j not in others]
        local = [(quintic_loo(x, y, usable, j, (j,) + others), j) for j in near]
        errs = [v[0] for v, _ in local if v is not None] or [0.0]
        if exact:
            # no noise to amplify: one-sided stencils may avoid a junction of the law
            own = (min(own[0], _one_sided_miss(x, y, usable, int(i), others)), own[1])
            errs = [min(v[0], _one_sided_miss(x, y, usable, j, (j,) + others))
                    for v, j in local if v is not None] or [0.0]
        med, top = NEIGHBOUR_FACTORS[int(exact)]
        scale = max(med * float(np.median(errs)), top * max(errs))
        ok[k] = own[0] > max(tol * own[1], floor * (EXACT_FLOOR if exact else 1.0), scale)
    return ok
