"""A lift law from tables of its jets (h, h', h'', h''' on a grid): the degree-7
Hermite interpolant of the four columns, C3 and exact at the nodes. The same degree-7
Hermite form carries the cam input of the valve-train models (``valve_train.cam_input``)
and the lobe law of a reconstructed profile (``lift_table.lobe_table.lobe_from_jets``).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw

DEGREE = 7


def _hermite_matrix() -> NDArray[np.float64]:
    """Inverse of the map from monomial coefficients to end derivatives (0..3)."""
    rows = []
    for at in (0.0, 1.0):
        for d in range(4):
            row = []
            for j in range(DEGREE + 1):
                if j < d:
                    row.append(0.0)
                else:
                    row.append(math.perm(j, d) * at ** (j - d))
            rows.append(row)
    return np.linalg.inv(np.array(rows))


HERMITE_INV = _hermite_matrix()


class JetTableLift(LiftLaw):
    """A lift from tables of h, h', h'', h''' on a grid (e.g. /reconstruction/profile):
    the degree-7 Hermite interpolant of the four columns (C3, exact at the nodes).

    The support is the contiguous run of samples around the maximum where h exceeds
    ``trim`` times the maximum lift (plus two grid steps): a measured table over the whole
    revolution then still has a base circle, and its ripple there (noise, smoothing
    residue) is dropped. The cut is a step of at most trim * max lift in h (8 um for an
    8 mm lobe at the default 1e-3), far below the lash at the valve.
    """

    continuity_order = 3

    def __init__(self, alpha: NDArray[np.float64], jets: NDArray[np.float64], *,
                 key: str = 'profile', trim: float = 1e-3) -> None:
        from scipy.interpolate import PPoly

        a = np.asarray(alpha, dtype=float)
        j = np.asarray(jets, dtype=float)
        if a.ndim != 1 or a.size < 4 or j.shape != (4, a.size):
            raise InputError(f'{key}.alpha_rad', a.shape, 'a 1-D grid and 4 columns of '
                             'h, h\', h\'\', h\'\'\' of the same length (>= 4)')
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(j))):
            raise InputError(key, 'non-finite values', 'finite numbers')
        if np.any(np.diff(a) <= 0):
            raise InputError(f'{key}.alpha_rad', 'not increasing', 'increasing angles')
        hmax = float(np.max(j[0]))
        if hmax <= 0:
            raise InputError(f'{key}.lift_m', hmax, 'a lobe with positive lift')
        top = int(np.argmax(j[0]))
        low = j[0] <= trim * hmax
        before = np.nonzero(low[:top])[0]
        after = np.nonzero(low[top:])[0]
        i0 = max(int(before[-1]) - 2, 0) if before.size else 0
        i1 = min(top + int(after[0]) + 2, a.size - 1) if after.size else a.size - 1
        self.alpha = a[i0:i1 + 1]
        self.jets = j[:, i0:i1 + 1]
        lengths = np.diff(self.alpha)
        scale = np.stack([lengths ** d for d in range(4)])
        ends = np.concatenate([self.jets[:, :-1] * scale, self.jets[:, 1:] * scale])
        sig = HERMITE_INV @ ends                                  # (8, n) in sigma
        local = sig / lengths[None, :] ** np.arange(DEGREE + 1)[:, None]
        self._poly = PPoly(local[::-1], self.alpha, extrapolate=False)
        self._derivs = [self._poly] + [self._poly.derivative(n) for n in (1, 2, 3)]

    @property
    def support(self) -> tuple[float, float]:
        return float(self.alpha[0]), float(self.alpha[-1])

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        return self._derivs[nu](alpha)
